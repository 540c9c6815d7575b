/* edt.c - exact squared Euclidean distance transform (see edt.h). */
#include "engine/geom/edt.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"

void edt_scratch_init(struct edt_scratch *s)
{
	memset(s, 0, sizeof *s);
}

static void lane_lines_free(struct edt_lane *l)
{
	mem_free(l->f);
	mem_free(l->d);
	mem_free(l->z);
	mem_free(l->v);
	mem_free(l->a);
	mem_free(l->g);
	l->f = l->d = NULL;
	l->z = l->g = NULL;
	l->v = l->a = NULL;
	l->cap = 0;
}

static void lane_tiles_free(struct edt_lane *l)
{
	mem_free(l->tf);
	mem_free(l->td);
	mem_free(l->ta);
	mem_free(l->tn);
	l->tf = l->td = NULL;
	l->ta = l->tn = NULL;
	l->tcap = 0;
}

void edt_scratch_fini(struct edt_scratch *s)
{
	for (int t = 0; t < EDT_LANES; t++) {
		lane_lines_free(&s->lane[t]);
		lane_tiles_free(&s->lane[t]);
	}
	memset(s, 0, sizeof *s);
}

/* Columns per block of the column pass: 16 floats are one 64-byte cache
 * line of a row. */
#define EDT_BLOCK 16

/* Images under this many pixels run on one thread: starting threads
 * would cost more than they save. */
#define EDT_PAR_MIN_PX 65536

/* 1D: d[q] = min_p (sp*(q-p))^2 + f[p] over n samples (f may be INF);
 * arg (may be NULL): arg[q] = that p (the lower p on ties), -1 when every
 * f is INF.  v, z, g: scratch of n + 1, n + 2, n + 1 (g[k] holds kept
 * parabola v[k]'s f + (sp v[k])^2, computed once). */
