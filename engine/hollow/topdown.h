/* topdown.h - the top-down support-free fill (topdown.c): the largest
 * void a greedy top-down construction fits inside the offset stack,
 * print layer by print layer on the verifier's pixel grid, used where the
 * optimiser left space unhollowed.  Design: docs/hollow.md "Top-down fill".
 */
#ifndef INFILLD_HOLLOW_TOPDOWN_H
#define INFILLD_HOLLOW_TOPDOWN_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/hollow/grid.h"

struct mesh;
struct err;
struct hl_config;
struct progress;

struct hl_fill_layer {
	struct hl_run *run; /* void pixels, grid coordinates, row-major */
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
};

void hl_fill_fini(struct hl_fill *f);

/* Fill f with the top-down support-free void of the region that keeps
 * c->wall_mm from part's surface and, when solid != NULL (part minus the
 * optimised voids, one closed mesh), c->wall_next_mm from solid's surface,
 * designed on the pixels of c->fill_map (an axis-aligned printer-mm ->
 * image-pixel map; the very pixels the verifier reads) and the print
 * layers of c->print_layer_mm.  Consecutive layers obey the overhang rule
 * (docs/hollow.md).  Components under c->min_void_mm3 are dropped.
 * prog (may be NULL) advances from f0 to f1 and can cancel.
 * Returns 0 (f replaced; left empty when the map is not axis-aligned),
 * ERR_NOMEM, ERR_LIMIT, ERR_CANCELLED or a slicer error. */
int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_config *c,
		  struct progress *prog, double f0, double f1, struct hl_fill *f, struct err *e);

/* Volume (mm^3) of f's void and the (x, y) of its centroid (printer mm;
 * 0, 0 when empty), from its pixel centres. */
void hl_fill_mass(const struct hl_fill *f, double *vol_mm3, double cxy[2]);

/* Layer source for slice/erode.h over a slicer: layer k is the slice at
 * (k + 1/2) layer_mm.  ctx is a struct hl_src_ctx (borrowed). */
struct slicer;
struct hl_src_ctx {
	struct slicer *s;
	double layer_mm;
};
int hl_src_layer(void *ctx, int k, struct paths *region, struct err *e);

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
struct vec3;
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

#endif
