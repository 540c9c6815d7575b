/* support.c - self-supporting metrics and vertex position optimisation
 * (paper 000 section 5.2, eq. 11-17, Appendix II).
 *
 * theta = angle between a strut and the print direction +z, in [0, pi/2]
 * (a strut has no direction).  A strut is self-supported when theta <=
 * alpha.  g(theta) is the risky fraction of its projected area: eq. 12's
 * polynomial for alpha = 45 deg, else eq. 20 integrated numerically.
 * Gamma (eq. 13) = sum r L g / sum r L, Psi (eq. 14) = length fraction of
 * supported struts; both with one radius for all struts (Table 3).
 */
#include "engine/lattice/gen.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/core/rng.h"
#include "engine/geom/polytope.h"

#include <math.h>
#include <string.h>

static const double G_POLY[6] = {-0.02, -0.31, 1.44, -1.11, 0.58, -0.16};

static int is_45(double alpha)
{
	return fabs(alpha - M_PI / 4) < 1e-9;
}

/* Appendix II, eq. 20: risky arc fraction of the cylinder's projected
 * bottom ellipse (axes 1 and cos theta); arc element
 * sqrt(sin^2 phi + cos^2 theta cos^2 phi), risky where phi > phi0 =
 * asin(sin alpha / sin theta).  Simpson, 128 panels. */
static double g_exact(double theta, double alpha)
{
	double st = sin(theta), ct = cos(theta), phi0, num = 0, den = 0;
	const int n = 128;

	if (st <= sin(alpha))
		return 0;
	phi0 = asin(sin(alpha) / st);
	for (int i = 0; i <= n; i++) {
		double w = (i == 0 || i == n) ? 1 : (i & 1) ? 4 : 2;
		double a = M_PI / 2 * i / n, b = phi0 + (M_PI / 2 - phi0) * i / n;
		den += w * sqrt(sin(a) * sin(a) + ct * ct * cos(a) * cos(a));
		num += w * sqrt(sin(b) * sin(b) + ct * ct * cos(b) * cos(b));
	}
	return (num * (M_PI / 2 - phi0)) / (den * (M_PI / 2));
}

double lattice_support_g(double theta, double alpha)
{
	double t = 1, g = 0;

	if (theta <= alpha)
		return 0;
	if (!is_45(alpha))
		return g_exact(theta, alpha);
	for (int i = 0; i < 6; i++) {
		g += G_POLY[i] * t;
		t *= theta;
	}
	return g;
}

/* dg/dtheta (0 where g is 0). */
static double support_dg(double theta, double alpha)
{
	double t = 1, d = 0;

	if (theta <= alpha)
		return 0;
	if (!is_45(alpha)) {
		double h = 1e-5;
		return (g_exact(fmin(theta + h, M_PI / 2), alpha) - g_exact(theta - h, alpha)) /
		       (fmin(theta + h, M_PI / 2) - (theta - h));
	}
	for (int i = 1; i < 6; i++) {
		d += i * G_POLY[i] * t;
		t *= theta;
	}
	return d;
}

static double edge_theta(struct vec3 a, struct vec3 b, double *len)
{
	struct vec3 d = v3_sub(b, a);
	double l = v3_len(d);

	*len = l;
	return l > 0 ? acos(fmin(1, fabs(d.z) / l)) : 0;
}

/* Length sums of eq. 13-14: total, supported, and weighted by g. */
struct support_sums {
	double lt, ls, lg;
};

static void sums_add(struct support_sums *u, struct vec3 a, struct vec3 b, double alpha)
{
	double l, th = edge_theta(a, b, &l);

	u->lt += l;
	if (th <= alpha)
		u->ls += l;
	else
		u->lg += l * lattice_support_g(th, alpha);
}

static void sums_finish(const struct support_sums *u, struct lattice_support_metrics *m)
{
	m->gamma = u->lt > 0 ? u->lg / u->lt : 0;
	m->psi = u->lt > 0 ? u->ls / u->lt : 0;
}

void lattice_support_measure(const struct lattice_tetmesh *t, double alpha,
			     struct lattice_support_metrics *m)
{
	struct support_sums u = {0, 0, 0};
	uint32_t *ed = NULL;
	size_t ne = 0;

	memset(m, 0, sizeof *m);
	if (lattice_tetmesh_edges(t, &ed, &ne, NULL) == 0)
		for (size_t i = 0; i < ne; i++)
			sums_add(&u, t->p[ed[2 * i]], t->p[ed[2 * i + 1]], alpha);
	mem_free(ed);
	sums_finish(&u, m);
}

void lattice_support_measure_lattice(const struct lattice *q, double alpha,
				     struct lattice_support_metrics *m)
{
	struct support_sums u = {0, 0, 0};

