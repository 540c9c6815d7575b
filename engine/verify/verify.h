/* verify.h - printability check of a produced layer stack, independent of
 * the engine that made it.
 *
 * Reads layer images in print order (0 = on the plate) and finds:
 *  - interior overhangs: a solid pixel of layer i+1 above a void pixel of
 *    layer i that is farther than layer_mm * tan(alpha) (+ tolerance_px,
 *    distances at sub-pixel accuracy: subpx.h) from layer i's solid, where that void pixel belongs to an
 *    ENCLOSED void: its 3D void component (8-connected in a layer, linked
 *    to the void directly above and below) never reaches the outside (the
 *    image border, or anything above the last layer; the build plate
 *    closes the bottom).  Such overhangs would need supports that can
 *    never be removed.  Overhangs over voids that do reach the outside are
 *    counted apart (ordinary, removable supports);
 *  - floating islands: solid components (8-connected) of layer i+1 with
 *    no pixel above layer i's solid;
 *  - minimum wall thickness between enclosed voids and the outside, and
 *    between two enclosed voids: in the layer plane (exact distance
 *    transform) and along columns;
 *  - fins: solid one or two pixels thick between enclosed voids.
 * Memory: two layers of per-pixel state over the layers' bounding boxes,
 * plus a 16-bit run start and a 32-bit void id per image pixel.  Design and the
 * tolerance argument: docs/verify.md.
 */
#ifndef INFILLD_VERIFY_H
#define INFILLD_VERIFY_H

#include <stddef.h>

#include "engine/geom/raster.h"

struct err;
struct metrics;

struct verify_params {
	double layer_mm;     /* layer height, > 0 */
	double alpha_deg;    /* largest self-supporting overhang from the vertical, (0, 90) */
	double pixel_x_mm;   /* pitch along image columns (x), > 0 */
	double pixel_y_mm;   /* pitch along image rows (y), > 0 */
	double tolerance_px; /* overhang tolerance in pixels of the larger pitch beyond
			      * layer_mm tan(alpha), distances measured at sub-pixel
			      * accuracy (VERIFY_TOLERANCE_PX when 0 is given) */
	int threshold;       /* gray >= threshold is solid (128 when 0 is given): an
			      * anti-aliased pixel is solid when at least half covered */
	int speck_voxels;    /* enclosed 3D void components of at most this many
			      * voxels are specks: counted apart, kept out of the wall
			      * minima (VERIFY_SPECK_VOXELS when 0 is given) */
	int threads;         /* threads the distance transforms (at most
			      * EDT_LANES of them) and the overhang readings may
			      * use (0 or 1: one); the report does not depend on
			      * it */
};

/* Default speck size: a 2 x 2 x 2 voxel pocket. */
#define VERIFY_SPECK_VOXELS 8
/* Default overhang tolerance (pixels): the sub-pixel distances' error
 * on exactly rendered straight and curved edges stays below it
 * (tests/unit/verify/test_verify_subpx.c). */
#define VERIFY_TOLERANCE_PX 0.2
/* Default threshold: gray >= 128 is solid. */
#define VERIFY_THRESHOLD 128

