/* pair.c - the overhang reading of verify_layer for one pair of layer
 * images, pixel by pixel, for a caller that mends its layers before they
 * are written (verify.h: verify_far_pixels; the hollow engine's repair).
 * The bounds and the measurement are verify_overhangs()' (support.c):
 * an upper bound from the nearest solid pixel settles most pixels, a
 * lower bound from the nearest grey one the gross overhangs, and the rest
 * are measured by subpx.h.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/geom/edt.h"
#include "engine/geom/raster.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify.h"

struct pair_scratch {
	uint8_t *box_below, *box_above; /* the pixels' box of each image */
	uint8_t *seed;
	float *d2_solid, *d2_any;
	int32_t *near;
	double *far; /* per box pixel: its reading (mm), -INFINITY when not read */
	struct verify_subpx_fits fb, fa;
	struct edt_scratch es;
};

/* One row of the box, read on any thread (parfor.h): each pixel's
 * reading into far[], so that the caller's fn sees them in row order
 * whatever the threads. */
struct pair_rows {
	const struct pair_scratch *s;
	const struct verify_subpx_img *bi, *ai;
	int x0, y0, bx0, by0, bx1, by1;
	double reach_mm;
};

static void pair_row(void *ctx, size_t row, int tid)
{
	const struct pair_rows *r = ctx;
	const struct pair_scratch *s = r->s;
	const uint8_t *a = r->ai->gray, *b = r->bi->gray;
	int w = r->ai->w, y = (int)row;

	(void)tid;
	for (int x = 0; x < w; x++) {
		size_t i = (size_t)y * (size_t)w + (size_t)x;
		double u = INFINITY;
		s->far[i] = -INFINITY;
		if (a[i] == 0 || b[i] == 255 || x + r->x0 < r->bx0 || x + r->x0 > r->bx1 ||
		    y + r->y0 < r->by0 || y + r->y0 > r->by1)
			continue;
		if (s->near[i] >= 0)
			u = sqrt(s->d2_solid[i]) +
			    verify_subpx_gap_mm(r->bi, s->near[i] % w + r->bi->x0,
						s->near[i] / w + r->bi->y0);
		if (u <= r->reach_mm)
			continue;
		s->far[i] = verify_subpx_far_bounded_mm(r->bi, r->ai, x + r->ai->x0, y + r->ai->y0,
							a[i], u, sqrt(s->d2_any[i]), r->reach_mm);
	}
}

static void pair_fini(struct pair_scratch *s)
{
	mem_free(s->box_below);
	mem_free(s->box_above);
	mem_free(s->seed);
	mem_free(s->d2_solid);
	mem_free(s->d2_any);
	mem_free(s->near);
	mem_free(s->far);
	verify_subpx_fits_fini(&s->fb);
	verify_subpx_fits_fini(&s->fa);
	edt_scratch_fini(&s->es);
}

/* Grey pixels (0 < gray < 255) of r. */
static size_t grey_count(const struct raster *r)
{
	size_t n = 0;

	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++) {
			uint8_t g = r->px[(size_t)y * r->stride + (size_t)x];
			n += g > 0 && g < 255;
		}
	return n;
}

int verify_far_pad_px(double reach_mm, double px_mm, double py_mm)
{
	/* the window of verify_subpx_far_mm, at most (reach + 6 hd) / pmin
	 * with hd the half diagonal, and the 5 x 5 neighbourhood of each
	 * pixel in it */
	return (int)ceil((reach_mm + 3 * hypot(px_mm, py_mm)) / fmin(px_mm, py_mm)) + 3;
}

int verify_far_pixels(const struct raster *below, const struct raster *above, int ox, int oy,
		      const struct verify_pair_read *rd,
		      int (*fn)(void *ctx, int x, int y, double far_mm), void *ctx, struct err *e)
{
	return verify_far_pixels_in(below, above, ox, oy, rd, 0, 0, above->w - 1, above->h - 1, fn,
				    ctx, e);
}

int verify_far_pixels_in(const struct raster *below, const struct raster *above, int ox, int oy,
			 const struct verify_pair_read *rd, int bx0, int by0, int bx1, int by1,
			 int (*fn)(void *ctx, int x, int y, double far_mm), void *ctx,
			 struct err *e)
{
	double px_mm = rd->px_mm, py_mm = rd->py_mm, reach_mm = rd->reach_mm;
	int threads = rd->threads;
	struct pair_scratch s;
	struct raster b, a;
	int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1, pad, rc = 0;
	size_t np;