	for (size_t i = 0; i < q->nedges; i++)
		sums_add(&u, q->node[q->edge[i].a], q->node[q->edge[i].b], alpha);
	sums_finish(&u, m);
}

/* ---- PO ---- */

struct csr {
	size_t *start; /* n + 1 */
	uint32_t *v;
};

static void csr_free(struct csr *c)
{
	mem_free(c->start);
	mem_free(c->v);
}

/* node -> incident items; pairs (node, item) given by get(i, k). */
static int csr_build(size_t nnodes, size_t nitems, int per, const uint32_t *nodes,
		     struct csr *c)
{
	size_t total = nitems * (size_t)per;

	c->start = mem_calloc(nnodes + 1, sizeof *c->start);
	c->v = mem_alloc((total ? total : 1) * sizeof *c->v);
	if (!c->start || !c->v)
		return ERR_NOMEM;
	for (size_t i = 0; i < total; i++)
		c->start[nodes[i] + 1]++;
	for (size_t i = 0; i < nnodes; i++)
		c->start[i + 1] += c->start[i];
	{
		size_t *fill = mem_alloc((nnodes ? nnodes : 1) * sizeof *fill);
		if (!fill)
			return ERR_NOMEM;
		memcpy(fill, c->start, nnodes * sizeof *fill);
		for (size_t i = 0; i < total; i++)
			c->v[fill[nodes[i]]++] = (uint32_t)(i / (size_t)per);
		mem_free(fill);
	}
	return 0;
}

/* J(v) of eq. 16 with one radius: sum L g / sum L over the node's edges;
 * grad (may be NULL) by the chain rule through L and theta. */
static double objective(const struct vec3 *p, const uint32_t *ed, const struct csr *ve,
			uint32_t v, struct vec3 pos, double alpha, struct vec3 *grad)
{
	double N = 0, D = 0;
	struct vec3 dN = v3(0, 0, 0), dD = v3(0, 0, 0);

	for (size_t k = ve->start[v]; k < ve->start[v + 1]; k++) {
		uint32_t e = ve->v[k], u = ed[2 * e] == v ? ed[2 * e + 1] : ed[2 * e];
		struct vec3 d = v3_sub(pos, p[u]);
		double L = v3_len(d), c, th, g, st;
		struct vec3 dh;

		if (!(L > 0))
			continue;
		c = fmin(1, fabs(d.z) / L);
		th = acos(c);
		g = lattice_support_g(th, alpha);
		N += L * g;
		D += L;
		if (!grad)
			continue;
		dh = v3_scale(d, 1 / L);
		dD = v3_add(dD, dh);
		dN = v3_add(dN, v3_scale(dh, g));
		st = sin(th);
		if (st > 1e-9 && th > alpha) {
			double s = d.z > 0 ? 1 : d.z < 0 ? -1 : 0;
			/* dtheta/dv = -(s z - c dh) / (L sin theta) */
			struct vec3 dth = v3_scale(v3_sub(v3(0, 0, s), v3_scale(dh, c)), -1 / (L * st));
			dN = v3_add(dN, v3_scale(dth, L * support_dg(th, alpha)));
		}
	}
	if (!(D > 0)) {
		if (grad)
			*grad = v3(0, 0, 0);
		return 0;
	}
	if (grad)
		*grad = v3_scale(v3_sub(v3_scale(dN, D), v3_scale(dD, N)), 1 / (D * D));
	return N / D;
}

static double signed_volume(struct vec3 a, struct vec3 b, struct vec3 c, struct vec3 d)
{
	return v3_dot(v3_sub(b, a), v3_cross(v3_sub(c, a), v3_sub(d, a))) / 6;
}

/* Every tet around v keeps a positive volume with v at pos. */
static int star_valid(const struct lattice_tetmesh *t, const struct csr *vt, uint32_t v,
		      struct vec3 pos)
{
	for (size_t k = vt->start[v]; k < vt->start[v + 1]; k++) {
		const uint32_t *q = t->tet + 4 * vt->v[k];
		struct vec3 c[4];
		double ref;
		for (int i = 0; i < 4; i++)
			c[i] = q[i] == v ? pos : t->p[q[i]];
		ref = signed_volume(t->p[q[0]], t->p[q[1]], t->p[q[2]], t->p[q[3]]);
		if (!(signed_volume(c[0], c[1], c[2], c[3]) > 1e-6 * fabs(ref)))
			return 0;
	}
	return 1;
}

/* Inscribed sphere of the star's kernel: each tet's face opposite v gives
 * a half-space on v's side. */
static int star_sphere(const struct lattice_tetmesh *t, const struct csr *vt, uint32_t v,
		       struct vec3 *nrm, double *dd, struct vec3 *o, double *tau)
{
	size_t m = 0;
	double span = 0;

