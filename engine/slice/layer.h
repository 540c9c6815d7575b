/* layer.h - one printed layer and the layer schedule.
 *
 * Schedule: layer k (0-based) spans [k*layer_mm, (k+1)*layer_mm] above the
 * build plate and is sampled at its middle, z = (k + 0.5) * layer_mm, so
 * no sampling plane ever passes through a vertex or a horizontal face at
 * the part's top or bottom (which sit at layer boundaries after
 * placement).  The layer count is ceil(height_mm / layer_mm).
 */
#ifndef INFILLD_LAYER_H
#define INFILLD_LAYER_H

#include "engine/geom/path.h"
#include "engine/geom/raster.h"

enum layer_fill {
	LAYER_FILL_PART = 0, /* region is the part's bulk: FDM may use sparse
				infill plus top/bottom skins */
	LAYER_FILL_SOLID     /* region is designed material: deposit all of it */
};

struct layer {
	int index, count;
	double z_mm;        /* sample height, middle of the layer (printer frame) */
	double z_top_mm;    /* top of the layer: where an FDM nozzle prints it */
	double height_mm;
	struct paths region;   /* material region, normalised (path.h); filled by
				  the engine when the output wants regions */
	struct raster *raster; /* non-NULL when the output wants pixels: zeroed;
				  an engine MAY render into it and set
				  raster_ready, else the driver rasterises region */
	int raster_ready;
	enum layer_fill fill;
};

/* Most layers a job may have (5 m of part at 1 um layers). */
#define LAYER_MAX_COUNT 5000000

/* Number of layers for a part of this height: ceil(height_mm / layer_mm),
 * >= 1 for height > 0 (an excess below 1e-9 layer is rounding noise and
 * does not add a layer).  Returns 0 when either argument is not a
 * positive finite number or the count would exceed LAYER_MAX_COUNT. */
int layer_count_for(double height_mm, double layer_mm);
/* Fill index, count, z_mm, z_top_mm and height_mm of ly for layer k
 * (other fields untouched). */
void layer_place(struct layer *ly, int k, int count, double layer_mm);

#endif
