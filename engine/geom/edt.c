/* edt.c - exact squared Euclidean distance transform (see edt.h). */
#include "engine/geom/edt.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

void edt_scratch_init(struct edt_scratch *s)
{
	memset(s, 0, sizeof *s);
}

void edt_scratch_fini(struct edt_scratch *s)
{
	mem_free(s->f);
	mem_free(s->d);
	mem_free(s->z);
	mem_free(s->v);
	mem_free(s->a);
	mem_free(s->tf);
	mem_free(s->td);
	mem_free(s->ta);
	mem_free(s->tn);
	memset(s, 0, sizeof *s);
}

/* Columns per block of the column pass: 16 floats are one 64-byte cache
 * line of a row. */
#define EDT_BLOCK 16

/* 1D: d[q] = min_p (sp*(q-p))^2 + f[p] over n samples (f may be INF);
 * arg (may be NULL): arg[q] = that p (the lower p on ties), -1 when every
 * f is INF. */
static void edt_1d(const float *f, float *d, int n, double sp, int *v, double *z, int *arg)
{
	int k = -1;
	double s2 = sp * sp;

	for (int q = 0; q < n; q++) {
		if (!isfinite(f[q]))
			continue;
		/* parabola q vs the last kept one: intersection abscissa */
		while (k >= 0) {
			int p = v[k];
			double s = ((f[q] + s2 * (double)q * q) - (f[p] + s2 * (double)p * p)) /
				   (2 * s2 * (q - p));
			if (s <= z[k]) {
				k--;
				continue;
			}
			z[k + 1] = s;
			break;
		}
		if (k < 0)
			z[0] = -INFINITY;
		v[++k] = q;
		z[k + 1] = INFINITY;
		if (k == 0)
			z[0] = -INFINITY;
	}
	if (k < 0) {
		for (int q = 0; q < n; q++) {
			d[q] = INFINITY;
			if (arg)
				arg[q] = -1;
		}
		return;
	}
	for (int q = 0, j = 0; q < n; q++) {
		while (z[j + 1] < q)
			j++;
		double dq = sp * (q - v[j]);
		d[q] = (float)(dq * dq + f[v[j]]);
		if (arg)
			arg[q] = v[j];
	}
}

/* Scratch for lines of n samples. */
static int scratch_need(struct edt_scratch *s, size_t n, struct err *e)
{
	if (n + 1 <= s->cap)
		return 0;
	mem_free(s->f);
	mem_free(s->d);
	mem_free(s->z);
	mem_free(s->v);
	mem_free(s->a);
	s->f = mem_alloc((n + 1) * sizeof *s->f);
	s->d = mem_alloc((n + 1) * sizeof *s->d);
	s->z = mem_alloc((n + 2) * sizeof *s->z);
	s->v = mem_alloc((n + 1) * sizeof *s->v);
	s->a = mem_alloc((n + 1) * sizeof *s->a);
	if (!s->f || !s->d || !s->z || !s->v || !s->a) {
		edt_scratch_fini(s);
		return ERR_SET(e, ERR_NOMEM, "distance transform: out of memory");
	}
	s->cap = n + 1;
	return 0;
}

/* Tiles for EDT_BLOCK columns of h samples. */
static int tiles_need(struct edt_scratch *s, size_t h, struct err *e)
{
	size_t n = EDT_BLOCK * h;

	if (n <= s->tcap)
		return 0;
	mem_free(s->tf);
	mem_free(s->td);
	mem_free(s->ta);
	mem_free(s->tn);
	s->tf = mem_alloc(n * sizeof *s->tf);
	s->td = mem_alloc(n * sizeof *s->td);
	s->ta = mem_alloc(n * sizeof *s->ta);
	s->tn = mem_alloc(n * sizeof *s->tn);
	if (!s->tf || !s->td || !s->ta || !s->tn) {
		edt_scratch_fini(s);
		return ERR_SET(e, ERR_NOMEM, "distance transform: out of memory");
	}
	s->tcap = n;
	return 0;
}

int edt_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm, double py_mm,
	   float *out, struct edt_scratch *s, struct err *e)
{
	return edt_nearest_sq(seed, stride, w, h, px_mm, py_mm, out, NULL, s, e);
}

