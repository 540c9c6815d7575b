/* erode.h - exact 3D inward offset (erosion by a ball) of a layer stack.
 *
 * For layer k, the eroded region is the set of points of the layer whose
 * 3D distance to the part's outside is at least r_mm: the cavity of a
 * uniform shell of thickness r (solid engine's shell_mm, hollow engine's
 * uniform offset).  It is a true 3D offset, not a per-layer 2D one: a
 * ceiling or floor within r above or below thins the layer too.
 *
 * Model and exactness: the part is the voxel stack of the layer regions
 * sampled on a square grid of pitch pixel_mm (pixel inside iff its centre
 * is inside the layer region, layer k = the slab [k, k+1] * layer_mm);
 * layers outside 0..layer_count-1 and pixels outside the grid are
 * outside.  D(p, k) is the exact Euclidean distance from each pixel
 * centre of layer k's mid-plane to the union of outside voxels, computed
 * by separable lower envelopes (z by nearest outside slab per column,
 * then Felzenszwalb-Huttenlocher along columns and rows with the
 * voxel-box metric).  The region D >= r is contoured by marching squares
 * with linear interpolation (sub-pixel).  Errors come only from the
 * sampling of each layer on the grid (< 1 pixel), never from the
 * combination across layers.  Derivation: docs/slicing.md "Erosion".
 *
 * Streaming: layer regions are pulled from a source in increasing order,
 * each once; memory is (R + 2) bit planes plus ~25 bytes per grid pixel,
 * with R = ceil((r + 2 pixel) / layer + 0.5) layers: independent of the
 * layer count.  Work per layer is linear in the pixels of the layer's
 * bounding box grown by r.
 */
#ifndef INFILLD_SLICE_ERODE_H
#define INFILLD_SLICE_ERODE_H

#include <stddef.h>

#include "engine/geom/path.h"
#include "engine/geom/raster.h"

struct err;

struct slice_erode_params {
	double r_mm;        /* ball radius, > 0 */
	double pixel_mm;    /* grid pitch, > 0 (result exact to this) */
	double layer_mm;    /* layer height of the stack, > 0 */
	int layer_count;    /* layers 0..layer_count-1 (>= 1); the rest is outside */
	/* Printer-frame XY box containing every layer region (mm); the grid
	 * covers it plus one outside pixel all round.  Material outside the
	 * box is not seen. */
	double x0_mm, y0_mm, x1_mm, y1_mm;
};

/* Where layer regions come from.  layer() fills *region (normalised, nm,
 * printer frame) for layer k; called once per layer in increasing k,
 * running ahead of the eroded layer asked for by up to R layers (so a
 * caller slicing the same mesh for itself uses a second slicer). */
struct slice_erode_source {
	int (*layer)(void *ctx, int k, struct paths *region, struct err *e);
	void *ctx;
};

/* The usual source: the slices of a mesh at the mid-planes of the stack's
 * layers (layer k: z = (k + 1/2) layer_mm).  Use slice_mid_layer as
 * layer() with a struct slice_mid_source as ctx (borrowed; it must
 * outlive the eroder). */
struct slicer;
struct slice_mid_source {
	struct slicer *slicer;
	double layer_mm;
};
int slice_mid_layer(void *ctx, int k, struct paths *region, struct err *e);

struct slice_eroder;

/* Validate p (ERR_PARAM naming the field), size the grid (ERR_LIMIT when
 * it would exceed 65535 pixels a side or 2^28 pixels: choose a larger
 * pixel_mm) and allocate.  src is copied.  Caller frees with
 * slice_erode_free(). */
int slice_erode_new(const struct slice_erode_params *p, const struct slice_erode_source *src,
		    struct slice_eroder **out, struct err *e);
void slice_erode_free(struct slice_eroder *er);

/* The usual eroder: of mesh m (closed, printer frame, mm) by r_mm, on a
 * grid of pixel_mm over the XY box of bb, layer_count layers of layer_mm,
 * its mid-plane slices taken through a slicer of its own made into
 * src->slicer (src->layer_mm set).  The caller frees *out with
 * slice_erode_free and then src->slicer with slice_free, also on error
 * (either may be NULL).  0 or slice_new's and slice_erode_new's errors. */
struct mesh;
struct box3;
int slice_erode_mesh_new(const struct mesh *m, double r_mm, double pixel_mm, double layer_mm,
			 int layer_count, const struct box3 *bb, struct slice_mid_source *src,
			 struct slice_eroder **out, struct err *e);

/* The eroded region of layer k (normalised, nm), replacing *region.  k
 * must not decrease from one call to the next (ERR_PARAM); asking for
 * the same k again is free.  Errors of the source are passed on. */
int slice_erode_layer(struct slice_eroder *er, int k, struct paths *region, struct err *e);

/* Raster form: the eroded region of layer k rasterised through map into
 * r like slice_rasterize (exact-area anti-aliasing or centre sampling,
 * max-combined).  Same ordering rule as slice_erode_layer. */
int slice_erode_raster(struct slice_eroder *er, int k, const struct raster_map *map,
		       int antialias, struct raster *r, struct err *e);

/* Field form: *field (borrowed until the next call) is the grid's
 * w x h row-major clearance D - r_mm in mm at each pixel centre of layer
 * k, capped at 2 pixels above 0 (exact below that); pixels outside the
 * layer read -r_mm.  The region D >= r is where field >= 0. */
int slice_erode_field(struct slice_eroder *er, int k, const float **field, struct err *e);

struct slice_erode_info {
	int w, h;            /* grid pixels */
	struct raster_map map; /* printer mm -> grid pixels */
	int window_layers;   /* R: layers looked at above and below */
	size_t bytes;        /* memory held */
	double pixels;       /* pixels run through the distance passes so far */
};

void slice_erode_info(const struct slice_eroder *er, struct slice_erode_info *info);

#endif
