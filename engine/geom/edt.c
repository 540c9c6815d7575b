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
	memset(s, 0, sizeof *s);
}

/* 1D: d[q] = min_p (sp*(q-p))^2 + f[p] over n samples (f may be INF). */
static void edt_1d(const float *f, float *d, int n, double sp, int *v, double *z)
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
		for (int q = 0; q < n; q++)
			d[q] = INFINITY;
		return;
	}
	for (int q = 0, j = 0; q < n; q++) {
		while (z[j + 1] < q)
			j++;
		double dq = sp * (q - v[j]);
		d[q] = (float)(dq * dq + f[v[j]]);
	}
}

int edt_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm, double py_mm,
	   float *out, struct edt_scratch *s, struct err *e)
{
	size_t n = (size_t)(w > h ? w : h);

	if (n + 1 > s->cap) {
		edt_scratch_fini(s);
		s->f = mem_alloc((n + 1) * sizeof *s->f);
		s->d = mem_alloc((n + 1) * sizeof *s->d);
		s->z = mem_alloc((n + 2) * sizeof *s->z);
		s->v = mem_alloc((n + 1) * sizeof *s->v);
		if (!s->f || !s->d || !s->z || !s->v) {
			edt_scratch_fini(s);
			return ERR_SET(e, ERR_NOMEM, "distance transform: out of memory");
		}
		s->cap = n + 1;
	}
	/* rows: along x */
	for (int y = 0; y < h; y++) {
		const uint8_t *r = seed + (size_t)y * stride;
		for (int x = 0; x < w; x++)
			s->f[x] = r[x] ? 0.0f : INFINITY;
		edt_1d(s->f, out + (size_t)y * (size_t)w, w, px_mm, s->v, s->z);
	}
	/* columns: along y */
	for (int x = 0; x < w; x++) {
		for (int y = 0; y < h; y++)
			s->f[y] = out[(size_t)y * (size_t)w + (size_t)x];
		edt_1d(s->f, s->d, h, py_mm, s->v, s->z);
		for (int y = 0; y < h; y++)
			out[(size_t)y * (size_t)w + (size_t)x] = s->d[y];
	}
	return 0;
}
