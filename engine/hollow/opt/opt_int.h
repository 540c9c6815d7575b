/* opt_int.h - internals of the paper's optimiser (engine/hollow/opt/, whose
 * face is opt.h): the data model and the steps rounds.c chains.
 *
 * Paper 004 (Wang et al., "Support-Free Hollowing", TVCG 2018): method and
 * derivations in docs/hollow.md.  Printer frame, mm, z up (d = +z).  A void
 * is a stack of loops: simple counter-clockwise polygons, one per slice,
 * the void on their left; vertex j moves to v_j + l_j r_j, r_j its inward
 * shifting direction, 0 <= l_j <= ub_j (P -> P', eq. 1, 7-10).
 */
#ifndef INFILLD_HOLLOW_OPT_INT_H
#define INFILLD_HOLLOW_OPT_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/hull.h"
#include "engine/geom/path.h"
#include "engine/geom/vec.h"
#include "engine/hollow/opt/opt.h"

struct err;
struct mesh_bvh;
struct progress;

/* One contour at one optimisation slice. */
struct hl_loop {
	int slice;       /* optimisation slice index */
	double z_mm;
	size_t n;
	double *xy;      /* 2n, mm, counter-clockwise, owned */
	double area_mm2; /* > 0 */
};

void hl_loop_fini(struct hl_loop *l);
/* Move src into dst (src left empty). */
void hl_loop_move(struct hl_loop *dst, struct hl_loop *src);
/* 1 when (x, y) is inside loop xy (n vertices, any orientation; poles.c). */
int hl_loop_inside(const double *xy, size_t n, double x, double y);

/* All loops of one slice. */
struct hl_slice {
	struct hl_loop *loop;
	size_t n, cap;
};

/* ---- contours: regions -> simple resampled loops (contour.c) ---- */

struct hl_contour_params {
	double spacing_mm;  /* resampling step s along the boundary */
	double slit_mm;     /* width of the cut that opens a region's holes */
	double min_area_mm2;/* loops smaller than this are dropped */
};

/* Turn the normalised region of one slice (the inner solid: the part
 * eroded by the wall) into simple counter-clockwise loops: an opening by
 * spacing_mm removes necks the sampling cannot follow, holes are opened
 * by slits (so every loop is genus 0), boundaries are resampled every
 * ~spacing_mm keeping reflex corners.  Loops are appended to out (z, slice
 * set).  0, ERR_NOMEM or a clip error. */
int hl_contours_from_region(const struct paths *region, int slice, double z_mm,
			    const struct hl_contour_params *p, struct hl_slice *out,
			    struct err *e);

/* Area (mm^2) of the intersection of two loops' projections. */
int hl_loop_overlap_mm2(const struct hl_loop *a, const struct hl_loop *b, double *area,
			struct err *e);

/* Loop <-> integer path conversions (nm). */
int hl_loop_to_path(const struct hl_loop *l, struct path *p);

/* Section 6's P -> P~ (contour.c): `passes` truncated Laplacian passes
 * over loop l's vertices, each convex vertex moved half way to its
 * neighbours' midpoint (reflex vertices stay): corners are cut, the loop
 * only shrinks, so walls only thicken (loops from hl_contours_from_region,
 * whose opening keeps other stretches of boundary away; see contour.c).
 * area_mm2 updated.  0 or ERR_NOMEM. */
int hl_loop_smooth(struct hl_loop *l, int passes, struct err *e);

/* ---- adaptive optimisation slices (slices.c, step 2 and ref. [30]) ---- */

/* Mean distance (mm) by which region mid leaves the band between lo and hi
 * (lo n hi <= mid <= lo u hi on a ruled surface): the area outside it over
 * mid's perimeter.  All normalised, nm.  0 or a clip error. */
int hl_slab_deviation_mm(const struct paths *lo, const struct paths *mid, const struct paths *hi,
			 double *dev_mm, struct err *e);

/* Choose optimisation slices among nc candidate layers (regions reg,
 * bottom to top): from each chosen one the next is the farthest at most
 * tmax candidates up whose layers in between all keep dev <= dev_mm.
 * pick (nc entries) receives the chosen indices, increasing, the first and
 * last always among them; *npick their count.  0 or a clip error. */
int hl_slices_adaptive(const struct paths *reg, size_t nc, size_t tmax, double dev_mm,
		       size_t *pick, size_t *npick, struct err *e);

/* ---- grouping (group.c, paper section 7.1) ---- */

/* Link loop (k, a) to (k + 1, b) by the paper's three rules: never two
 * loops of one slice in a group; overlap at least `ratio` of both areas;
 * a loop overlapping several goes with the largest overlap (links are
 * kept only when mutually best).  up[k][a] = index b in slice k + 1 or -1.
 * up is an array of nslices arrays (caller frees with hl_links_free). */
