/* raster.h - 8-bit grayscale layer images and their placement.
 *
 * A raster is what a resin printer exposes: 0 = empty, 255 = fully cured,
 * values between = partial coverage (anti-aliasing).  Row 0 is the first
 * row stored in the image file.  Where the image sits on the build plate
 * is a struct raster_map: an affine map from printer millimetres (x, y)
 * to continuous pixel coordinates (u = column, v = row), where pixel
 * (i, j) covers [i, i+1) x [j, j+1) and its centre is (i+0.5, j+0.5).
 * Printer profiles build the map (orientation, mirroring, pixel pitch);
 * rasterisers and engines that render pixels directly (lattice) use it,
 * so no image is ever transposed or flipped after the fact.
 */
#ifndef INFILLD_RASTER_H
#define INFILLD_RASTER_H

#include <stddef.h>
#include <stdint.h>

struct raster {
	int w, h;        /* pixels */
	size_t stride;   /* bytes per row (>= w) */
	uint8_t *px;     /* owned, h * stride bytes */
};

struct raster_map {
	/* u = a[0][0]*x + a[0][1]*y + b[0];  v = a[1][0]*x + a[1][1]*y + b[1]
	 * (x, y in mm; u, v in pixels).  Pitch is |det a|^(-1/2) mm. */
	double a[2][2];
	double b[2];
};

/* Allocate a zeroed w x h raster.  Returns NULL on ERR_NOMEM or if w or h
 * is not in 1..65535.  Caller frees with raster_free(). */
struct raster *raster_new(int w, int h);
void raster_free(struct raster *r);
void raster_clear(struct raster *r);

/* Pixel coordinates of printer point (x_mm, y_mm). */
void raster_map_apply(const struct raster_map *m, double x_mm, double y_mm, double *u, double *v);
/* Printer point of pixel coordinates (u, v).  Returns 0, or -1 if the map
 * is singular. */
int raster_map_invert(const struct raster_map *m, double u, double v, double *x_mm,
		      double *y_mm);
/* Area of one pixel in mm^2. */
double raster_map_pixel_area_mm2(const struct raster_map *m);

/* Sum of pixel values / 255, i.e. the covered area in pixels. */
double raster_coverage_px(const struct raster *r);

/* The first and last x of row[0..w) with row[x] >= thr (thr >= 1) into
 * *x0, *x1; returns 0 (both untouched) when there is none.  Zero bytes
 * are skipped eight at a time: most of a layer image is empty. */
int raster_row_span(const uint8_t *row, int w, int thr, int *x0, int *x1);

#endif
