/* repair.h - the layer images of the optimised voids mended to the
 * verifier's sub-pixel reading (repair.c; docs/hollow.md "Mended
 * images"), and the drawing of one layer that both the mending and the
 * layer pass use.  Frame: printer mm through a raster_map; images in
 * pixels of that map, crops offset by (x0, y0).
 */
#ifndef INFILLD_HOLLOW_REPAIR_H
#define INFILLD_HOLLOW_REPAIR_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/hollow/fill/fill.h"

struct err;
struct mesh;
struct slicer;

/* Draw print layer z_mm's image into r, whose pixel (0, 0) is pixel
 * (x0, y0) of map's images: region (the hollowed part's section, nm)
 * rasterised with antialias (max-ed into r: the caller clears it), then
 * frag's pixels of that layer painted solid and fill's cleared (either
 * may be NULL).  0, ERR_NOMEM or a rasteriser error. */
int hl_layer_draw(const struct paths *region, const struct raster_map *map, int antialias,
		  const struct hl_fill *fill, const struct hl_fill *frag, double z_mm, int x0,
		  int y0, struct raster *r, struct err *e);

/* The same layer as a mesh output with stepped voids (hmesh.h) slices
 * again: part (the part's own section) drawn into part_img with antialias
 * (the printer's: the mesh's outer surface is the input's), and where that
 * is wholly solid (255), region at pixel centres (0 or 255); then frag and
 * fill as hl_layer_draw paints them.  r and part_img: the same size
 * (ERR_PARAM otherwise), cleared by the caller; part_img keeps the part's
 * drawing.  0, ERR_PARAM, ERR_NOMEM or a rasteriser error. */
int hl_layer_draw_stepped(const struct paths *region, const struct paths *part,
			  const struct raster_map *map, int antialias, const struct hl_fill *fill,
			  const struct hl_fill *frag, double z_mm, int x0, int y0, struct raster *r,
			  struct raster *part_img, struct err *e);

/* Passes of the mending a layer gets at most. */
#define HL_REPAIR_PASSES 8

/* Carving (hl_repair_build, carve 1) keeps the wall to the part's
 * outside but this many pixels (the larger pitch): it cuts only where the
 * part's 3D distance to its outside is wall_mm less that. */
#define HL_CARVE_SLACK_PX 2

/* One mended pixel: image pixel (x, y) drawn with gray g (raised by the
 * mending, 0 where carved). */
struct hl_mend {
	int32_t x, y;
	uint8_t g;
};

struct hl_repair {
	struct { struct hl_mend *px; size_t n; } *layer; /* n print layers */
	int n;
	double layer_mm;
	long long pixels;  /* mended pixels, all layers */
	double mm3;        /* solid they add: gray added / 255 x pixel x layer
			    * (negative when carved) */
	int layers;        /* layers with a mended pixel */
	int layers_left;   /* layers where a pixel still reads over after the passes */
	double seconds;
};

void hl_repair_fini(struct hl_repair *r);

/* Mend the layers of res (the part: its first part_nv vertices and
 * part_nt triangles, then the optimised voids' surfaces; res_slicer, the
 * caller's, slices it) drawn as hl_layer_draw does through map with
 * antialias, with fill and frag (may be NULL), print layers of layer_mm,
 * over the layers the voids span (and one more each way), on the image
 * box of their surfaces grown by the reach.  A pixel of layer k + 1 that
 * reads farther than reach_mm from layer k's solid (verify_far_pixels,
 * pitches px_mm, py_mm) is over.
 * - carve 0 (grey edges), top down: the pixel of layer k under an over
 *   pixel takes layer k + 1's gray there, or when it has that already its
 *   eight neighbours take theirs, where the part is wholly solid, up to
 *   HL_REPAIR_PASSES times a layer (each pass after the first reading
 *   only what its raises can change); islands the mending made in layer
 *   k + 1 get its gray under them; the gray added to layer k is checked
 *   against layer k - 1 in its turn.  Only solid is added.
 * - carve 1 (a mesh's stepped voids: layers drawn by
 *   hl_layer_draw_stepped, antialias unused), bottom up: an over pixel of
 *   layer k + 1 is cleared where the part at layers k and k + 1 is wholly
 *   solid (what it hangs over is a void, and no cut opens the part's
 *   surface) and, for wall_mm > HL_CARVE_SLACK_PX pixels, where the part's
 *   3D distance to its outside is at least wall_mm less those pixels, up
 *   to HL_REPAIR_PASSES passes a layer, over the layers the voids span and
 *   one more each way, and on upward while a layer loses solid (a void's
 *   top rising until it closes: each layer's cuts lie over the void of the
 *   one under it, farther than the reach from its solid); layer k + 2 is
 *   read against the carved layer in its turn.  Only solid over the voids
 *   is taken.
 * Only pixels inside the part change.  r (zeroed or finished) receives
 * the changed pixels per layer.  0, ERR_NOMEM, ERR_LIMIT (a box over
 * 2^28 pixels) or a slicer error. */
int hl_repair_build(const struct mesh *res, struct slicer *res_slicer, size_t part_nv,
		    size_t part_nt, const struct raster_map *map, int antialias, const struct hl_fill *fill,
		    const struct hl_fill *frag, double layer_mm, double px_mm, double py_mm,
		    double reach_mm, double wall_mm, int carve, int threads, struct hl_repair *r,
		    struct err *e);

/* Draw the mended pixels of the print layer at mid-plane z_mm into r, an
 * image of the map r was built on, drawn as r was built (hl_layer_draw, or
 * hl_layer_draw_stepped when carved; each pixel set to its gray; pixels
 * outside r skipped). */
void hl_repair_apply(const struct hl_repair *rp, double z_mm, struct raster *r);

#endif