static void edt_1d(const float *f, float *d, int n, double sp, int *v, double *z, double *g,
		   int *arg)
{
	int k = -1;
	double s2 = sp * sp;

	for (int q = 0; q < n; q++) {
		double gq;
		if (!isfinite(f[q]))
			continue;
		gq = f[q] + s2 * (double)q * q;
		/* parabola q vs the last kept one: intersection abscissa */
		while (k >= 0) {
			int p = v[k];
			double s = (gq - g[k]) / (2 * s2 * (q - p));
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
		g[k] = gq;
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

/* Lane l's line buffers for n samples and tiles for EDT_BLOCK columns of
 * h samples. */
static int lane_need(struct edt_lane *l, size_t n, size_t h, struct err *e)
{
	size_t tn = EDT_BLOCK * h;

	if (n + 1 > l->cap) {
		lane_lines_free(l);
		l->f = mem_alloc((n + 1) * sizeof *l->f);
		l->d = mem_alloc((n + 1) * sizeof *l->d);
		l->z = mem_alloc((n + 2) * sizeof *l->z);
		l->v = mem_alloc((n + 1) * sizeof *l->v);
		l->a = mem_alloc((n + 1) * sizeof *l->a);
		l->g = mem_alloc((n + 1) * sizeof *l->g);
		if (!l->f || !l->d || !l->z || !l->v || !l->a || !l->g) {
			lane_lines_free(l);
			return ERR_SET(e, ERR_NOMEM, "distance transform: out of memory");
		}
		l->cap = n + 1;
	}
	if (tn > l->tcap) {
		lane_tiles_free(l);
		l->tf = mem_alloc(tn * sizeof *l->tf);
		l->td = mem_alloc(tn * sizeof *l->td);
		l->ta = mem_alloc(tn * sizeof *l->ta);
		l->tn = mem_alloc(tn * sizeof *l->tn);
		if (!l->tf || !l->td || !l->ta || !l->tn) {
			lane_tiles_free(l);
			return ERR_SET(e, ERR_NOMEM, "distance transform: out of memory");
		}
		l->tcap = tn;
	}
	return 0;
}

/* One transform's arguments, shared by its threads. */
struct edt_job {
	const uint8_t *seed;
	size_t stride;
	int w, h;
	double px_mm, py_mm;
	float *out;
	int32_t *near;
	struct edt_scratch *s;
};

/* Row y: along x, the nearest seed column by a left and a right scan (the
 * left one on ties); near holds that column for now. */
static void edt_row(void *ctx, size_t yi, int tid)
{
	const struct edt_job *j = ctx;
	int w = j->w, y = (int)yi, *a = j->s->lane[tid].a;
	const uint8_t *r = j->seed + (size_t)y * j->stride;
	float *o = j->out + (size_t)y * (size_t)w;
	int last = -1;

	for (int x = 0; x < w; x++) {
		if (r[x])
			last = x;
		a[x] = last;
	}
	last = -1;
	for (int x = w - 1; x >= 0; x--) {
		if (r[x])
			last = x;
		if (last >= 0 && (a[x] < 0 || last - x < x - a[x]))
			a[x] = last;
		o[x] = a[x] < 0 ? INFINITY
				: (float)((double)(x - a[x]) * (x - a[x]) * j->px_mm * j->px_mm);
	}
	if (j->near)
		for (int x = 0; x < w; x++)
			j->near[(size_t)y * (size_t)w + (size_t)x] = a[x];
}

/* Column block bi (columns EDT_BLOCK bi ..): along y through the tiles;
 * the row chosen picks that row's column. */
static void edt_cols(void *ctx, size_t bi, int tid)
{
	const struct edt_job *j = ctx;
	struct edt_lane *l = &j->s->lane[tid];
	int w = j->w, h = j->h, x0 = (int)bi * EDT_BLOCK;
	int nb = w - x0 < EDT_BLOCK ? w - x0 : EDT_BLOCK;
	size_t H = (size_t)h;

	for (int y = 0; y < h; y++) {
		const float *o = j->out + (size_t)y * (size_t)w + (size_t)x0;
		for (int b = 0; b < nb; b++)
			l->tf[(size_t)b * H + (size_t)y] = o[b];
	}
	for (int b = 0; b < nb; b++)
		edt_1d(l->tf + (size_t)b * H, l->td + (size_t)b * H, h, j->py_mm, l->v, l->z, l->g,
		       j->near ? l->ta + (size_t)b * H : NULL);
	for (int y = 0; y < h; y++) {
		float *o = j->out + (size_t)y * (size_t)w + (size_t)x0;
		for (int b = 0; b < nb; b++)
			o[b] = l->td[(size_t)b * H + (size_t)y];
	}
	if (!j->near)
		return;
	/* every row's column of the row pass is read before any is written:
	 * the block's columns of near go to tn first */
	for (int y = 0; y < h; y++) {
		const int32_t *nr = j->near + (size_t)y * (size_t)w + (size_t)x0;
		for (int b = 0; b < nb; b++)
			l->tn[(size_t)b * H + (size_t)y] = nr[b];
	}
	for (int y = 0; y < h; y++) {
		int32_t *nr = j->near + (size_t)y * (size_t)w + (size_t)x0;
		for (int b = 0; b < nb; b++) {
			int q = l->ta[(size_t)b * H + (size_t)y];
			int32_t c = q < 0 ? -1 : l->tn[(size_t)b * H + (size_t)q];
			nr[b] = c < 0 ? -1 : (int32_t)((size_t)q * (size_t)w + (size_t)c);
		}
	}
}

int edt_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm, double py_mm,
	   float *out, struct edt_scratch *s, struct err *e)
{
	return edt_nearest_sq(seed, stride, w, h, px_mm, py_mm, out, NULL, s, e);
}

int edt_nearest_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm,
		   double py_mm, float *out, int32_t *near, struct edt_scratch *s, struct err *e)
{
	struct edt_job j = {seed, stride, w, h, px_mm, py_mm, out, near, s};
	int threads = s->threads < 1 ? 1 : s->threads > EDT_LANES ? EDT_LANES : s->threads;
	size_t n = (size_t)(w > h ? w : h), blocks = ((size_t)w + EDT_BLOCK - 1) / EDT_BLOCK;

	if (w <= 0 || h <= 0)
		return 0; /* nothing to transform (and no tiles to point into) */
	if ((size_t)w * (size_t)h < EDT_PAR_MIN_PX)
		threads = 1;
	for (int t = 0; t < threads; t++)
		if (lane_need(&s->lane[t], n, (size_t)h, e))
			return ERR_NOMEM;
	parfor_run((size_t)h, threads, 32, edt_row, &j);
	parfor_run(blocks, threads, 1, edt_cols, &j);
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
		rc = lane_need(&s.lane[0], (size_t)d, 0, e);
	for (size_t c = 0; c < plane && !rc; c++) {
		struct edt_lane *l = &s.lane[0];
		for (int z = 0; z < d; z++)
			l->f[z] = out[z * plane + c];
		edt_1d(l->f, l->d, d, vox_mm, l->v, l->z, l->g, NULL);
		for (int z = 0; z < d; z++)
			out[z * plane + c] = l->d[z];
	}
	edt_scratch_fini(&s);
	return rc;
}
