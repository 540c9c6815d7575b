/* hollow_int.h - data model shared by the files of the hollow engine.
 *
 * Paper 004 (Wang et al., "Support-Free Hollowing", TVCG 2018); the method
 * and every derivation are in docs/hollow.md.  Frame: printer frame, mm,
 * z up (the printing direction d = +z).  A void is described by contours
 * ("loops"): simple counter-clockwise polygons, one per optimisation slice,
 * the void on their left.  Shrinking a loop shrinks the void (the paper's
 * P -> P'): vertex j moves to v_j + l_j r_j with r_j its inward shifting
 * direction and 0 <= l_j <= ub_j (eq. 1, 7-10).
 */
#ifndef INFILLD_HOLLOW_INT_H
#define INFILLD_HOLLOW_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/geom/vec.h"

struct err;
struct mesh_bvh;

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
	int iterations;
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

#endif