int edt_nearest_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm,
		   double py_mm, float *out, int32_t *near, struct edt_scratch *s, struct err *e)
{
	if (scratch_need(s, (size_t)(w > h ? w : h), e))
		return ERR_NOMEM;
	/* rows: along x, the nearest seed column by a left and a right scan
	 * (the left one on ties); near holds that column for now */
	for (int y = 0; y < h; y++) {
		const uint8_t *r = seed + (size_t)y * stride;
		float *o = out + (size_t)y * (size_t)w;
		int last = -1;
		for (int x = 0; x < w; x++) {
			if (r[x])
				last = x;
			s->a[x] = last;
		}
		last = -1;
		for (int x = w - 1; x >= 0; x--) {
			if (r[x])
				last = x;
			if (last >= 0 && (s->a[x] < 0 || last - x < x - s->a[x]))
				s->a[x] = last;
			o[x] = s->a[x] < 0 ? INFINITY
					   : (float)((double)(x - s->a[x]) * (x - s->a[x]) * px_mm * px_mm);
		}
		if (near)
			for (int x = 0; x < w; x++)
				near[(size_t)y * (size_t)w + (size_t)x] = s->a[x];
	}
	/* columns: along y, EDT_BLOCK columns at a time through the tiles;
	 * the row chosen picks that row's column */
	if (tiles_need(s, (size_t)h, e))
		return ERR_NOMEM;
	for (int x0 = 0; x0 < w; x0 += EDT_BLOCK) {
		int nb = w - x0 < EDT_BLOCK ? w - x0 : EDT_BLOCK;
		size_t H = (size_t)h;
		for (int y = 0; y < h; y++) {
			const float *o = out + (size_t)y * (size_t)w + (size_t)x0;
			for (int b = 0; b < nb; b++)
				s->tf[(size_t)b * H + (size_t)y] = o[b];
		}
		for (int b = 0; b < nb; b++)
			edt_1d(s->tf + (size_t)b * H, s->td + (size_t)b * H, h, py_mm, s->v, s->z,
			       near ? s->ta + (size_t)b * H : NULL);
		for (int y = 0; y < h; y++) {
			float *o = out + (size_t)y * (size_t)w + (size_t)x0;
			for (int b = 0; b < nb; b++)
				o[b] = s->td[(size_t)b * H + (size_t)y];
		}
		if (!near)
			continue;
		/* every row's column of the row pass is read before any is
		 * written: the block's columns of near go to tn first */
		for (int y = 0; y < h; y++) {
			const int32_t *nr = near + (size_t)y * (size_t)w + (size_t)x0;
			for (int b = 0; b < nb; b++)
				s->tn[(size_t)b * H + (size_t)y] = nr[b];
		}
		for (int y = 0; y < h; y++) {
			int32_t *nr = near + (size_t)y * (size_t)w + (size_t)x0;
			for (int b = 0; b < nb; b++) {
				int q = s->ta[(size_t)b * H + (size_t)y];
				int32_t c = q < 0 ? -1 : s->tn[(size_t)b * H + (size_t)q];
				nr[b] = c < 0 ? -1 : (int32_t)((size_t)q * (size_t)w + (size_t)c);
			}
		}
	}
	return 0;
}

int edt3_sq(const uint8_t *seed, int w, int h, int d, double vox_mm, float *out, struct err *e)
{
	struct edt_scratch s;
	size_t plane = (size_t)w * (size_t)h;
	int rc = 0;

	edt_scratch_init(&s);
	for (int z = 0; z < d && !rc; z++)
		rc = edt_sq(seed + z * plane, (size_t)w, w, h, vox_mm, vox_mm, out + z * plane, &s,
			    e);
	if (!rc)
		rc = scratch_need(&s, (size_t)d, e);
	for (size_t c = 0; c < plane && !rc; c++) {
		for (int z = 0; z < d; z++)
			s.f[z] = out[z * plane + c];
		edt_1d(s.f, s.d, d, vox_mm, s.v, s.z, NULL);
		for (int z = 0; z < d; z++)
			out[z * plane + c] = s.d[z];
	}
	edt_scratch_fini(&s);
	return rc;
}
