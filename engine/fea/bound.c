/* bound.c - a certified lower bound on the compliance of every density
 * field between a floor and a ceiling with a given total (fea.h,
 * fea_relax_bound; docs/fea.md "Compliance bound").
 *
 * Design variable x_e in [0, 1]: rho_e = f_e + x_e (c_e - f_e) (f floor,
 * c ceiling; the budget counts rho_e as it is).  The element's SIMP
 * weight W(rho) = max(rho, rho_min)^p (the solver's clamp) is convex in
 * rho, so it lies under its chord
 *   w_e(x) = W(f_e) + x_e (W(c_e) - W(f_e))
 * and, since compliance only falls as any weight rises, the compliance
 * under the chord weights bounds that under rho^p from below.  The chord
 * weights are affine in x, so that compliance is convex in x, and for any
 * displacement field v and scalar t
 *   C(x) = max_u (2 f.u - u^T K(x) u) >= 2 t f.v - t^2 sum_e w_e(x) E_e(v),
 * E_e(v) = v_e^T K0 v_e.  Hence, for every x with sum rho <= vol,
 *   C(x) >= (f.v)^2 / M(v),  M(v) = max over those x of sum_e w_e(x) E_e(v),
 * a fractional knapsack: every element at its floor, then the budget left
 * to the elements of largest (W(c) - W(f)) E_e / (c - f) first.
 * Optimality-criteria steps on the chord problem move v towards its
 * optimum, where the bound meets that problem's compliance.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/fea/fea.h"

#define BOUND_MOVE 0.2  /* most change of a design variable per step */
#define BOUND_XMIN 1e-3 /* least design variable (the update is multiplicative) */

struct key {
	double ratio; /* weight gained per unit of material, times E_e */
	size_t e;
};

/* Per element: floor and ceiling densities, and their weights. */
struct elem {
	double f, c;   /* densities, f <= c; c = 0: no element */
	double wf, wc; /* W(f), W(c): the clamped weights */
};

/* rho_e at design variable x */
static double elem_rho(const struct elem *p, double x)
{
	return p->f + x * (p->c - p->f);
}

/* weight gained per unit of material at element energy en (c > f) */
static double elem_ratio(const struct elem *p, double en)
{
	return (p->wc - p->wf) * en / (p->c - p->f);
}

static int cmp_ratio_desc(const void *pa, const void *pb)
{
	const struct key *a = pa, *b = pb;

	if (a->ratio != b->ratio)
		return a->ratio > b->ratio ? -1 : 1;
	return a->e < b->e ? -1 : a->e > b->e;
}

/* M(v) for the element energies en. */
static double knapsack(const struct elem *el, const float *en, struct key *keys, size_t n,
		       double budget)
{
	double m = 0;
	size_t nk = 0;

	for (size_t e = 0; e < n; e++) {
		if (!(el[e].c > 0))
			continue;
		m += el[e].wf * en[e];
		if (el[e].c > el[e].f)
			keys[nk++] = (struct key){elem_ratio(&el[e], en[e]), e};
	}
	qsort(keys, nk, sizeof *keys, cmp_ratio_desc);
	for (size_t q = 0; q < nk && budget > 0; q++) {
		const struct elem *p = &el[keys[q].e];
		double take = fmin(p->c - p->f, budget);
		m += take * keys[q].ratio;
		budget -= take;
	}
	return m;
}

/* The solver runs at penal 1 on "densities" that are the chord weights. */
static void weights(const struct elem *el, const double *x, float *w, size_t n)
{
	for (size_t e = 0; e < n; e++)
		w[e] = el[e].c > 0 ? (float)(el[e].wf + x[e] * (el[e].wc - el[e].wf)) : 0;
}

static double step_value(const struct elem *p, double x, double en, double lambda)
{
	double a = fmax(BOUND_XMIN, x - BOUND_MOVE), b = fmin(1, x + BOUND_MOVE), t;

	t = p->c > p->f ? x * sqrt(elem_ratio(p, fmax(en, 0)) / lambda) : 1;
	return t < a ? a : t > b ? b : t;
}

/* Optimality criteria: x_e sqrt(-dC/dx_e / (lambda dV/dx_e)) within the
 * move limit and [XMIN, 1], lambda by bisection so that sum rho = vol. */
static void oc_step(const struct elem *el, const float *en, double *x, size_t n, double vol)
{
	double lo = 0, hi = 0;

	for (size_t e = 0; e < n; e++)
		if (el[e].c > el[e].f)
			hi = fmax(hi, elem_ratio(&el[e], en[e]));
	hi = hi > 0 ? hi * 1e6 : 1;
	for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; it++) {
		double mid = 0.5 * (lo + hi), v = 0;
		for (size_t e = 0; e < n; e++)
			if (el[e].c > 0)
				v += elem_rho(&el[e], step_value(&el[e], x[e], en[e], mid));
		if (v > vol)
			lo = mid;
		else
			hi = mid;
	}
	for (size_t e = 0; e < n; e++)
		if (el[e].c > 0)
			x[e] = step_value(&el[e], x[e], en[e], hi);
}

