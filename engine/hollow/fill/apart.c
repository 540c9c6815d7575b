/* apart.c - walls between the fill's voids, read in 3D (see fill_int.h
 * hl_fill_apart and docs/hollow.md 4.2 "walls between voids").
 *
 * Keep-apart (fillstep.c) keeps a void of layer k from the other voids of
 * layer k + 1 only; two voids born side by side in one layer (hl_step_born)
 * are not kept apart at that layer, and whether two pieces of a layer are
 * two voids or one is known only once every layer below is built.  This
 * pass runs on the finished fill: it groups the runs into 3D components
 * with the verifier's connectivity (8-connected in a layer, linked to the
 * void directly above and below) and, in each layer, turns solid the void
 * pixels of two different components that lie within wall_next + 1 px
 * (pixel centres, the verifier's min_wall_between_mm + its pixel) of each
 * other, half a wall either side of their Voronoi boundary.  A pixel turns
 * solid only over solid in the layer below, so nothing hangs and nothing
 * floats: solid added over solid.  Pieces of one void stay as they are,
 * however close (a sheet inside one void is a fin, not a wall between
 * voids).
 */
#include "engine/hollow/fill/fill_int.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"

/* Rounds at most: a void cut in two by the pass is two voids, whose wall
 * the next round reads, and a cut whose one side cannot be cut (void
 * below) leaves the boundary nearer the other side, which the next round
 * cuts again. */
#define APART_ROUNDS 8

/* The scratch of one layer's window (ww x wh, row stride ww). */
struct apart_win {
	uint32_t *lab;   /* 3D component + 1 of each void pixel, 0 solid */
	uint8_t *seed;   /* void pixels; then the conflict's boundary pixels */
	uint8_t *below;  /* void in the layer below */
	float *d2;       /* squared distances, mm^2 */
	int32_t *near;   /* nearest void pixel (feature transform) */
	size_t cap;      /* pixels each of the five buffers above holds */
	size_t *rows;    /* the layer's first run of each grid row (h + 1) */
	struct edt_scratch es;
};

/* Room for a window of np pixels (the buffers grow only where a layer
 * has two voids too near: none on most parts).  0 or ERR_NOMEM. */
static int win_reserve(struct apart_win *a, size_t np, struct err *e)
{
	if (np <= a->cap)
		return 0;
	mem_free(a->lab);
	mem_free(a->seed);
	mem_free(a->below);
	mem_free(a->d2);
	mem_free(a->near);
	a->lab = mem_alloc(np * sizeof *a->lab);
	a->seed = mem_alloc(np);
	a->below = mem_alloc(np);
	a->d2 = mem_alloc(np * sizeof *a->d2);
	a->near = mem_alloc(np * sizeof *a->near);
	a->cap = a->lab && a->seed && a->below && a->d2 && a->near ? np : 0;
	if (!a->cap)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (walls between voids)");
	return 0;
}

static void win_fini(struct apart_win *a)
{
	mem_free(a->lab);
	mem_free(a->seed);
	mem_free(a->below);
	mem_free(a->d2);
	mem_free(a->near);
	mem_free(a->rows);
	edt_scratch_fini(&a->es);
}

/* Paint the runs of l that fall in the window (x0, y0, ww x wh) into m. */
static void paint(uint8_t *m, uint32_t *lab, const struct hl_fill_layer *l, int x0, int y0,
		  int ww, int wh)
{
	for (size_t i = 0; i < l->n; i++) {
		const struct hl_span *r = &l->run[i];
		int a = r->x0 - x0, b = r->x1 - x0;
		if (r->y < y0 || r->y >= y0 + wh)
			continue;
		a = a < 0 ? 0 : a;
		b = b >= ww ? ww - 1 : b;
		for (int x = a; x <= b; x++) {
			size_t j = (size_t)(r->y - y0) * (size_t)ww + (size_t)x;
			if (m)
				m[j] = 1;
			if (lab)
				lab[j] = r->comp + 1;
		}
	}
}

/* Append r clipped to columns [lo, hi] to *run (nothing when that leaves
 * none of it). */
static int push_run(struct hl_span **run, size_t *n, size_t *cap, struct hl_span r, int lo, int hi,
		    struct err *e)
{
	void *arr = *run;

	r.x0 = r.x0 > lo ? r.x0 : lo;
	r.x1 = r.x1 < hi ? r.x1 : hi;
	if (r.x0 > r.x1)
		return 0;
	if (mem_grow(&arr, cap, *n + 1, sizeof **run))
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (walls between voids)");
	*run = arr;
	(*run)[(*n)++] = r;
	return 0;
}

/* The box (grid pixels, inclusive) around every pair of void pixels of
 * layer L in two different components whose centres lie closer than
 * lim (mm): for each two runs of such a pair, rows y .. y2 and the
 * columns where they come within reach.  From the runs alone, rows
 * ordered: rs[y] = L's first run of row y (rs[h] = L->n).  Returns 1 and
 * the box, or 0 when no such pair exists. */
