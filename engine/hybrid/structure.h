/* structure.h - the hybrid engine's interior structures (paper 003
 * sections 5-6): muscle-fibre sections, the tetrahedral crystal and the
 * transient layers.  Frames and units as in hybrid.h; docs/hybrid.md.
 */
#ifndef INFILLD_HYBRID_STRUCTURE_H
#define INFILLD_HYBRID_STRUCTURE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/capsule.h"
#include "engine/geom/vec.h"

struct err;

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

#endif
