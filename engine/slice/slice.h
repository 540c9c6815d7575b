/* slice.h - mesh -> layer contours, contours -> pixels, fields -> contours.
 *
 * Design and complexity: docs/slicing.md.
 *
 * Contours: a z-sweep.  Triangles are sorted by min z once (O(n log n));
 * planes are visited in increasing z with an active list of triangles
 * spanning the plane, so a full schedule costs O(n log n + k) for k
 * triangle/plane intersections.  Segments are chained into loops through
 * the mesh's shared edges (exact, topological: no epsilon matching).
 * Degenerate cases: planes are sampled at mid-layer heights (layer.h); a
 * vertex lying exactly on the plane is treated as lying just above it
 * (symbolic perturbation), so every triangle is cut in 0 or 2 edges and
 * horizontal faces contribute nothing.  Chaining needs a welded mesh
 * (shared vertex indices: the driver runs mesh_repair first); an edge
 * shared by four faces is fine.  Open meshes leave open chains; each is
 * closed by a straight join to the nearest chain head on the same hole
 * (border loop), else to the nearest head, and the result is normalised
 * under the nonzero rule; the count of closed chains is reported so
 * callers can say what was repaired.
 *
 * Raster: exact-area anti-aliasing (signed-area accumulation per cell)
 * or binary centre sampling, nonzero winding rule.  Nonzero, not
 * even-odd, because normalised regions are already non-overlapping
 * (both agree there) and for raw self-overlapping input nonzero treats
 * overlapping shells of a multi-body mesh as solid, as printers expect.
 */
#ifndef INFILLD_SLICE_H
#define INFILLD_SLICE_H

#include <stddef.h>

#include "engine/geom/path.h"
#include "engine/geom/raster.h"

struct err;
struct mesh;

struct slicer;

struct slice_stats {
	size_t segments;      /* triangle/plane intersections */
	size_t loops;         /* closed loops found directly */
	size_t chains_closed; /* open chains that had to be closed (open mesh) */
};

/* Prepare a sweep over m (borrowed; must outlive the slicer).  Caller
 * frees with slice_free() (NULL-safe).  O(n log n).  ERR_GEOMETRY for an
 * out-of-range index or a non-finite coordinate (e->item names it),
 * ERR_LIMIT beyond MESH_MAX_*, ERR_NOMEM.  Degenerate triangles are
 * skipped.  A slicer is used by one thread at a time. */
int slice_new(const struct mesh *m, struct slicer **out, struct err *e);
void slice_free(struct slicer *s);

/* Region (normalised, nm, printer frame) where the plane z = z_mm cuts
 * the solid, replacing *region.  Successive calls with non-decreasing z
 * are O(active + new); a lower z restarts the sweep.  stats may be NULL;
 * they accumulate per call.  ERR_PARAM for a non-finite z, ERR_NOMEM. */
int slice_at(struct slicer *s, double z_mm, struct paths *region, struct slice_stats *stats,
	     struct err *e);

/* Rasterise a region (nonzero rule) into r through map.  antialias: 1 =
 * exact area coverage (0..255), 0 = pixel centre inside -> 255.  Pixels
 * are OR-ed (max) into r, so callers clear r first. */
int slice_rasterize(const struct paths *region, const struct raster_map *map, int antialias,
		    struct raster *r, struct err *e);

/* The exact area coverage (0..1, before 8-bit quantisation) of region in
 * each pixel of a w x h float image with row stride `stride` floats,
 * through map; max-ed into cov like slice_rasterize.  For callers that
 * need unquantised coverage (tests of exactness, thumbnails, volume
 * estimates).  0, ERR_PARAM (singular map, bad size) or ERR_NOMEM. */
int slice_coverage(const struct paths *region, const struct raster_map *map, float *cov, int w,
		   int h, size_t stride, struct err *e);

/* Contours of a scalar field sampled at pixel centres (marching squares
 * with linear interpolation, saddles resolved by the cell centre value):
 * the region where field > iso, mapped to printer nm through map's
 * inverse, replacing *region.  field: w*h floats, row-major, row stride
 * w; NaN counts as below iso.  Outside the grid the field counts as below
 * iso (crossings on the image border), so contours close.  The loops are
 * simple, disjoint and oriented: a normalised region without a union.
 * O(w h + crossings).  ERR_PARAM (empty grid, singular map), ERR_NOMEM. */
int slice_field_contours(const float *field, int w, int h, float iso,
			 const struct raster_map *map, struct paths *region, struct err *e);

struct hull_pt;
/* Contact hull of a placed part (bbox min z = 0): convex hull (CCW, mm)
 * of its section in the first layer (z = layer_mm / 2).  *h (caller
 * frees with mem_free) with *n >= 3 points, or *n = 0 when the section
 * has fewer than 3 hull points.  0, or the slicer's error.  contact.c. */
int slice_contact_hull(const struct mesh *part, double layer_mm, struct hull_pt **h, size_t *n,
		       struct err *e);

#endif
