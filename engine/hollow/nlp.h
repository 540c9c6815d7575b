/* nlp.h - the support-free offset optimisation of paper 004 (sections 4-6,
 * 8.2-8.3) as an Ipopt problem with exact sparse derivatives.
 *
 * Variables: the inward offsets l_j of every vertex of the given voids
 * (bounds 0 <= l_j <= ub_j), plus three auxiliary variables for the
 * stability objective.  Constraints: faces (eq. 3), facing-down cross
 * edges (eq. 5, sign-gated by an outer active-set loop), ceilings (eq. 6)
 * and, for stability, the definitions of the removed volume and its first
 * moments.  Derivations: docs/hollow.md.
 */
#ifndef INFILLD_HOLLOW_NLP_H
#define INFILLD_HOLLOW_NLP_H

#include <stddef.h>

#include "engine/geom/hull.h"
#include "engine/hollow/hollow_int.h"

enum hl_objective { HL_OBJ_LIGHTWEIGHT = 0, HL_OBJ_STABILITY = 1 };

struct hl_nlp_opts {
	double alpha_rad;    /* overhang limit of the constraints (from the vertical) */
	double h_mm;         /* optimisation layer thickness */
	double ceil_eps_mm2; /* eq. 6 */
	int ceiling_literal; /* 1: eq. 6 as a constraint A(top) <= eps; 0 (default):
				its limit form, the top loop fixed on its poles
				(docs/hollow.md: the literal form violates
				constraint qualification at the collapse) */
	double gate_tau;     /* an edge faces down when n_e . d < -gate_tau */
	int max_iter;        /* Ipopt iterations per outer round */
	int max_outer;       /* sign-gating rounds */
	enum hl_objective objective;
	/* stability: the solid before these voids and the target region */
	double vol_mm3;             /* V(M) */
	double com_xy[2];           /* c(M) projected on the plate (mm) */
	const struct hull_pt *target; /* convex CCW region the COM must reach */
	size_t ntarget;
	double light_weight;        /* weight of the lightweight term (>= 0) */
	/* time budget: progress_now_s() instant (s) after which no solve goes
	 * on; Ipopt's max_cpu_time is cut to what is left.  0 = none */
	double deadline_s;
	/* cooperative cancellation (inline solves only); may be NULL */
	int (*cancelled)(void *ctx);
	void *cancel_ctx;
};

/* Optimise the voids v[0..n) as one problem.  On success every void has
 * l (nv offsets, allocated with mem_alloc), iterations, outer and seconds
 * set; status = 0 when the result passes hl_void_check() at the
 * constraint angle, else a negative value (the void must not be used).
 * Returns 0, ERR_NOMEM, ERR_CANCELLED or ERR_INTERNAL (solver setup). */
int hl_nlp_solve(struct hl_void *v, size_t n, const struct hl_nlp_opts *o, struct err *e);

struct hl_check {
	double worst_face;    /* max over faces of (sin alpha - n.z ... ) > 0 = violation, radians */
	double worst_edge_mm; /* max over facing-down cross edges of |d| - h tan alpha */
	double top_area_mm2;  /* area of the topmost loop after shifting */
	double max_shift_mm;  /* max over vertices of l - ub (> 0 = bound broken) */
	double min_shift_mm;  /* min over vertices of l (< 0 = bound broken) */
};

/* Measure how well offsets l satisfy the paper's constraints at alpha_rad
 * (independent re-evaluation, used after every solve and by tests). */
void hl_void_check(const struct hl_void *v, const double *l, double alpha_rad, double h_mm,
		   double gate_tau, struct hl_check *c);

/* Volume (mm^3) enclosed by void v with offsets l (divergence theorem over
 * the strip faces and both caps' polygons). */
double hl_void_volume(const struct hl_void *v, const double *l);

/* Signed area (mm^2) and first moments (mm^3) of loop k with offsets l. */
void hl_loop_moments(const struct hl_void *v, size_t k, const double *l, double *area,
		     double *mx, double *my);

#endif