int fea_relax_bound(const struct fea_grid *g, const float *ceil_rho, double vol,
		    const struct fea_loads *l, const double *force, const struct fea_opts *o,
		    const struct fea_bound_opts *bo, struct fea_bound *out, struct err *e)
{
	size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
	size_t nn = (size_t)(g->nx + 1) * (size_t)(g->ny + 1) * (size_t)(g->nz + 1);
	struct fea_grid g1 = *g;
	struct fea_opts o1 = *o;
	struct fea_solver *s = NULL;
	struct fea_result res;
	struct key *keys = NULL;
	struct elem *el = NULL;
	double *x = NULL, vfloor = 0, vceil = 0, wmin = 1, t;
	double lower = 0, upper = INFINITY, solve_s = 0;
	float *w = NULL, *en = NULL;
	int rc = 0, it;

	if (bo->max_iter < 1 || !(bo->gap >= 0))
		return ERR_FIELD(e, "bound", "bound: max_iter must be >= 1 and gap >= 0");
	el = mem_calloc(n, sizeof *el);
	x = mem_alloc(n * sizeof *x);
	w = mem_alloc(n * sizeof *w);
	en = mem_alloc(n * sizeof *en);
	keys = mem_alloc(n * sizeof *keys);
	if (!el || !x || !w || !en || !keys) {
		rc = ERR_SET(e, ERR_NOMEM, "bound: out of memory for %zu elements", n);
		goto out;
	}
	for (size_t q = 0; q < n; q++) {
		double f = g->rho[q], c = ceil_rho[q];
		if (f == 0 && c == 0)
			continue; /* no element */
		if (!(f > 0) || !(f <= c) || !(c <= 1)) {
			rc = ERR_FIELD(e, "rho", "bound: element %zu needs 0 < floor (%g) <= ceiling "
				       "(%g) <= 1, or both 0", q, f, c);
			goto out;
		}
		/* volumes count the densities as they are; weights as the
		 * solver clamps them (w(rho) = max(rho, rho_min)^p is convex in
		 * rho too, so the chord between f and c still lies above it) */
		el[q] = (struct elem){f, c, pow(fmax(f, o->rho_min), o->penal),
				      pow(fmax(c, o->rho_min), o->penal)};
		wmin = el[q].wf < wmin ? el[q].wf : wmin;
		vfloor += f;
		vceil += c;
	}
	if (!(vol >= vfloor * (1 - 1e-9))) {
		rc = ERR_FIELD(e, "volume", "bound: the budget %g is below the floor's %g", vol,
			       vfloor);
		goto out;
	}
	/* start: the budget spread evenly over the room above the floor */
	t = vceil > vfloor ? (vol - vfloor) / (vceil - vfloor) : 1;
	t = t < BOUND_XMIN ? BOUND_XMIN : t > 1 ? 1 : t;
	for (size_t q = 0; q < n; q++)
		x[q] = t;
	weights(el, x, w, n);
	g1.rho = w;
	o1.penal = 1;
	o1.rho_min = wmin;
	if ((rc = fea_solver_new(&g1, l, &o1, &s, e)) != 0)
		goto out;
	if (force)
		memcpy(fea_solver_force(s), force, 3 * nn * sizeof *force);
	for (it = 0; it < bo->max_iter; it++) {
		const double *u, *f = fea_solver_force(s);
		double fu = 0, m, lb, used;
		if (it > 0) {
			oc_step(el, en, x, n, vol);
			weights(el, x, w, n);
			if ((rc = fea_solver_set_rho(s, w, e)) != 0)
				goto out;
		}
		if ((rc = fea_solve(s, &res, e)) != 0)
			goto out;
		used = 0;
		for (size_t q = 0; q < n; q++)
			if (el[q].c > 0)
				used += elem_rho(&el[q], x[q]);
		solve_s += res.solve_s;
		u = fea_displacement(s);
		for (size_t q = 0; q < 3 * nn; q++)
			fu += f[q] * u[q];
		fea_element_energy(s, en);
		m = knapsack(el, en, keys, n, vol - vfloor);
		lb = m > 0 ? fu * fu / m : 0;
		lower = lb > lower ? lb : lower;
		/* upper only from designs of the set (the move limits and XMIN
		 * can hold a step above the budget when it is nearly spent) */
		if (used <= vol * (1 + 1e-9))
			upper = fmin(upper, res.compliance_nmm);
		if (upper - lower <= bo->gap * lower)
			break;
		if (bo->progress &&
		    (rc = progress_update(bo->progress,
					  bo->f0 + (bo->f1 - bo->f0) * (it + 1) / bo->max_iter, e)) != 0)
			goto out;
	}
	out->lower_nmm = lower;
	out->upper_nmm = upper;
	out->iterations = it < bo->max_iter ? it + 1 : bo->max_iter;
	out->solve_s = solve_s;
out:
	fea_solver_free(s);
	mem_free(el);
	mem_free(x);
	mem_free(w);
	mem_free(en);
	mem_free(keys);
	return rc;
}