struct verify_report {
	int layers;
	int width, height;
	/* interior (enclosed) overhangs */
	double interior_overhang_mm2;
	long long interior_overhang_px;
	int overhang_layers;          /* layers with at least one interior overhang pixel */
	int worst_layer;              /* -1 when none */
	long long worst_layer_px;
	long long *overhang_px;       /* per layer (layers entries, owned): interior px on that layer */
	/* the largest distance by which a solid point over an enclosed void
	 * lies farther from the layer below's solid than layer_mm tan(alpha)
	 * (sub-pixel, verify.c); 0 when no point does.  In mm and in pixels
	 * of the larger pitch */
	double slope_excess_mm, slope_excess_px;
	double tolerance_px;          /* the tolerance the check ran with */
	/* overhangs over voids open to the outside (removable supports) */
	double exterior_overhang_mm2;
	/* with a reference stack (verify_layer_ref): overhangs over the
	 * part's own air that the layers' linking reads as enclosed (a sealed
	 * pocket of the part, a slanted crevice under thick layers), the
	 * part's and not the interior's; counted in neither of the two above */
	double part_overhang_mm2;
	/* floating islands */
	long long islands;
	double island_mm2;
	int first_island_layer;       /* -1 when none */
	/* islands the interior adds: an island with a pixel over a void that
	 * the layer below encloses (2D: its void component does not reach
	 * the image border), where the part filled solid would have held it
	 * up.  The others (islands - islands_interior, metric islands_part)
	 * start over the outside: the part's own features that begin in mid
	 * air and need external supports whatever fills it */
	long long islands_interior;
	double island_interior_mm2;
	int first_interior_island_layer; /* -1 when none */
	/* islands the solid part does not have (only with a reference stack,
	 * verify_layer_ref): islands none of whose pixels lies within
	 * ceil(tolerance_px) (Chebyshev) of a pixel of an island of the reference's
	 * same layer (the part's own first contacts: an overhanging chin) */
	int has_reference;
	long long islands_added;
	double island_added_mm2;
	int first_added_island_layer; /* -1 when none */
	int first_solid_layer;        /* lowest layer with a solid pixel, -1 if none */
	/* walls between enclosed voids and the outside (definitions:
	 * verify.c head comment, docs/verify.md); specks excluded */
	double min_wall_mm;           /* in-layer (2D distance); INFINITY without enclosed voids */
	int min_wall_layer;
	double min_wall_vertical_mm;  /* along columns (floors and ceilings); INFINITY if none */
	double enclosed_void_mm3;     /* volume of enclosed voids, specks included */
	long long specks;             /* enclosed 3D void components of <= speck_voxels voxels */
	double speck_min_wall_mm;     /* smallest in-layer wall around a speck; INFINITY if none */
	/* fins: solid pixels in a run of at most 2 pixels (along a row, a
	 * column or a diagonal) with enclosed void at both ends: solid too
	 * thin to print standing between cavities (or between two parts of
	 * one); a convex tip of thicker solid adds a pixel or two */
	long long fin_px;
	double fin_mm3;               /* fin_px as volume (pixel area x layer height) */
	/* slivers: fin pixels none of whose solid 4-neighbours is solid
	 * beyond the fins (fins.h): standing free, not a bump on a wall */
	long long sliver_px;
	double sliver_mm3;
	/* walls between two cavities (enclosed 3D void components, neither
	 * a speck; a partition inside one cavity is not one): in-layer, the
	 * centre distance between their nearest pixels less one pixel, an
	 * upper bound exact along rows and columns (between.h); along
	 * columns, solid runs with the two cavities at its ends */
	double min_wall_between_mm;   /* INFINITY when no layer holds two cavities */
	int min_wall_between_layer;   /* 0-based layer of that minimum, -1 if none */
	double min_wall_between_vertical_mm; /* INFINITY if none */
	/* shelves: solid voxels in column runs of at most 2 layers with
	 * enclosed void at both ends (one cavity or two): the vertical
	 * counterpart of fins */
	long long shelf_px;
	double shelf_mm3;             /* shelf_px as volume */
};

void verify_report_fini(struct verify_report *r);

struct verify;

/* Check p (ERR_PARAM naming the field) and start a check.  Caller frees
 * with verify_free(). */
int verify_new(const struct verify_params *p, struct verify **out, struct err *e);
void verify_free(struct verify *v);

/* Feed the next layer (layers in print order).  All layers must have the
 * same size (ERR_PARAM otherwise).  r is borrowed for the call. */
int verify_layer(struct verify *v, const struct raster *r, struct err *e);
/* The same with ref, the same layer of a reference stack (the solid part
 * sliced by the same printer, same image size; borrowed for the call),
 * against which islands are told apart (the report's islands_added) and
 * the part's own air: a void component with a pixel that ref holds void
 * is the outside, its overhang counted in part_overhang_mm2.  Give a
 * reference on every layer or on none (ERR_FIELD "reference"). */
int verify_layer_ref(struct verify *v, const struct raster *r, const struct raster *ref,
		     struct err *e);

/* Corner fits kept by neighbourhood across calls (corner.h): a hollow
 * engine's mending reads each pair of layers several times, and each
 * layer as the upper and then the lower one.  One memo may serve calls on
 * several threads at once.  slots: rounded down to a power of two (0: the
 * default, 65,536, 7.3 MB touched as used).  Returns the memo, which the
 * caller frees with verify_fit_memo_free, or NULL when out of memory. */
struct verify_fit_memo;
struct verify_fit_memo *verify_fit_memo_new(size_t slots);
void verify_fit_memo_free(struct verify_fit_memo *m);
/* Fits looked up in m since it was made (the corner fits past the
 * one-edge gate), and those of them it held. */
void verify_fit_memo_stats(const struct verify_fit_memo *m, size_t *lookups, size_t *hits);

/* How verify_far_pixels reads a pair of layers. */
struct verify_pair_read {
	double px_mm, py_mm; /* pitches along columns and rows */
	double reach_mm;     /* a pixel reading farther is passed to fn */
	int threads;         /* as verify_params (the pixels are read on
			      * them, fn is called on the caller's thread) */
	struct verify_fit_memo *memo; /* borrowed; NULL: fits made per call */
};

