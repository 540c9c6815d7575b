/* hybrid.h - internals of the `hybrid` engine: muscle-fibre (MFS) and
 * tetrahedral-crystal (TCS) interiors split by shape and stress (Mao, Wu,
 * Yan, Guo, Chen, Chen, paper 003).  The method as built, each step mapped
 * to the paper's sections, deviations and figures: docs/hybrid.md.
 *
 * Frames and units.  Everything is in the printer frame (mm, z up from the
 * plate) of the placed part.  Pixel images use the raster.h convention
 * through a struct raster_map; binary images here are one byte per pixel
 * (0 or 1), row-major, stride = width, unless a comment says otherwise.
 *
 * Pipeline (hybrid_engine.c):
 *   sdf.c        section 4.1  shape diameter function per facet, nsdf
 *   parts.c      section 4.1  Col / NCol facet components, small ones merged,
 *                             PCA axis and base of every component
 *   label.c      section 4.1  volumetric partition: a label for every point
 *   verify.c     section 4.2  mean stress per component under the paper's
 *                             1000 N loads (engine/fea), VCol / NCol, merges
 *   mfs.c        section 5.1  2D porous section, extruded along the axis
 *   tcs.c        section 5.2  diamond ball-and-stick lattice (capsules)
 *   transient.c  section 6    transient layer and extended support regions
 *   stack.c      beyond paper per-layer composition, top-down support rule
 *
 * This header: the partition (sdf, parts, label, verify).  The structures
 * (mfs, tcs, transient): structure.h.  The layer stack: stack.h.
 */
#ifndef INFILLD_HYBRID_H
#define INFILLD_HYBRID_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;
struct mesh;
struct mesh_bvh;
struct progress;
struct raster_map;

/* ---- sdf.c: shape diameter function (Shapira, Shamir, Cohen-Or 2008) ---- */

struct hy_sdf_opts {
	int rays;          /* rays per facet (about 30), 1..1024 */
	double cone_deg;   /* full opening angle of the cone (120), (0, 180) */
	int threads;       /* parfor threads, <= 0 = 1 */
	uint64_t seed;     /* ray directions are deterministic for a seed */
};

/* rays 30, cone 120 deg (Shapira et al.'s figures), 1 thread, seed 0. */
void hy_sdf_opts_default(struct hy_sdf_opts *o);

/* sdf_mm[f] for every facet f of m (m->nt entries, mm): rays from the
 * facet's centroid (nudged 1e-7 of the bbox diagonal inward) inside a
 * cone around the inward normal (m is CCW seen from outside), cast on b
 * (built on m).  A ray counts only when the first wall it meets faces
 * along it (the opposite wall seen from inside); a ray that meets a
 * wall facing back at it, or nothing, is dropped; a hit on the facet
 * itself is stepped over.  Lengths further than one standard deviation
 * from the median dropped; the rest averaged with weights 1 / angle from
 * the cone axis (capped near the axis: sdf.c, make_pattern).  Directions
 * are a fixed spiral rotated by the seed, so results do not depend on
 * threads.  A facet with no ray kept (zero area, or every ray dropped)
 * gets the mean of the others (or 0).  O(nt rays log nt).
 * 0, ERR_PARAM (rays, cone_deg) or ERR_NOMEM (sdf_mm untouched). */
int hy_sdf(const struct mesh *m, const struct mesh_bvh *b, const struct hy_sdf_opts *o,
	   double *sdf_mm, struct err *e);

/* The paper's normalisation (section 4.1; its formula writes nsdf where
 * sdf is meant inside the log):
 * nsdf = log((sdf - min)/(max - min) * alpha + 1) / log(alpha + 1), in
 * [0, 1], min and max over the n facets.  All equal: 0 everywhere.
 * alpha <= 0: the linear (sdf - min)/(max - min), the log form's limit. */
void hy_nsdf(const double *sdf_mm, size_t n, double alpha, double *nsdf);

/* ---- parts.c: facet components ---- */

enum hy_class { HY_NCOL = 0, HY_COL = 1, HY_VCOL = 2 };

struct hy_part {
	int cls;               /* enum hy_class */
	size_t facets;
	double area_mm2;
	struct vec3 centroid_mm;  /* area-weighted facet centroid */
	struct vec3 axis;         /* unit principal axis: the eigenvector of the
				     largest eigenvalue of the area-weighted
				     covariance of the facet centroids (a leg's
				     long axis), pointing from base into the part
				     (axis . (centroid - base) >= 0); a part with
				     no boundary: largest component positive */
	double radius_mm;         /* largest distance of the part's boundary
				     edge ends from the axis line through base_mm
				     (0 when no boundary) */
	double length_mm;         /* largest axis . (q - base_mm) over the part's
				     facet corners q: how far the part reaches
				     along its axis beyond the base plane */
	struct vec3 base_mm;      /* mean of the midpoints of the edges shared
				     with other parts, weighted by edge length
				     (centroid when there are none) */
	int neighbour;            /* the part sharing the longest boundary, -1 */
	double sdf_mean_mm;       /* area-weighted mean SDF */
};

struct hy_parts {
	uint32_t *facet_part;   /* m->nt entries: index into p, owned */
	struct hy_part *p;      /* n parts, largest area first after build, owned */
	size_t n;
	double *shared_mm;      /* n * n: boundary length (mm) shared by parts
				   i, j (symmetric, 0 on the diagonal), owned */
	uint32_t *facet_nbr;    /* 3 * m->nt: mesh_facet_neighbours of m, owned;
				   kept for hy_parts_merge */
	size_t nt;              /* m->nt at build */
};

