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
 */
#ifndef INFILLD_HYBRID_H
#define INFILLD_HYBRID_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/capsule.h"
#include "engine/geom/raster.h"
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

/* ---- mfs.c: muscle-fibre section (section 5.1) ---- */

/* A 2D porous pattern in the plane across an axis: walls of thickness
 * wall_mm along the Voronoi boundaries of a Poisson-disk point set of
 * spacing cell_mm, or a user's binary template image tiled with pixel
 * pitch template_mm.  Extrusion along the axis: a 3D point p maps to
 * (e1 . p, e2 . p) with e1, e2 unit and orthogonal to the axis
 * (hy_mfs_basis).  Caller frees with hy_mfs_free(). */
struct hy_mfs;

/* Sites: poisson2_sample (radius cell_mm, seed) over the square of side
 * 2 extent_mm centred on origin_mm's projection; material where the
 * distance to the Voronoi boundary is < wall_mm / 2 (exact: the nearest
 * site's cell, all its bisectors), and everywhere beyond the square.
 * hy_mfs_solid is O(1) (a grid of candidate lists, about 3 sites a
 * cell).  0, ERR_PARAM (axis zero or not finite, cell_mm not > 0,
 * wall_mm not in [0, cell_mm), extent_mm not > 0), ERR_LIMIT (more than
 * 2^24 sampling squares), ERR_NOMEM. */
int hy_mfs_new_voronoi(struct vec3 axis, struct vec3 origin_mm, double extent_mm,
		       double cell_mm, double wall_mm, uint64_t seed, struct hy_mfs **out,
		       struct err *e);
/* PNG template (any PNG, read as 8-bit gray; > 127 = material) of the
 * paper's kind, tiled from origin_mm's projection: pixel column i along
 * +e1, row 0 at the top (largest e2) of each tile.  Walls thinner than
 * wall_mm (to within a pixel) thickened to at least it, once at load;
 * thicker material unchanged.  0, ERR_PARAM, ERR_IO / ERR_PARSE (the
 * file), ERR_LIMIT (a side beyond 65535, or the padded tile beyond 2^26
 * pixels), ERR_NOMEM. */
int hy_mfs_new_template(struct vec3 axis, struct vec3 origin_mm, const char *png_path,
			double template_mm, double wall_mm, struct hy_mfs **out,
			struct err *e);
/* 1 when p is material of the pattern.  Thread-safe. */
int hy_mfs_solid(const struct hy_mfs *f, struct vec3 p);
void hy_mfs_free(struct hy_mfs *f);
/* The section plane's basis: e1 the unit projection of the coordinate
 * axis least aligned with the axis, e2 = axis x e1 (axis z: x, y). */
void hy_mfs_basis(const struct hy_mfs *f, struct vec3 *e1, struct vec3 *e2);
/* Voronoi pattern's sites: *n (u, v) pairs relative to the sampled
 * square's corner (*u_lo, *v_lo) in plane coordinates (e1 . p, e2 . p);
 * borrowed from f.  A template has none (*n = 0, NULL). */
const double *hy_mfs_sites(const struct hy_mfs *f, size_t *n, double *u_lo, double *v_lo);

/* ---- tcs.c: tetrahedral crystal (diamond) lattice (section 5.2) ---- */

/* Diamond cubic balls (radius ball_mm) and sticks (radius stick_mm / 2
 * where stick_mm is the stick diameter) of cubic cell cell_mm covering
 * box [lo, hi], cube axes along x, y, z shifted by shift_mm (an atom at
 * shift_mm): every stick is at acos(1/sqrt 3) = 54.74 deg from the
 * vertical.  Every atom within one bond length (sqrt 3 / 4 cell) of the
 * box on each axis, and every bond between two such atoms, once (sticks
 * with a.z <= b.z), so clipping to the box leaves no gaps.  Balls no
 * larger than the sticks' radius are left out (inside the sticks' ends).
 * *caps owned by the caller (mem_free() or free()).  steepest_deg: the
 * largest stick angle from the vertical.  0, ERR_PARAM (cell not > 0,
 * stick_mm not in (0, sqrt 3 / 2 cell), ball_mm not in [0, cell / 2),
 * empty box), ERR_LIMIT (more than max_caps), ERR_NOMEM. */
int hy_tcs_build(struct vec3 lo, struct vec3 hi, double cell_mm, double ball_mm,
		 double stick_mm, struct vec3 shift_mm, size_t max_caps,
		 struct capsule **caps, size_t *n, double *steepest_deg, struct err *e);

/* ---- transient.c: transient structures (section 6) ---- */

/* The transient layer of an interface (section 6.1): us = (mfs | tcs) &
 * mask (nonzero = set, us gets 0/1); the 8-connected regions of us other
 * than the largest (the paper's R_1^1; the first in raster order on ties)
 * are joined to it by bridges of width bridge_px (pixels): every pixel of
 * a bridge's centre line is the centre of a painted disc of diameter
 * bridge_px wherever the mask allows.  Nothing is painted off the mask; a
 * region that no path inside the mask reaches stays as it is.  How this
 * realises the paper's bounding-box rule and where it deviates:
 * docs/hybrid.md.  us may alias neither input; undefined on failure.
 * Images w x h, row stride w.  O(w h) plus O(length x bridge_px^2) per
 * bridge.  0, ERR_PARAM (sizes, NULL images, bridge_px not > 0) or
 * ERR_NOMEM. */