/* The overhang reading of verify_layer for one pair of images, pixel by
 * pixel: below (layer k) and above (layer k + 1), crops of one size of
 * the layer images, their pixel (0, 0) the images' pixel (ox, oy) (the
 * model reads in image coordinates, as verify_layer does, so a crop
 * reads each pixel as the whole image does).  For every pixel
 * of above with some solid over a pixel of below that is not whole
 * solid, the largest distance (mm) from a point of its solid to below's
 * solid, each read at sub-pixel accuracy (docs/verify.md "Sub-pixel
 * overhangs"; pixels beyond the images are empty); fn(ctx, x, y, far_mm)
 * is called (x, y: crop pixels), row by row, for each pixel where that
 * exceeds rd->reach_mm (a lower bound where it is far beyond; INFINITY
 * with no solid in reach).
 * A nonzero return of fn stops the calls (every pixel is read first) and
 * is returned.  Unlike
 * verify_layer this does not tell enclosed voids from the outside.
 * 0, ERR_PARAM (sizes), ERR_NOMEM or fn's. */
int verify_far_pixels(const struct raster *below, const struct raster *above, int ox, int oy,
		      const struct verify_pair_read *rd,
		      int (*fn)(void *ctx, int x, int y, double far_mm), void *ctx, struct err *e);
/* The same for the pixels of above in the crop box [bx0, bx1] x [by0, by1]
 * only (clipped to the crops), each read as in the whole crops. */
int verify_far_pixels_in(const struct raster *below, const struct raster *above, int ox, int oy,
			 const struct verify_pair_read *rd, int bx0, int by0, int bx1, int by1,
			 int (*fn)(void *ctx, int x, int y, double far_mm), void *ctx,
			 struct err *e);

/* How far (pixels, either axis) verify_far_pixels' reading of one pixel
 * looks at below for the given reach and pitches: a pixel of below
 * farther than this from every pixel of above changes no reading. */
int verify_far_pad_px(double reach_mm, double px_mm, double py_mm);

/* Close the stack (the space above the last layer is outside) and fill
 * *out (replaced; caller frees with verify_report_fini).  The check can
 * not be fed afterwards. */
int verify_finish(struct verify *v, struct verify_report *out, struct err *e);

/* Record the report under "<prefix>." (e.g. "verify.interior_overhang_mm2"). */
int verify_report_metrics(const struct verify_report *r, const char *prefix, struct metrics *m,
			  struct err *e);

/* Check a written layer archive (PrusaSlicer SL1/SL1S or a plain zip of
 * PNG layers): layers are the PNGs outside thumbnail/, in file-name order;
 * layer height and pixel pitch come from config.ini (layerHeight) and
 * prusaslicer.ini (display_width/height, display_pixels_x/y,
 * display_orientation) unless p gives them (> 0).  alpha_deg from p.
 * Reads with libarchive and libpng; holds the compressed PNGs in memory
 * only when the archive does not list them in order. */
int verify_archive(const char *path, const struct verify_params *p, struct verify_report *out,
		   struct err *e);
/* The same with ref_path (NULL: none), a reference archive with layers of
 * the same size (the solid engine's output for the same part
 * and printer), fed to verify_layer_ref(): the report's islands_added.
 * Its layers above the reference's last are compared with empty layers;
 * the reference's extra layers are not read.  Layer height and pixel
 * pitch come from path's own ini files. */
int verify_archive_ref(const char *path, const char *ref_path, const struct verify_params *p,
		       struct verify_report *out, struct err *e);

/* A layer archive's stack as its writer described it. */
struct verify_stack {
	int layers;            /* layer images, print order (layer k spans z from
				  k * layer_mm to (k + 1) * layer_mm above the plate) */
	int width, height;     /* pixels of layer 0 (the others are checked as decoded) */
	double layer_mm;       /* config.ini layerHeight / manifest.json; 0 if unstated */
	int has_map;           /* map is known */
	struct raster_map map; /* printer mm -> pixel (raster.h) as the writer used it:
				  from prusaslicer.ini's display (printer_raster_geometry)
				  or a plain zip's manifest.json map_mm_to_px */
};

struct verify_stack_reader;

/* Open a layer archive (as verify_archive reads it: the PNGs outside
 * thumbnail/, in print order), holding its compressed layers in memory
 * (a few KB each; at most 4 GB in all), and describe it in *st.  ERR_IO,
 * ERR_PARSE, ERR_LIMIT, ERR_NOMEM.  Caller closes with verify_stack_close(). */
int verify_stack_open(const char *path, struct verify_stack_reader **out, struct verify_stack *st,
		      struct err *e);
/* Decode layer k (0 = on the plate) into *img (allocated or reallocated to
 * the layer's size; caller frees with raster_free).  Calls for distinct
 * img may run on several threads at once.  ERR_PARSE, ERR_LIMIT, ERR_NOMEM. */
int verify_stack_layer(const struct verify_stack_reader *r, int k, struct raster **img,
		       struct err *e);
void verify_stack_close(struct verify_stack_reader *r);

#endif