	if (below->w != above->w || below->h != above->h)
		return ERR_SET(e, ERR_PARAM, "verify: a pair of layers of different sizes");
	/* the pixels of the box that can read over: some solid over a pixel
	 * not whole */
	bx0 = bx0 < 0 ? 0 : bx0;
	by0 = by0 < 0 ? 0 : by0;
	bx1 = bx1 >= above->w ? above->w - 1 : bx1;
	by1 = by1 >= above->h ? above->h - 1 : by1;
	for (int y = by0; y <= by1; y++) {
		const uint8_t *ra = above->px + (size_t)y * above->stride;
		const uint8_t *rb = below->px + (size_t)y * below->stride;
		for (int x = bx0; x <= bx1; x++)
			if (ra[x] && rb[x] != 255) {
				x0 = x < x0 ? x : x0;
				x1 = x > x1 ? x : x1;
				y0 = y < y0 ? y : y0;
				y1 = y > y1 ? y : y1;
			}
	}
	if (x1 < 0)
		return 0;
	/* their box, grown past every pixel of below that a reading within
	 * the reach looks at: a pixel read over for want of solid beyond the
	 * box reads over with it too */
	pad = verify_far_pad_px(reach_mm, px_mm, py_mm);
	x0 = x0 - pad < 0 ? 0 : x0 - pad;
	y0 = y0 - pad < 0 ? 0 : y0 - pad;
	x1 = x1 + pad >= above->w ? above->w - 1 : x1 + pad;
	y1 = y1 + pad >= above->h ? above->h - 1 : y1 + pad;
	b.w = a.w = x1 - x0 + 1;
	b.h = a.h = y1 - y0 + 1;
	b.stride = a.stride = (size_t)b.w;
	np = (size_t)b.w * (size_t)b.h;
	memset(&s, 0, sizeof s);
	edt_scratch_init(&s.es);
	s.es.threads = threads;
	b.px = s.box_below = mem_alloc(np);
	a.px = s.box_above = mem_alloc(np);
	s.seed = mem_alloc(np);
	s.d2_solid = mem_alloc(np * sizeof *s.d2_solid);
	s.d2_any = mem_alloc(np * sizeof *s.d2_any);
	s.near = mem_alloc(np * sizeof *s.near);
	s.far = mem_alloc(np * sizeof *s.far);
	if (!s.box_below || !s.box_above || !s.seed || !s.d2_solid || !s.d2_any || !s.near ||
	    !s.far) {
		rc = ERR_SET(e, ERR_NOMEM, "verify: out of memory (a pair of layers)");
		goto out;
	}
	for (int y = 0; y < b.h; y++) {
		memcpy(b.px + (size_t)y * b.stride, below->px + (size_t)(y + y0) * below->stride + x0,
		       (size_t)b.w);
		memcpy(a.px + (size_t)y * a.stride, above->px + (size_t)(y + y0) * above->stride + x0,
		       (size_t)a.w);
	}
	if (verify_subpx_fits_size(&s.fb, np, grey_count(&b)) ||
	    verify_subpx_fits_size(&s.fa, np, grey_count(&a))) {
		rc = ERR_SET(e, ERR_NOMEM, "verify: out of memory (a pair of layers)");
		goto out;
	}
	for (size_t i = 0; i < np; i++)
		s.seed[i] = b.px[i] >= VERIFY_THRESHOLD;
	rc = edt_nearest_sq(s.seed, (size_t)b.w, b.w, b.h, px_mm, py_mm, s.d2_solid, s.near, &s.es,
			    e);
	for (size_t i = 0; !rc && i < np; i++)
		s.seed[i] = b.px[i] > 0;
	if (!rc)
		rc = edt_sq(s.seed, (size_t)b.w, b.w, b.h, px_mm, py_mm, s.d2_any, &s.es, e);
	if (rc)
		goto out;
	{
		/* the box's pixel (0, 0) is pixel (x0, y0) of the crops, (ox + x0,
		 * oy + y0) of the layer images: the model reads in the images'
		 * coordinates, as verify_layer does, so that a crop reads each
		 * pixel to the bit as the whole image does */
		int ix = ox + x0, iy = oy + y0;
		struct verify_subpx_img bi = {b.px,  ix,    iy, b.w,   b.h,
					      px_mm, py_mm, 0,  &s.fb, rd->memo};
		struct verify_subpx_img ai = {a.px,  ix,    iy, a.w,   a.h,
					      px_mm, py_mm, 0,  &s.fa, rd->memo};
		struct pair_rows rows = {&s, &bi, &ai, x0, y0, bx0, by0, bx1, by1, reach_mm};
		parfor_run((size_t)a.h, threads, 4, pair_row, &rows);
		for (size_t i = 0; i < np && !rc; i++)
			if (s.far[i] > reach_mm)
				rc = fn(ctx, (int)(i % (size_t)a.w) + x0,
					(int)(i / (size_t)a.w) + y0, s.far[i]);
	}
out:
	pair_fini(&s);
	return rc;
}