int hy_transient_layer(const uint8_t *mfs, const uint8_t *tcs, const uint8_t *mask, int w,
		       int h, double bridge_px, uint8_t *us, struct err *e);
/* The extended-support region (section 6.2): tcs_proj (the TCS projected
 * on the layer) AND us, 8-connected regions of fewer than min_px pixels
 * dropped; into out (0/1; may alias either input; undefined on failure).
 * 0, ERR_PARAM (sizes, NULL images) or ERR_NOMEM. */
int hy_support_region(const uint8_t *tcs_proj, const uint8_t *us, int w, int h,
		      size_t min_px, uint8_t *out, struct err *e);

/* ---- stack.c: the designed layer stack ---- */

/* Bit planes of every layer on the design grid (pitch_mm square pixels
 * over the part's box, the slice/erode.h grid): bit j * w + i of layer k
 * in words [k * words, (k + 1) * words).  part: pixel centre inside the
 * part; interior: at least the shell's thickness from the outside (3D);
 * voids: interior pixels left empty by the design; tcsr: interior pixels
 * whose structure is the crystal lattice (their support rule uses the
 * struts' angle).  Material = part & !voids. */
struct hy_stack {
	int w, h, layers;
	struct raster_map map;  /* printer mm -> design-grid pixel coordinates */
	double pitch_mm, layer_mm;
	size_t words;           /* uint64_t words per plane of one layer */
	uint64_t *part, *interior, *voids, *tcsr;
};

enum hy_structure { HY_STRUCT_HYBRID = 0, HY_STRUCT_TCS, HY_STRUCT_MFS };

/* What stack.c composes: the partition, the structures and the rules. */
struct hy_design {
	int structure;                 /* enum hy_structure */
	const struct hy_labeler *labels; /* HY_STRUCT_HYBRID only */
	const struct hy_parts *parts;    /* HY_STRUCT_HYBRID only */
	struct hy_mfs *const *mfs;     /* per part (NULL for non-VCol) in hybrid
					  mode; mfs[0] for the whole interior in
					  HY_STRUCT_MFS */
	struct capsule *caps;          /* TCS balls and sticks (owned by the caller;
					  the extended support columns are appended
					  by hy_stack_columns, which may realloc) */
	size_t ncaps, caps_cap;
	double transient_mm;           /* thickness of the transient layer across
					  each VCol part's base plane */
	double bridge_mm;              /* width of its connecting bridges */
	double tcs_cell_mm;            /* length of the extended support columns */
	double column_mm;              /* their diameter */
	double column_spacing_mm;      /* their Poisson-disk spacing */
	double r_alpha_mm;             /* h tan(alpha): the support rule, MFS side */
	double r_tcs_mm;               /* h tan(alpha_tcs): TCS side */
	int threads;
	uint64_t seed;
};

struct hy_stack_report {
	size_t columns;             /* extended support columns added */
	size_t transient_px;        /* transient-layer pixels, all layers */
	size_t filled_px;           /* void pixels filled by the support rule */
	double overhang_mm2;        /* material of layer k+1 farther than h tan(alpha)
				       from material of layer k, over the part's
				       interior (the struts' own angle) */
	double material_mm3, part_mm3;
	double seconds_interior, seconds_compose, seconds_support;
};

/* The part's and interior planes of every layer (mesh sliced and eroded
 * in 3D by shell_mm on a grid of pitch_mm over box).  0, ERR_LIMIT
 * (grid too large, field "grid_mm"), ERR_NOMEM, slicing errors. */
int hy_stack_init(struct hy_stack *st, const struct mesh *m, struct box3 box, double pitch_mm,
		  double layer_mm, int layers, double shell_mm, struct progress *pg,
		  struct err *e);
/* Section 6.2 for every VCol part of a hybrid design: the extended
 * support columns, appended to d->caps.  Before hy_stack_compose. */
int hy_stack_columns(const struct hy_stack *st, struct hy_design *d, size_t *ncolumns,
		     struct err *e);
/* Sections 5-6: every layer's voids from the structures, then the support
 * rule top-down (docs/hybrid.md "Printability").  Fills rep. */
int hy_stack_compose(struct hy_stack *st, const struct hy_design *d, struct progress *pg,
		     struct hy_stack_report *rep, struct err *e);
/* 1 when design pixel (i, j) of layer k is material; 0 outside the grid. */
int hy_stack_material(const struct hy_stack *st, int k, int i, int j);
/* 1 when it is a void of the design (interior left empty). */
int hy_stack_void(const struct hy_stack *st, int k, int i, int j);
/* Element densities for the FEA: the material fraction of every cube of
 * edge h_mm over the part's box (grid g allocated and filled as
 * fea_voxelize_mesh would; solid_part != 0: the part itself, no voids). */
struct fea_grid;
int hy_stack_fea_grid(const struct hy_stack *st, struct box3 box, double h_mm, int solid_part,
		      size_t max_elements, struct fea_grid *g, struct err *e);
/* The material as a closed manifold mesh: block averages of bx x bx
 * pixels x bz layers, marching tetrahedra at 1/2 (mesh/isosurface.h). */
int hy_stack_mesh(const struct hy_stack *st, int bx, int bz, size_t max_triangles,
		  struct mesh **out, struct err *e);
void hy_stack_fini(struct hy_stack *st);

#endif
