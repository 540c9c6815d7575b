/* layer.c - the layer schedule (see layer.h and docs/slicing.md).
 *
 * Layer k spans [k*layer_mm, (k+1)*layer_mm] and is sampled at its
 * middle; the count is ceil(height/layer_mm) with a relative tolerance
 * of 1e-9 layer so a 50 mm part at 0.05 mm gets 1000 layers, not 1001,
 * whatever the last bit of 50/0.05 says.
 */
#include "engine/slice/layer.h"

#include <limits.h>
#include <math.h>

/* A part whose height exceeds an integer number of layers by less than
 * this fraction of a layer (about 50 fm at 0.05 mm) gets that number:
 * the excess is floating-point noise of the placement, not material. */
#define LAYER_COUNT_SLACK 1e-9

int layer_count_for(double height_mm, double layer_mm)
{
	double n;

	if (!(height_mm > 0) || !(layer_mm > 0) || !isfinite(height_mm) || !isfinite(layer_mm))
		return 0;
	n = ceil(height_mm / layer_mm - LAYER_COUNT_SLACK);
	if (n < 1)
		n = 1;
	if (n > (double)LAYER_MAX_COUNT)
		return 0;
	return (int)n;
}

void layer_place(struct layer *ly, int k, int count, double layer_mm)
{
	ly->index = k;
	ly->count = count;
	ly->z_mm = ((double)k + 0.5) * layer_mm;
	ly->z_top_mm = ((double)k + 1.0) * layer_mm;
	ly->height_mm = layer_mm;
}
