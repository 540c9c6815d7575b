/* parts.c - Col / NCol facet components of the partition (paper 003,
 * section 4.1): the nsdf threshold, edge-connected components per class,
 * small components merged into the neighbour with the longest shared
 * boundary, and each part's figures (area, centroid, PCA axis, base,
 * radius).  docs/hybrid.md, "Partition".
 */
#include "engine/hybrid/hybrid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

/* ---- figures of every part from facet_part and facet_nbr ---- */

/* Per-part accumulators of one figures pass. */
struct acc {
	double area, wsum[3], w2[6]; /* area, area-weighted centroid sums, second moments */
	double blen, bmid[3];        /* boundary length, length-weighted midpoint sums */
};

static struct vec3 corner(const struct mesh *m, size_t f, int k)
{
	return m->v[m->tri[3 * f + (size_t)k]];
}

static double facet_area(const struct mesh *m, size_t f, struct vec3 *centroid)
{
	struct vec3 a = corner(m, f, 0), b = corner(m, f, 1), c = corner(m, f, 2);

	*centroid = v3_scale(v3_add(v3_add(a, b), c), 1.0 / 3);
	return 0.5 * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

/* Eigenvector of the largest eigenvalue of the symmetric 3x3 s (xx, yy,
 * zz, xy, xz, yz) by cyclic Jacobi rotations; zero matrix: +x. */
static struct vec3 principal_axis(const double s6[6])
{
	double a[3][3] = {{s6[0], s6[3], s6[4]}, {s6[3], s6[1], s6[5]}, {s6[4], s6[5], s6[2]}};
	double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
	int best = 0;

	for (int sweep = 0; sweep < 50; sweep++) {
		double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
		double scale = fabs(a[0][0]) + fabs(a[1][1]) + fabs(a[2][2]);
		if (off <= 1e-15 * scale || off == 0)
			break;
		for (int p = 0; p < 2; p++)
			for (int q = p + 1; q < 3; q++) {
				double th, t, c, s;
				if (a[p][q] == 0)
					continue;
				th = (a[q][q] - a[p][p]) / (2 * a[p][q]);
				t = (th >= 0 ? 1 : -1) / (fabs(th) + sqrt(th * th + 1));
				c = 1 / sqrt(t * t + 1);
				s = t * c;
				for (int k = 0; k < 3; k++) { /* a = a J */
					double akp = a[k][p], akq = a[k][q];
					a[k][p] = c * akp - s * akq;
					a[k][q] = s * akp + c * akq;
				}
				for (int k = 0; k < 3; k++) { /* a = J^T a */
					double apk = a[p][k], aqk = a[q][k];
					a[p][k] = c * apk - s * aqk;
					a[q][k] = s * apk + c * aqk;
				}
				for (int k = 0; k < 3; k++) { /* v = v J */
					double vkp = v[k][p], vkq = v[k][q];
					v[k][p] = c * vkp - s * vkq;
					v[k][q] = s * vkp + c * vkq;
				}
			}
	}
	for (int k = 1; k < 3; k++)
		if (a[k][k] > a[best][best])
			best = k;
	return v3_normalize(v3(v[0][best], v[1][best], v[2][best]));
}

/* Recompute every figure except cls and sdf_mean_mm from facet_part and
 * facet_nbr.  acc: ps->n scratch entries.  O(nt + n^2). */
static void compute_figures(struct hy_parts *ps, const struct mesh *m, struct acc *acc)
{
	size_t n = ps->n, f, i;

	memset(acc, 0, n * sizeof *acc);
	memset(ps->shared_mm, 0, n * n * sizeof *ps->shared_mm);
	for (i = 0; i < n; i++)
		ps->p[i].facets = 0;
	for (f = 0; f < ps->nt; f++) {
		uint32_t pf = ps->facet_part[f];
		struct acc *a = &acc[pf];
		struct vec3 c;
		double w = facet_area(m, f, &c);
		ps->p[pf].facets++;
		a->area += w;
		a->wsum[0] += w * c.x;
		a->wsum[1] += w * c.y;
		a->wsum[2] += w * c.z;
		a->w2[0] += w * c.x * c.x;
		a->w2[1] += w * c.y * c.y;
		a->w2[2] += w * c.z * c.z;
		a->w2[3] += w * c.x * c.y;
		a->w2[4] += w * c.x * c.z;
		a->w2[5] += w * c.y * c.z;
		for (int k = 0; k < 3; k++) {
			uint32_t g = ps->facet_nbr[3 * f + (size_t)k], pg;
			struct vec3 p0, p1, mid;
			double len;
			/* each shared edge once, from its lower facet */
			if (g == MESH_NO_FACET || g < f || (pg = ps->facet_part[g]) == pf)
				continue;
			p0 = corner(m, f, k);
			p1 = corner(m, f, (k + 1) % 3);
			len = v3_dist(p0, p1);
			mid = v3_scale(v3_add(p0, p1), 0.5);
			ps->shared_mm[pf * n + pg] += len;
			ps->shared_mm[pg * n + pf] += len;
			for (int s = 0; s < 2; s++) {
				struct acc *b = &acc[s ? pg : pf];
				b->blen += len;
				b->bmid[0] += len * mid.x;
				b->bmid[1] += len * mid.y;
				b->bmid[2] += len * mid.z;
			}
		}
	}
	for (i = 0; i < n; i++) {
		struct hy_part *p = &ps->p[i];
		struct acc *a = &acc[i];
		double A = a->area > 0 ? a->area : 1, cov[6], best = 0;
		struct vec3 mu = v3(a->wsum[0] / A, a->wsum[1] / A, a->wsum[2] / A);
		cov[0] = a->w2[0] / A - mu.x * mu.x;
		cov[1] = a->w2[1] / A - mu.y * mu.y;
		cov[2] = a->w2[2] / A - mu.z * mu.z;
		cov[3] = a->w2[3] / A - mu.x * mu.y;
		cov[4] = a->w2[4] / A - mu.x * mu.z;
		cov[5] = a->w2[5] / A - mu.y * mu.z;
		p->area_mm2 = a->area;
		p->centroid_mm = mu;
		p->axis = principal_axis(cov);
		p->base_mm = a->blen > 0 ? v3(a->bmid[0] / a->blen, a->bmid[1] / a->blen,
					      a->bmid[2] / a->blen)
					 : mu;
		if (a->blen > 0) {
			if (v3_dot(p->axis, v3_sub(mu, p->base_mm)) < 0)
				p->axis = v3_scale(p->axis, -1);
		} else {
			double ax = fabs(p->axis.x), ay = fabs(p->axis.y), az = fabs(p->axis.z);
			double big = az >= ax && az >= ay ? p->axis.z : ay >= ax ? p->axis.y : p->axis.x;
			if (big < 0)
				p->axis = v3_scale(p->axis, -1);
		}
		p->neighbour = -1;
		for (size_t j = 0; j < n; j++)
			if (j != i && ps->shared_mm[i * n + j] > best) {
				best = ps->shared_mm[i * n + j];
				p->neighbour = (int)j;
			}
		p->radius_mm = 0;
		p->length_mm = 0;
	}
	/* second pass: distances from the axis lines, now that they are known */
	for (f = 0; f < ps->nt; f++) {
		uint32_t pf = ps->facet_part[f];
		struct hy_part *p = &ps->p[pf];
		for (int k = 0; k < 3; k++) {
			struct vec3 q = v3_sub(corner(m, f, k), p->base_mm);
			double t = v3_dot(q, p->axis);
			uint32_t g = ps->facet_nbr[3 * f + (size_t)k];
			if (t > p->length_mm)
				p->length_mm = t;
			if (g != MESH_NO_FACET && ps->facet_part[g] != pf) {
				/* both ends of a boundary edge: corner k and k + 1 */
				for (int s = 0; s < 2; s++) {
					struct vec3 r = v3_sub(corner(m, f, (k + s) % 3), p->base_mm);
					double d = v3_len(v3_madd(r, p->axis, -v3_dot(r, p->axis)));
					if (d > p->radius_mm)
						p->radius_mm = d;
				}
			}
		}
	}
}

/* ---- components and the small-component merge ---- */

struct nbr {
	uint32_t other; /* component */
	double len_mm;  /* shared boundary */
};

struct comp {
	double area_mm2;
	int cls;
	uint32_t into;   /* itself while live, else the component it joined */
	struct nbr *nb;  /* owned */
	size_t nn, cap;
};

static uint32_t comp_find(const struct comp *c, uint32_t i)
{
	while (c[i].into != i)
		i = c[i].into;
	return i;
}

/* Add len to the entry of `other` in c's list (appending it).  0 or ERR_NOMEM. */
static int nbr_add(struct comp *c, uint32_t other, double len)
{
	for (size_t i = 0; i < c->nn; i++)
		if (c->nb[i].other == other) {
			c->nb[i].len_mm += len;
			return 0;
		}
	if (mem_grow((void **)&c->nb, &c->cap, c->nn + 1, sizeof *c->nb))
		return ERR_NOMEM;
	c->nb[c->nn].other = other;
	c->nb[c->nn].len_mm = len;
	c->nn++;
	return 0;
}

static void nbr_remove(struct comp *c, uint32_t other)
{
	for (size_t i = 0; i < c->nn; i++)
		if (c->nb[i].other == other) {
			c->nb[i] = c->nb[--c->nn];
			return;
		}
}

/* Merge component b into a: lists joined, b's neighbours re-pointed. */
static int comp_join(struct comp *c, uint32_t a, uint32_t b)
{
	struct comp *cb = &c[b];

	for (size_t i = 0; i < cb->nn; i++) {
		uint32_t x = cb->nb[i].other;
		double len = cb->nb[i].len_mm;
		if (x == a)
			continue;
		nbr_remove(&c[x], b);
		if (nbr_add(&c[x], a, len) || nbr_add(&c[a], x, len))
			return ERR_NOMEM;
	}
	nbr_remove(&c[a], b);
	c[a].area_mm2 += cb->area_mm2;
	cb->into = a;
	mem_free(cb->nb);
	cb->nb = NULL;
	cb->nn = cb->cap = 0;
	return 0;
}

struct order {
	double area;
	uint32_t comp;
};

static int cmp_order(const void *x, const void *y)
{
	const struct order *a = x, *b = y;

	if (a->area != b->area)
		return a->area > b->area ? -1 : 1;
	return (a->comp > b->comp) - (a->comp < b->comp);
}

static int alloc_figures(struct hy_parts *ps, size_t n, struct acc **acc)
{
	ps->p = mem_calloc(n ? n : 1, sizeof *ps->p);
	ps->shared_mm = n ? mem_realloc_array(NULL, n * n, sizeof *ps->shared_mm)
			  : mem_alloc(sizeof *ps->shared_mm);
	*acc = mem_calloc(n ? n : 1, sizeof **acc);
	return ps->p && ps->shared_mm && *acc ? 0 : ERR_NOMEM;
}

int hy_parts_build(const struct mesh *m, const double *nsdf, const double *sdf_mm,
		   double threshold, double min_area_frac, struct hy_parts *out,
		   struct err *e)
{
	struct hy_parts ps;
	struct comp *comps = NULL;
	struct order *ord = NULL;
	struct acc *acc = NULL;
	uint32_t *comp_of = NULL, *stack = NULL, *part_of = NULL;
	double total = 0, *sdf_sum = NULL;
	size_t ncomp = 0, nlive = 0, f, i;
	int rc = 0;

	memset(out, 0, sizeof *out);
	memset(&ps, 0, sizeof ps);
	if (!(min_area_frac >= 0 && min_area_frac < 1))
		return ERR_FIELD(e, "min_area_frac", "small-part fraction must be in [0, 1), not %g",
				 min_area_frac);
	if (m->nt >= UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "%zu facets: too many to partition", m->nt);
	ps.nt = m->nt;
	ps.facet_part = mem_alloc((m->nt ? m->nt : 1) * sizeof *ps.facet_part);
	ps.facet_nbr = mem_alloc((m->nt ? 3 * m->nt : 1) * sizeof *ps.facet_nbr);
	comp_of = mem_alloc((m->nt ? m->nt : 1) * sizeof *comp_of);
	stack = mem_alloc((m->nt ? m->nt : 1) * sizeof *stack);
	if (!ps.facet_part || !ps.facet_nbr || !comp_of || !stack)
		goto nomem;
	if ((rc = mesh_facet_neighbours(m, ps.facet_nbr, e)))
		goto out;

	/* components of each class: depth-first over same-class neighbours */
	for (f = 0; f < m->nt; f++)
		comp_of[f] = UINT32_MAX;
	for (f = 0; f < m->nt; f++) {
		size_t sp = 0;
		int cls = nsdf[f] < threshold ? HY_COL : HY_NCOL;
		if (comp_of[f] != UINT32_MAX)
			continue;
		comp_of[f] = (uint32_t)ncomp;
		stack[sp++] = (uint32_t)f;
		while (sp) {
			uint32_t g = stack[--sp];
			for (int k = 0; k < 3; k++) {
				uint32_t h = ps.facet_nbr[3 * (size_t)g + (size_t)k];
				if (h == MESH_NO_FACET || comp_of[h] != UINT32_MAX ||
				    (nsdf[h] < threshold ? HY_COL : HY_NCOL) != cls)
					continue;
				comp_of[h] = (uint32_t)ncomp;
				stack[sp++] = h;
			}
		}
		ncomp++;
	}
	comps = mem_calloc(ncomp ? ncomp : 1, sizeof *comps);
	if (!comps)
		goto nomem;
	for (i = 0; i < ncomp; i++)
		comps[i].into = (uint32_t)i;
	for (f = 0; f < m->nt; f++) {
		struct comp *c = &comps[comp_of[f]];
		struct vec3 cen;
		double w = facet_area(m, f, &cen);
		c->area_mm2 += w;
		c->cls = nsdf[f] < threshold ? HY_COL : HY_NCOL;
		total += w;
		for (int k = 0; k < 3; k++) {
			uint32_t g = ps.facet_nbr[3 * f + (size_t)k];
			double len;
			if (g == MESH_NO_FACET || g < f || comp_of[g] == comp_of[f])
				continue;
			len = v3_dist(corner(m, f, k), corner(m, f, (k + 1) % 3));
			if (nbr_add(c, comp_of[g], len) || nbr_add(&comps[comp_of[g]], comp_of[f], len))
				goto nomem;
		}
	}

	/* smallest small component first, into its longest-boundary
	 * neighbour, until none is left (each pass O(c)) */
	for (;;) {
		uint32_t small = UINT32_MAX, into = UINT32_MAX;
		double best = 0;
		for (i = 0; i < ncomp; i++) {
			const struct comp *c = &comps[i];
			if (c->into != i || c->nn == 0 || c->area_mm2 >= min_area_frac * total)
				continue;
			if (small == UINT32_MAX || c->area_mm2 < comps[small].area_mm2)
				small = (uint32_t)i;
		}
		if (small == UINT32_MAX)
			break;
		for (i = 0; i < comps[small].nn; i++) {
			const struct nbr *b = &comps[small].nb[i];
			if (into == UINT32_MAX || b->len_mm > best ||
			    (b->len_mm == best && b->other < into)) {
				best = b->len_mm;
				into = b->other;
			}
		}
		if (comp_join(comps, into, small))
			goto nomem;
	}

	/* live components by decreasing area become the parts */
	for (i = 0; i < ncomp; i++)
		nlive += comps[i].into == i;
	ord = mem_alloc((nlive ? nlive : 1) * sizeof *ord);
	part_of = mem_alloc((ncomp ? ncomp : 1) * sizeof *part_of);
	if (!ord || !part_of)
		goto nomem;
	nlive = 0;
	for (i = 0; i < ncomp; i++)
		if (comps[i].into == i) {
			ord[nlive].area = comps[i].area_mm2;
			ord[nlive++].comp = (uint32_t)i;
		}
	qsort(ord, nlive, sizeof *ord, cmp_order);
	for (i = 0; i < nlive; i++)
		part_of[ord[i].comp] = (uint32_t)i;
	ps.n = nlive;
	if (alloc_figures(&ps, nlive, &acc))
		goto nomem;
	sdf_sum = mem_calloc(nlive ? nlive : 1, sizeof *sdf_sum);
	if (!sdf_sum)
		goto nomem;
	for (i = 0; i < nlive; i++)
		ps.p[i].cls = comps[ord[i].comp].cls;
	for (f = 0; f < m->nt; f++) {
		struct vec3 cen;
		uint32_t p = part_of[comp_find(comps, comp_of[f])];
		ps.facet_part[f] = p;
		sdf_sum[p] += facet_area(m, f, &cen) * sdf_mm[f];
	}
	compute_figures(&ps, m, acc);
	for (i = 0; i < nlive; i++)
		ps.p[i].sdf_mean_mm = ps.p[i].area_mm2 > 0 ? sdf_sum[i] / ps.p[i].area_mm2 : 0;
	*out = ps;
	memset(&ps, 0, sizeof ps);
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "out of memory partitioning %zu facets", m->nt);
out:
	for (i = 0; comps && i < ncomp; i++)
		mem_free(comps[i].nb);
	mem_free(comps);
	mem_free(ord);
	mem_free(acc);
	mem_free(comp_of);
	mem_free(stack);
	mem_free(part_of);
	mem_free(sdf_sum);
	hy_parts_fini(&ps);
	return rc;
}