int hl_group_links(const struct hl_slice *sl, size_t nslices, double ratio, int ***up,
		   struct err *e);
void hl_links_free(int **up, size_t nslices);

/* ---- one void: a chain of loops with strips (void.c) ---- */

struct hl_xedge {
	uint32_t lo, hi; /* vertex ids: lower loop, upper loop */
	uint32_t f[2];   /* the two strip faces sharing the edge */
};

struct hl_void {
	size_t nloops;
	int *slice;           /* nloops: slice index of each loop, consecutive */
	double *z;            /* nloops: z (mm) of each loop */
	size_t *off;          /* nloops + 1: vertex id range of each loop */
	size_t nv;            /* vertices = optimisation variables */
	double *p;            /* 2 nv: initial positions v_j (mm) */
	double *vz;           /* nv: z of each vertex (its loop's) */
	double *dir;          /* 2 nv: unit inward shifting directions r_j */
	double *ub;           /* nv: upper bounds l^U_j (mm), >= 0 */
	uint32_t *tri;        /* 3 nt vertex ids, normals into the void */
	size_t nt;
	struct hl_xedge *xe;  /* cross edges between consecutive loops */
	size_t nxe;
	double *l;            /* nv: optimised offsets (mm), NULL before solving */
	double *start;        /* nv: support-free start (restrip.c), NULL: start.c's sweep */
	/* solver record */
	int status;           /* 0 solved; < 0 failed (void dropped) */
	int iterations, capped; /* capped: the work budget's iter_cap cut it */
	int outer;            /* sign-gating rounds (eq. 5) */
	double seconds;
	double ceil_eps_mm2;  /* eq. 6 bound used for the top loop */
	double volume_mm3;    /* of the optimised void */
};

void hl_void_init(struct hl_void *v);
void hl_void_fini(struct hl_void *v);

/* Position (mm) of vertex id at offset l along its direction. */
static inline struct vec3 hl_void_pos(const struct hl_void *v, size_t id, double l)
{
	return v3(v->p[2 * id] + l * v->dir[2 * id], v->p[2 * id + 1] + l * v->dir[2 * id + 1],
		  v->vz[id]);
}

/* Is the straight triangle a, b, c (mm) unusable for a void surface (too
 * close to or crossing the part's outer surface)?  ctx from the caller. */
struct hl_block {
	int (*blocked)(void *ctx, struct vec3 a, struct vec3 b, struct vec3 c);
	void *ctx;
};

/* ---- Voronoi poles and bounds (poles.c, paper section 6) ---- */

/* For the n vertices of one loop (xy, counter-clockwise): shifting
 * directions r_j (unit, into the loop) from the inner Voronoi pole of each
 * sample (eq. 8) and upper bounds l^U_j = distance to where the ray leaves
 * the Voronoi cell (eq. 9).  dir: 2n, ub: n.  0, ERR_NOMEM, ERR_LIMIT. */
int hl_poles(const double *xy, size_t n, double *dir, double *ub, struct err *e);

/* One truncated Laplacian pass over a loop's bounds (eq. 10); tmp: n. */
void hl_bounds_smooth(double *ub, size_t n, double *tmp);

/* ---- strip triangulation (strip.c, paper section 8.1) ---- */

/* Optimal (minimum area) strip between lower loop A (na vertices, ids
 * ida + i) and upper loop B (nb, idb + j) by dynamic programming over the
 * toroidal grid, triangles that `block` rejects costing infinity.  Appends
 * faces (oriented into the void) to *tri / *nt (cap *tcap) and cross
 * edges to *xe.  Returns 0, 1 when no admissible strip exists (nothing
 * appended), or a negative err_code. */
int hl_strip(const double *pa, double za, size_t na, uint32_t ida, const double *pb, double zb,
	     size_t nb, uint32_t idb, const struct hl_block *block, uint32_t **tri, size_t *nt,
	     size_t *tcap, struct hl_xedge **xe, size_t *nxe, size_t *xcap, struct err *e);

/* ---- optimisation problem (nlp.c, check.c; sections 4-6, 8.2-8.3) ---- */