	for (size_t k = vt->start[v]; k < vt->start[v + 1] && m < 512; k++) {
		const uint32_t *q = t->tet + 4 * vt->v[k];
		struct vec3 f[3], nn;
		int j = 0;
		for (int i = 0; i < 4; i++)
			if (q[i] != v)
				f[j++] = t->p[q[i]];
		if (j != 3)
			return -1;
		nn = v3_cross(v3_sub(f[1], f[0]), v3_sub(f[2], f[0]));
		if (v3_dot(nn, v3_sub(t->p[v], f[0])) > 0)
			nn = v3_scale(nn, -1); /* point away from v */
		nrm[m] = nn;
		dd[m] = v3_dot(nn, f[0]);
		span = fmax(span, v3_dist(f[0], t->p[v]));
		m++;
	}
	if (m < 4)
		return -1;
	return geom_chebyshev_center(nrm, dd, m, t->p[v], 2 * span + 1e-9, o, tau);
}

/* Gamma and Psi over an edge list (pairs into t->p). */
static void measure_list(const struct lattice_tetmesh *t, const uint32_t *ed, size_t ne,
			 double alpha, struct lattice_support_metrics *m)
{
	struct support_sums u = {0, 0, 0};

	for (size_t i = 0; i < ne; i++)
		sums_add(&u, t->p[ed[2 * i]], t->p[ed[2 * i + 1]], alpha);
	sums_finish(&u, m);
}

int lattice_po_optimize(struct lattice_tetmesh *t, const struct lattice_po_opts *o,
			struct lattice_po_stats *st, struct err *e)
{
	uint32_t *ed = NULL, *order = NULL;
	size_t ne = 0, ninterior = 0;
	struct csr ve = {0}, vt = {0};
	struct vec3 *nrm = NULL;
	double *dd = NULL;
	struct rng rg;
	struct lattice_support_metrics m;
	int rc;

	memset(st, 0, sizeof *st);
	if ((rc = lattice_tetmesh_edges(t, &ed, &ne, e)) != 0)
		return rc;
	measure_list(t, ed, ne, o->alpha, &m);
	st->gamma_before = st->gamma_after = m.gamma;
	order = mem_alloc((t->np ? t->np : 1) * sizeof *order);
	nrm = mem_alloc(512 * sizeof *nrm);
	dd = mem_alloc(512 * sizeof *dd);
	if (!order || !nrm || !dd || csr_build(t->np, ne, 2, ed, &ve) ||
	    csr_build(t->np, t->nt, 4, t->tet, &vt)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for vertex optimisation");
		goto out;
	}
	for (size_t i = 0; i < t->np; i++)
		if (!t->fixed[i])
			order[ninterior++] = (uint32_t)i;
	rng_seed(&rg, o->seed);
	for (int round = 0; round < o->max_rounds; round++) {
		size_t moved = 0;
		double gamma_prev = st->gamma_after;

		/* random order (Fisher-Yates) */
		for (size_t i = ninterior; i > 1; i--) {
			size_t j = (size_t)rng_below(&rg, i);
			uint32_t x = order[i - 1];
			order[i - 1] = order[j];
			order[j] = x;
		}
		for (size_t oi = 0; oi < ninterior; oi++) {
			uint32_t v = order[oi];
			struct vec3 grad, c, dir;
			double J, tau, gl, step;

			J = objective(t->p, ed, &ve, v, t->p[v], o->alpha, &grad);
			gl = v3_len(grad);
			if (!(J > 0) || !(gl > 0))
				continue;
			if (star_sphere(t, &vt, v, nrm, dd, &c, &tau) != 0 || !(tau > 0))
				continue;
			tau *= 0.98; /* stay off the kernel's faces */
			dir = v3_scale(grad, -1 / gl);
			for (step = 2 * tau; step > tau * 1e-3; step *= 0.5) {
				struct vec3 cand = v3_madd(t->p[v], dir, step), off = v3_sub(cand, c);
				double ol = v3_len(off);
				if (ol > tau)
					cand = v3_madd(c, off, tau / ol); /* project into the sphere */
				if (objective(t->p, ed, &ve, v, cand, o->alpha, NULL) < J - 1e-12 &&
				    star_valid(t, &vt, v, cand)) {
					t->p[v] = cand;
					moved++;
					break;
				}
			}
		}
		measure_list(t, ed, ne, o->alpha, &m);
		st->rounds = round + 1;
		st->moves += moved;
		st->gamma_after = m.gamma;
		if (o->progress &&
		    (rc = progress_update(o->progress, (double)(round + 1) / o->max_rounds, e)) != 0)
			goto out;
		/* the paper's stop rules: nothing moves / Gamma stops falling */
		if (moved == 0 || !(m.gamma < gamma_prev - 1e-7))
			break;
	}
	rc = 0;
out:
	mem_free(ed);
	mem_free(order);
	mem_free(nrm);
	mem_free(dd);
	csr_free(&ve);
	csr_free(&vt);
	return rc;
}