static int conflict_box(const struct hl_fill_layer *L, const size_t *rs, int h, double px,
			double py, double lim, int *bx0, int *by0, int *bx1, int *by1)
{
	int any = 0;

	for (int y = 0; y < h; y++) {
		if (rs[y] == rs[y + 1])
			continue;
		for (int dy = 0; y + dy < h; dy++) {
			double rx2 = lim * lim - (dy * py) * (dy * py);
			int y2 = y + dy, reach;
			if (rx2 <= 0)
				break;
			/* columns apart: gap g pixels is near when (g px)^2 < rx2 */
			reach = (int)ceil(sqrt(rx2) / px);
			while (reach > 0 && (reach * px) * (reach * px) >= rx2)
				reach--;
			for (size_t i = rs[y]; i < rs[y + 1]; i++) {
				const struct hl_span *r = &L->run[i];
				for (size_t j = dy ? rs[y2] : i + 1; j < rs[y2 + 1]; j++) {
					const struct hl_span *q = &L->run[j];
					int lo, hi;
					if (q->x0 > r->x1 + reach)
						break;
					if (q->comp == r->comp || q->x1 + reach < r->x0)
						continue;
					/* the columns of each run within reach of the other */
					lo = (r->x0 > q->x0 ? r->x0 : q->x0) - reach;
					hi = (r->x1 < q->x1 ? r->x1 : q->x1) + reach;
					if (!any) {
						*bx0 = lo;
						*bx1 = hi;
						*by0 = y;
						*by1 = y2;
					}
					*bx0 = lo < *bx0 ? lo : *bx0;
					*bx1 = hi > *bx1 ? hi : *bx1;
					*by0 = y < *by0 ? y : *by0;
					*by1 = y2 > *by1 ? y2 : *by1;
					any = 1;
				}
			}
		}
	}
	return any;
}

/* One layer k: mark the boundary pixels between two components whose
 * nearest void pixels lie closer than lim (mm, centres), turn solid the
 * void pixels nearer than (lim + max(px, py)) / 2 to them that stand over
 * solid, and rebuild the layer's runs (strictly nearer than that, within 1e-12 mm^2).
 * *crowded: 1 when the layer held two components within lim (before the
 * cut), else 0; *cut: pixels turned solid.  0, ERR_NOMEM or an EDT error. */
static int apart_layer(struct hl_fill *f, int k, double px, double py, double lim,
		       struct apart_win *a, int *crowded, long *cut, struct err *e)
{
	static const int dir[4][2] = {{1, 0}, {0, 1}, {1, 1}, {-1, 1}};
	struct hl_fill_layer *L = &f->layer[k];
	int x0 = 0, y0 = 0, x1 = 0, y1 = 0, ww, wh, any, rc;
	size_t np, cap, n = 0, w = 0;
	struct hl_span *run = NULL;
	/* half a wall either side, and half a pixel more: the boundary
	 * pixels lie within a pixel of the bisector, diagonally 0.7 */
	double half = 0.5 * (lim + fmax(px, py));
	int rpx = (int)ceil(lim / fmin(px, py)) + 2;