struct hl_nlp_opts {
	double alpha_rad;    /* overhang limit of the constraints (from the vertical);
				eq. 5's h is each cross edge's rise, eq. 11's each
				loop's slab (hl_void_loop_h): slices may differ in
				thickness */
	double ceil_eps_mm2; /* eq. 6 */
	int ceiling_literal; /* 1: eq. 6 as a constraint A(top) <= eps; 0 (default):
				its limit form, the top loop fixed on its poles
				(docs/hollow.md: the literal form violates
				constraint qualification at the collapse) */
	double gate_tau;     /* an edge faces down when n_e . d < -gate_tau */
	int max_iter;        /* Ipopt iterations per outer round */
	int max_outer;       /* sign-gating rounds */
	int iter_cap;        /* work budget: callbacks a solve may make over all its
				rounds; 0 = no cap, < 0 = no solve starts */
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
void hl_void_check(const struct hl_void *v, const double *l, double alpha_rad, double gate_tau,
		   struct hl_check *c);

/* Area (mm^2) of v's top polygon at offsets l (NULL: 0), as a nonzero
 * region, farther than reach_mm from its edge: the flat ceiling eq. 6's
 * limit form can leave that print layers reaching reach_mm cannot bridge
 * (a sound collapsed top, a thin walk round a medial tree, reads about 0).
 * 0, ERR_NOMEM or a clip error. */
int hl_void_top_overhang_mm2(const struct hl_void *v, const double *l, double reach_mm, double *a,
			     struct err *e);

/* Thickness (mm) of the slab loop k of v stands for in eq. 11-12's sums:
 * half the rise to each neighbouring loop, the whole rise at the ends
 * (h for every loop of uniform slices); 0 for a void of one loop. */
double hl_void_loop_h(const struct hl_void *v, size_t k);

/* Volume (mm^3) enclosed by void v with offsets l (divergence theorem over
 * the strip faces and both caps' polygons). */
double hl_void_volume(const struct hl_void *v, const double *l);

/* Signed area (mm^2) and first moments (mm^3) of loop k with offsets l. */
void hl_loop_moments(const struct hl_void *v, size_t k, const double *l, double *area,
		     double *mx, double *my);

/* ---- one round's solves (solve.c) ---- */

/* status of a void whose optimum failed its check but whose support-free
 * starting point passed and was used instead */
#define HL_STATUS_FALLBACK 1
/* status of a void not optimised (o->deadline_s passed, o->iter_cap < 0):
 * it gets the support-free start like a failed one */
#define HL_STATUS_UNSOLVED (-2000)

/* Optimise v[0..n): lightweight voids each on their own, in up to
 * `threads` worker processes; stability as one problem.  Every void ends
 * with status 0 (optimum), HL_STATUS_FALLBACK, or < 0 (drop it); past
 * o->deadline_s or with o->iter_cap < 0 no solve starts and the rest take
 * their start.  prog (may be NULL) moves from stage fraction f0 to f1 as
 * voids finish and may cancel.
 * Returns 0, ERR_NOMEM, ERR_IO (pipe/poll) or ERR_CANCELLED. */
int hl_solve_round(struct hl_void *v, size_t n, const struct hl_nlp_opts *o, int threads,
		   struct progress *prog, double f0, double f1, struct err *e);

/* ---- support-free start (start.c, restrip.c) ---- */

/* Reach (mm) per mm of rise of the start's cross edges: 0.95 tan alpha. */
double hl_reach_slope(double alpha_rad);

/* Fill l (v->nv offsets): v->start when restrip.c made one, else a sweep
 * top-down: top loop on its poles, every other vertex the smallest offset
 * within reach_slope dz of its upper cross-edge neighbours, dz the rise
 * between the two loops (see start.c).  0 or ERR_NOMEM. */
int hl_void_support_start(const struct hl_void *v, double reach_slope, double *l, struct err *e);

/* Rebuild v's strips top-down where its start puts the vertices, and set v->start (restrip.c;
 * reach_slope as above, block: clearance at offset 0).  A pair of loops with no strip whose
 * cross edges stay within reach ends the void: it keeps the loops above, *first the index (in
 * v's loops before the call) of the lowest kept, else 0.  Returns 0, 1 when fewer than two
 * loops are left (v unusable), or a negative err_code. */
int hl_void_restrip(struct hl_void *v, double reach_slope, const struct hl_block *block,
		    size_t *first, struct err *e);

/* ---- building a void (void.c) ---- */

/* Build a void from loops[0..n) (bottom to top, consecutive slices;
 * borrowed, copied): shifting directions and bounds per loop (hl_poles),
 * strips between neighbours (hl_strip).  Strips are built upward until a
 * pair has no admissible strip; *used = loops taken (>= 1).  Returns 0
 * with *out replaced, 1 when fewer than two loops could be joined (the
 * caller continues from loops[*used]), or a negative err_code. */
int hl_void_build(const struct hl_loop *const *loops, size_t n, const struct hl_block *block,
		  struct hl_void *out, size_t *used, struct err *e);

#endif