/* Facets with nsdf < threshold are Col, others NCol; edge-connected
 * components of each class (facets joined across manifold edges of the
 * welded m); components below min_area_frac of the total area merged
 * into the neighbour sharing the longest boundary, smallest first and
 * repeated until none is left (a small component with no neighbour, a
 * separate shell, stays); the merged part keeps its class.  Then every
 * part's figures (struct hy_part), sdf_mean_mm from sdf_mm (m->nt
 * entries, mm).  Parts are numbered by decreasing area.  On success *out
 * is filled (hy_parts_fini frees); on failure *out is zeroed.
 * O(nt + k c + n^2) for k small components among c.  0, ERR_PARAM
 * (min_area_frac outside [0, 1)), ERR_LIMIT or ERR_NOMEM. */
int hy_parts_build(const struct mesh *m, const double *nsdf, const double *sdf_mm,
		   double threshold, double min_area_frac, struct hy_parts *out,
		   struct err *e);
/* Merge part b into part a (a != b, both < n): b's facets join a, which
 * keeps its class; sdf_mean_mm area-weighted; every part's figures and
 * shared_mm recomputed (O(nt + n^2)); indices above b shift down by one
 * (a itself becomes a - 1 when a > b).  m is the mesh of the build.
 * 0, ERR_PARAM (indices) or ERR_NOMEM (ps unchanged). */
int hy_parts_merge(struct hy_parts *ps, const struct mesh *m, size_t a, size_t b,
		   struct err *e);
/* The remap[old] = new of hy_parts_merge(ps, m, a, b) for n parts before
 * it (n entries), for hy_labeler_remap. */
void hy_parts_merge_remap(size_t n, size_t a, size_t b, int *remap);
/* Frees what ps owns and zeroes it; NULL-safe. */
void hy_parts_fini(struct hy_parts *ps);

/* ---- label.c: volumetric partition ---- */

/* Labels points of the part's interior: every voxel of a grid of edge
 * vox_mm over the part's box (fea_voxelize_mesh's grid: the bbox padded
 * by one voxel) that is inside (solid fraction of its mid-height section
 * >= 1/2) takes the part of its nearest surface facet (mesh_bvh_closest
 * from the voxel centre); then every Col / VCol part c with a neighbour
 * cuts the volume by the plane through base_mm across its axis: points
 * of c below the plane (t = axis . (p - base) < 0) go to the neighbour,
 * points of the neighbour above it (0 <= t <= length_mm) within
 * radius_mm of the axis go to c.  One step: a point moved to a
 * neighbour is not cut again by the neighbour's own plane.
 * m welded, b built on m, ps built on m (all borrowed during the call
 * only).  O(voxels log nt / threads).  On success *out (caller frees
 * with hy_labeler_free).  0, ERR_PARAM (vox_mm), ERR_GEOMETRY (empty
 * mesh), ERR_LIMIT (more than HY_LABEL_MAX_VOXELS, field vox_mm) or
 * ERR_NOMEM. */
#define HY_LABEL_MAX_VOXELS (UINT64_C(1) << 25)
struct hy_labeler;

int hy_labeler_new(const struct mesh *m, const struct mesh_bvh *b, const struct hy_parts *ps,
		   double vox_mm, int threads, struct hy_labeler **out, struct err *e);
/* Part index at p (the voxel holding p, then the plane rule), or -1
 * outside the voxel grid or in a voxel that is not inside.  Thread-safe. */
int hy_label_at(const struct hy_labeler *l, struct vec3 p);
/* Re-read the parts' classes and planes after hy_parts_merge (the voxels
 * keep facet-part indices mapped through remap[old] = new; a new index
 * < 0 makes the voxel outside).  ps->n must not exceed the part count
 * at hy_labeler_new (merges only lower it); extra parts are ignored. */
void hy_labeler_remap(struct hy_labeler *l, const struct hy_parts *ps, const int *remap);
/* NULL-safe. */
void hy_labeler_free(struct hy_labeler *l);

/* ---- verify.c: component verification (section 4.2) ---- */

/* The paper's two loads: load_n on the part's top (FEA_AT_TOP), straight
 * down and from the top right at 45 degrees between x and z, the nodes
 * within contact_mm of the plate fixed.  For each part, the volume-weighted mean stress (MPa) in x, y, z
 * of the elements whose centre the labeler gives it. */
struct hy_verify_opts {
	double load_n;        /* 1000 in the paper */
	double fea_voxel_mm;  /* element edge, > 0 */
	double dominance;     /* VCol: the largest |mean stress| at least this times
				 the second, under both loads */
	double floor_frac;    /* ... and at least this fraction of the largest such
				 stress over all Col parts (an unloaded appendage
				 carries nothing and is no column) */
	double E_mpa, nu;     /* material */
	double contact_mm;    /* nodes this close to the plate are fixed (>= half an
				 element): where the part stands */
	size_t max_elements;
	int threads;
};

struct hy_stress {
	double mean_mpa[2][3]; /* [load: 0 top, 1 at 45 deg][x, y, z] */
	double ratio[2];       /* largest / second |mean| per load (INFINITY when
				  the second is 0) */
	size_t elements;       /* elements of the part */
};

/* Solve both loads on the solid part (m voxelised at fea_voxel_mm), fill
 * st[i] for every part and set the class of every HY_COL part to HY_VCOL
 * when it passes, HY_NCOL otherwise.  *seconds: FEA wall time.  0 or the
 * solver's errors (ERR_GEOMETRY for an unconstrained part, ERR_LIMIT). */
int hy_verify(const struct mesh *m, const struct hy_labeler *l, struct hy_parts *ps,
	      const struct hy_verify_opts *o, struct hy_stress *st, double *seconds,
	      struct err *e);

#endif