	hl_grid_row_starts(L->run, L->n, f->h, a->rows);
	*crowded = conflict_box(L, a->rows, f->h, px, py, lim, &x0, &y0, &x1, &y1);
	if (!*crowded)
		return 0; /* no two components within lim */
	/* the pixels of every near pair, the boundary between them and the
	 * void pixels nearer to it than they are */
	x0 -= rpx;
	y0 -= rpx;
	x1 += rpx;
	y1 += rpx;
	x0 = x0 < 0 ? 0 : x0;
	y0 = y0 < 0 ? 0 : y0;
	x1 = x1 >= f->w ? f->w - 1 : x1;
	y1 = y1 >= f->h ? f->h - 1 : y1;
	ww = x1 - x0 + 1;
	wh = y1 - y0 + 1;
	np = (size_t)ww * (size_t)wh;
	rc = win_reserve(a, np, e);
	if (rc)
		return rc;
	memset(a->lab, 0, np * sizeof *a->lab);
	memset(a->seed, 0, np);
	paint(a->seed, a->lab, L, x0, y0, ww, wh);
	rc = edt_nearest_sq(a->seed, (size_t)ww, ww, wh, px, py, a->d2, a->near, &a->es, e);
	if (rc)
		return rc;
	/* seed: the pixels astride a boundary between two components whose
	 * nearest pixels are closer than lim */
	memset(a->seed, 0, np);
	any = 0;
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			int32_t ni = a->near[i];
			for (int q = 0; q < 4; q++) {
				int x2 = x + dir[q][0], y2 = y + dir[q][1];
				size_t j;
				int32_t nj;
				double dx, dy;
				if (x2 < 0 || x2 >= ww || y2 >= wh)
					continue;
				j = (size_t)y2 * (size_t)ww + (size_t)x2;
				nj = a->near[j];
				if (ni < 0 || nj < 0 || a->lab[ni] == a->lab[nj])
					continue;
				dx = (double)(ni % ww - nj % ww) * px;
				dy = (double)(ni / ww - nj / ww) * py;
				if (dx * dx + dy * dy >= lim * lim)
					continue;
				a->seed[i] = a->seed[j] = 1;
				any = 1;
			}
		}
	if (!any)
		return 0;
	rc = edt_sq(a->seed, (size_t)ww, ww, wh, px, py, a->d2, &a->es, e);
	if (rc)
		return rc;
	memset(a->below, 0, np);
	if (k > 0)
		paint(a->below, NULL, &f->layer[k - 1], x0, y0, ww, wh);
	/* seed, again: the layer's void after the cut */
	for (size_t i = 0; i < np; i++) {
		a->seed[i] = a->lab[i] != 0;
		/* (a pixel at exactly half stays: 1e-12 mm^2 off the float) */
		if (!a->seed[i] || (double)a->d2[i] >= half * half - 1e-12)
			continue;
		if (a->below[i])
			continue; /* held up by nothing: the next round may cut it */
		a->seed[i] = 0;
		(*cut)++;
	}
	/* the layer's runs, row-major: rows outside the window as they
	 * were; in a window row the parts of runs left of it, the window's
	 * rebuilt, the parts right of it */
	cap = 0;
	for (size_t i = 0, j; i < L->n; i = j) {
		int y = L->run[i].y;
		size_t n0;
		for (j = i; j < L->n && L->run[j].y == y; j++)
			;
		if (y < y0 || y >= y0 + wh) {
			for (size_t t = i; t < j; t++)
				if ((rc = push_run(&run, &n, &cap, L->run[t], INT32_MIN, INT32_MAX, e)))
					goto fail;
			continue;
		}
		for (size_t t = i; t < j; t++)
			if (L->run[t].x0 < x0 &&
			    (rc = push_run(&run, &n, &cap, L->run[t], INT32_MIN, x0 - 1, e)))
				goto fail;
		n0 = n;
		rc = hl_grid_runs(a->seed, ww, 0, y - y0, ww, y - y0 + 1, &run, &n, &cap, e);
		if (rc)
			goto fail;
		for (size_t t = n0; t < n; t++) {
			run[t].comp = a->lab[(size_t)run[t].y * (size_t)ww + (size_t)run[t].x0] - 1;
			run[t].y += y0;
			run[t].x0 += x0;
			run[t].x1 += x0;
		}
		for (size_t t = i; t < j; t++)
			if (L->run[t].x1 > x1 &&
			    (rc = push_run(&run, &n, &cap, L->run[t], x1 + 1, INT32_MAX, e)))
				goto fail;
	}
	/* a window run that meets a part left or right of it is one run */
	for (size_t i = 0; i < n; i++) {
		if (w && run[w - 1].y == run[i].y && run[w - 1].x1 + 1 >= run[i].x0)
			run[w - 1].x1 = run[i].x1 > run[w - 1].x1 ? run[i].x1 : run[w - 1].x1;
		else
			run[w++] = run[i];
	}
	n = w;
	mem_free(L->run);
	L->run = run;
	L->n = n;
	return 0;
fail:
	mem_free(run);
	return rc;
}

int hl_fill_apart(struct hl_fill *f, double wall_mm, double px, double py, int threads,
		  long *cut, long *left, struct err *e)
{
	struct apart_win a;
	int rc = 0, x0, y0, x1, y1;
	double lim = wall_mm + fmin(px, py);
	size_t runs;
	long c0 = -1;

	*cut = *left = 0;
	memset(&a, 0, sizeof a);
	edt_scratch_init(&a.es);
	a.es.threads = threads;
	if (f->n < 1 || f->w < 1 || f->h < 1)
		goto out;
	a.rows = mem_alloc(((size_t)f->h + 1) * sizeof *a.rows);
	if (!a.rows) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (walls between voids)");
		goto out;
	}
	/* rounds while the last one cut: regrouped, since a void cut in two
	 * is two voids; every layer read again (the run scan costs little
	 * where nothing is near).  Bottom-up: a layer is cut on the layer
	 * below as already cut, so a wall too thin over many layers is cut
	 * from its foot up in one round. */
	for (int round = 0; !rc && round < APART_ROUNDS && *cut != c0; round++) {
		c0 = *cut;
		*left = 0;
		rc = hl_fill_label(f, 1, &runs, e);
		for (int k = 0; !rc && k < f->n; k++) {
			int crowded = 0;
			rc = apart_layer(f, k, px, py, lim, &a, &crowded, cut, e);
			*left += crowded;
		}
	}
	/* what is left: layers still holding two voids nearer than lim.  A
	 * round that cut nothing read them on the fill as it stands; after
	 * the last round's cuts, regroup and read them again */
	if (!rc && *cut != c0) {
		*left = 0;
		rc = hl_fill_label(f, 1, &runs, e);
		for (int k = 0; !rc && k < f->n; k++) {
			const struct hl_fill_layer *L = &f->layer[k];
			hl_grid_row_starts(L->run, L->n, f->h, a.rows);
			*left += conflict_box(L, a.rows, f->h, px, py, lim, &x0, &y0, &x1, &y1);
		}
	}
out:
	win_fini(&a);
	return rc;
}
