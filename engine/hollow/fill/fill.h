/* fill.h - the top-down support-free pixel fill (engine/hollow/fill/):
 * the largest void a greedy top-down construction fits inside the offset
 * part, print layer by print layer on the verifier's pixel grid, used
 * where the optimiser (engine/hollow/opt/) left space unhollowed; and the
 * beads ("fragments") the print layers split off the optimiser's voids.
 * Design: docs/hollow.md "Top-down fill" and "Fragments".  Frame: printer
 * frame, mm, z up; grids in pixels of a raster_map.
 */
#ifndef INFILLD_HOLLOW_FILL_H
#define INFILLD_HOLLOW_FILL_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/geom/raster.h"

struct mesh;
struct err;
struct progress;
struct vec3;

/* One run of set pixels: row y, columns x0..x1 inclusive (grid pixels). */
struct hl_span {
	int32_t y, x0, x1;
	uint32_t comp; /* 3D component id (the last grouping: hl_fill_components,
			* or hl_fill_build's walls pass), 0 before any */
};

struct hl_fill_params {
	double wall_mm;      /* the void keeps this far from the part's surface */
	double wall_next_mm; /* ... from the solid's (optimised voids') surfaces, and
			      * is the wall between two fill voids */
	double pixel_mm;     /* pitch of the erosion grid (the offsets) */
	double layer_mm;     /* print layer height */
	double alpha_rad;    /* overhang limit, from the vertical */
	double margin_rad;   /* safety subtracted from alpha in the design shrink */
	double min_void_mm3; /* smaller 3D components are turned solid */
	int lean;            /* walls between voids lean at the design slope (else stand) */
	int corners;         /* with lean: convex void corners grow square where the rule
			      * allows (hl_step_prune) */
	struct raster_map map; /* printer mm -> pixels of the images the verifier reads */
	/* keep to a half-plane: a pixel centre (x, y) (printer mm) may be void
	 * only where keep[0] x + keep[1] y < keep[2] (stability) */
	int keep_set;
	double keep[3];
	int threads;         /* threads the distance transforms may use (<= 1: one;
			      * the result does not depend on it) */
};

struct hl_fill_layer {
	struct hl_span *run; /* void pixels, grid coordinates, row-major */
	size_t n;
};

struct hl_fill {
	struct hl_fill_layer *layer; /* n print layers: layer j = slab [j, j + 1] * layer_mm */
	int n;
	double layer_mm;     /* print layer height */
	int u0, v0;          /* grid pixel (x, y) is image pixel (u0 + x, v0 + y) of the map */
	int w, h;            /* grid size */
	struct raster_map map; /* printer mm -> image pixels (the one the grid lies on) */
	size_t voids;        /* 3D components kept (4-connected in a layer, linked vertically) */
	size_t voids_small;  /* components dropped: below min_void_mm3 */
	double volume_mm3;   /* of the kept components */
	long apart_cut_px;   /* void pixels turned solid to keep two voids
			      * wall_next apart (hl_fill_build; 0 for fragments) */
	long apart_left_layers; /* layers where two voids still lie nearer than
				 * wall_next (docs/hollow.md 4.2) */
};

void hl_fill_fini(struct hl_fill *f);

/* Fill f with the top-down support-free void of the region that keeps
 * c->wall_mm from part's surface and, when solid != NULL (part minus the
 * optimised voids, one closed mesh), c->wall_next_mm from solid's surface,
 * designed on the pixels of c->map (an axis-aligned printer-mm ->
 * image-pixel map; the very pixels the verifier reads) and the print
 * layers of c->layer_mm.  Consecutive layers obey the overhang rule
 * (docs/hollow.md).  Components under c->min_void_mm3 are dropped; two
 * voids keep c->wall_next_mm apart in every layer where the layer below
 * allows (apart.c; f->apart_cut_px, f->apart_left_layers).
 * prog (may be NULL) advances from f0 to f1 and can cancel.
 * Returns 0 (f replaced; left empty when the map is not axis-aligned),
 * ERR_NOMEM, ERR_LIMIT, ERR_CANCELLED or a slicer error. */
int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_fill_params *c,
		  struct progress *prog, double f0, double f1, struct hl_fill *f, struct err *e);

/* Volume (mm^3) of f's void and the (x, y) of its centroid (printer mm;
 * 0, 0 when empty), from its pixel centres. */
void hl_fill_mass(const struct hl_fill *f, double *vol_mm3, double cxy[2]);

/* The fill's layer for a print layer whose mid-plane is at z_mm:
 * borrowed, NULL when it has no void pixels. */
const struct hl_fill_layer *hl_fill_at(const struct hl_fill *f, double z_mm);

/* Set the pixels of layer l to val in image r (0: the fill's void
 * cleared; 255: fragments painted solid), drawn through f->map: r must
 * be an image of that map. */
void hl_fill_paint(const struct hl_fill *f, const struct hl_fill_layer *l, struct raster *r,
		   uint8_t val);

/* Grid of map m over the box of pts[0..nv): f->u0, v0, w, h (2 pixels of
 * margin); *px, *py the pitches (mm).  ERR_LIMIT past 65535 pixels a side
 * or 2^28 pixels. */
int hl_fill_grid(const struct vec3 *pts, size_t nv, const struct raster_map *m, struct hl_fill *f,
		 double *px, double *py, struct err *e);

/* Group f's runs into 3D components (4-connected in a layer, linked to
 * the runs directly above and below: the verifier's void connectivity;
 * px_area_mm2 x f->layer_mm per pixel) and keep the components of at
 * least min_mm3 (keep_small 0: the fill drops small voids, void turned
 * solid) or only those under it (keep_small 1: fragments.c).  f->voids
 * and f->volume_mm3 count the kept components, f->voids_small the
 * others.  0, ERR_NOMEM or ERR_LIMIT (over 2^32 runs). */
int hl_fill_components(struct hl_fill *f, double min_mm3, double px_area_mm2, int keep_small,
		       struct err *e);

/* The fill's void of layer l as a region (nm, printer frame): contours at
 * half way between void and solid pixel centres.  Replaces *region. */
int hl_fill_region(const struct hl_fill *f, const struct hl_fill_layer *l, struct paths *region,
		   struct err *e);

/* The 3D components under min_mm3 of the optimised voids' pixels in the
 * print layers of out (the part's surface, then from vertex void_v0 and
 * triangle void_t0 on the void surfaces), each layer k (mid-plane
 * (k + 1/2) layer_mm) rasterised through map with antialias as the layer
 * pass does and read solid at >= threshold (the verifier's).  f (zeroed
 * or finished) gets them as runs: f->voids components, f->volume_mm3
 * their volume; empty without voids.  0, ERR_NOMEM, ERR_LIMIT or a slicer
 * error (f left empty). */
int hl_fragments_find(const struct mesh *out, size_t void_v0, size_t void_t0,
		      const struct raster_map *map, int antialias, int threshold, double layer_mm,
		      double min_mm3, struct hl_fill *f, struct err *e);

#endif
