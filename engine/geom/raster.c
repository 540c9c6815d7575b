/* raster.c - layer images and pixel maps (see raster.h). */
#include "engine/geom/raster.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

struct raster *raster_new(int w, int h)
{
	struct raster *r;

	if (w < 1 || h < 1 || w > 65535 || h > 65535)
		return NULL;
	r = mem_alloc(sizeof *r);
	if (!r)
		return NULL;
	r->w = w;
	r->h = h;
	r->stride = (size_t)w;
	r->px = mem_calloc((size_t)h, r->stride);
	if (!r->px) {
		mem_free(r);
		return NULL;
	}
	return r;
}

void raster_free(struct raster *r)
{
	if (!r)
		return;
	mem_free(r->px);
	mem_free(r);
}

void raster_clear(struct raster *r)
{
	memset(r->px, 0, (size_t)r->h * r->stride);
}

void raster_map_apply(const struct raster_map *m, double x, double y, double *u, double *v)
{
	*u = m->a[0][0] * x + m->a[0][1] * y + m->b[0];
	*v = m->a[1][0] * x + m->a[1][1] * y + m->b[1];
}

int raster_map_invert(const struct raster_map *m, double u, double v, double *x, double *y)
{
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	double du = u - m->b[0], dv = v - m->b[1];

	if (det == 0.0)
		return -1;
	*x = (m->a[1][1] * du - m->a[0][1] * dv) / det;
	*y = (-m->a[1][0] * du + m->a[0][0] * dv) / det;
	return 0;
}

double raster_map_pixel_area_mm2(const struct raster_map *m)
{
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	return det != 0.0 ? 1.0 / fabs(det) : 0.0;
}

double raster_coverage_px(const struct raster *r)
{
	uint64_t sum = 0;

	for (int j = 0; j < r->h; j++) {
		const uint8_t *row = r->px + (size_t)j * r->stride;
		for (int i = 0; i < r->w; i++)
			sum += row[i];
	}
	return (double)sum / 255.0;
}

int raster_row_span(const uint8_t *row, int w, int thr, int *x0, int *x1)
{
	int x = 0, b;

	for (;;) {
		uint64_t word;
		int end;
		while (x + 8 <= w) {
			memcpy(&word, row + x, sizeof word);
			if (word)
				break;
			x += 8;
		}
		if (x >= w)
			return 0;
		end = x + 8 < w ? x + 8 : w;
		while (x < end && row[x] < thr)
			x++;
		if (x < end)
			break;
	}
	b = w - 1;
	while (row[b] < thr)
		b--;
	*x0 = x;
	*x1 = b;
	return 1;
}