int hy_parts_merge(struct hy_parts *ps, const struct mesh *m, size_t a, size_t b,
		   struct err *e)
{
	struct acc *acc;
	double area;
	size_t f;

	if (a >= ps->n || b >= ps->n || a == b)
		return ERR_SET(e, ERR_PARAM, "merge of parts %zu and %zu of %zu", a, b, ps->n);
	if (m->nt != ps->nt)
		return ERR_SET(e, ERR_PARAM, "mesh of %zu facets for parts of %zu", m->nt, ps->nt);
	acc = mem_alloc(ps->n * sizeof *acc);
	if (!acc)
		return ERR_SET(e, ERR_NOMEM, "out of memory merging parts");
	area = ps->p[a].area_mm2 + ps->p[b].area_mm2;
	ps->p[a].sdf_mean_mm = area > 0 ? (ps->p[a].sdf_mean_mm * ps->p[a].area_mm2 +
					   ps->p[b].sdf_mean_mm * ps->p[b].area_mm2) / area
					: ps->p[a].sdf_mean_mm;
	for (f = 0; f < ps->nt; f++) {
		uint32_t p = ps->facet_part[f];
		if (p == b)
			p = (uint32_t)a;
		ps->facet_part[f] = p > b ? p - 1 : p;
	}
	memmove(ps->p + b, ps->p + b + 1, (ps->n - b - 1) * sizeof *ps->p);
	ps->n--;
	/* shared_mm shrinks in place: (n - 1)^2 <= n^2 */
	compute_figures(ps, m, acc);
	mem_free(acc);
	return 0;
}

void hy_parts_merge_remap(size_t n, size_t a, size_t b, int *remap)
{
	for (size_t i = 0; i < n; i++) {
		size_t j = i == b ? a : i;
		remap[i] = (int)(j > b ? j - 1 : j);
	}
}

void hy_parts_fini(struct hy_parts *ps)
{
	if (!ps)
		return;
	mem_free(ps->facet_part);
	mem_free(ps->p);
	mem_free(ps->shared_mm);
	mem_free(ps->facet_nbr);
	memset(ps, 0, sizeof *ps);
}
