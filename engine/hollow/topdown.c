/* topdown.c - the top-down support-free fill: the void a greedy top-down
 * construction fits inside the offset stack, one print layer at a time, on
 * the very pixel grid the verifier reads (distance transforms, O(pixels)
 * per layer whatever the shape); the hollow engine's fallback where the
 * optimiser (nlp.c) leaves space unhollowed.  Derivation and why it is a
 * deviation from paper 004: docs/hollow.md "Top-down fill".
 */
#include "engine/hollow/topdown.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/edt.h"
#include "engine/hollow/rounds.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/slice.h"

void hl_fill_fini(struct hl_fill *f)
{
	for (int k = 0; f->layer && k < f->n; k++)
		mem_free(f->layer[k].run);
	mem_free(f->layer);
	memset(f, 0, sizeof *f);
}

const struct hl_fill_layer *hl_fill_at(const struct hl_fill *f, double z_mm)
{
	int j;

	if (!f->layer || f->n < 1 || !(f->layer_mm > 0))
		return NULL;
	/* a print layer's mid-plane lies inside exactly one slab (the 1e-9
	 * keeps a mid-plane that falls on a slab boundary in the upper one) */
	j = (int)floor(z_mm / f->layer_mm + 1e-9);
	if (j < 0 || j >= f->n || !f->layer[j].n)
		return NULL;
	return &f->layer[j];
}

/* Printer mm of continuous image coordinates (u, v) through map m (its
 * matrix is invertible: raster_map pitches are > 0). */
static void map_inverse(const struct raster_map *m, double u, double v, double *x, double *y)
{
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	double du = u - m->b[0], dv = v - m->b[1];

	*x = (m->a[1][1] * du - m->a[0][1] * dv) / det;
	*y = (-m->a[1][0] * du + m->a[0][0] * dv) / det;
}

void hl_fill_mass(const struct hl_fill *f, double *vol_mm3, double cxy[2])
{
	double det = fabs(f->map.a[0][0] * f->map.a[1][1] - f->map.a[0][1] * f->map.a[1][0]);
	double sx = 0, sy = 0, cnt = 0;

	cxy[0] = cxy[1] = 0;
	*vol_mm3 = 0;
	if (!f->layer || !(det > 0))
		return;
	for (int j = 0; j < f->n; j++)
		for (size_t i = 0; i < f->layer[j].n; i++) {
			const struct hl_run *q = &f->layer[j].run[i];
			double k = (double)(q->x1 - q->x0 + 1), x, y;
			/* the centre of the run is the mean of its pixel centres */
			map_inverse(&f->map, f->u0 + 0.5 * (q->x0 + q->x1) + 0.5, f->v0 + q->y + 0.5,
				    &x, &y);
			sx += k * x;
			sy += k * y;
			cnt += k;
		}
	if (cnt > 0) {
		cxy[0] = sx / cnt;
		cxy[1] = sy / cnt;
	}
	/* a pixel is 1 / det mm^2 */
	*vol_mm3 = cnt / det * f->layer_mm;
}

void hl_fill_clear(const struct hl_fill *f, const struct hl_fill_layer *l, struct raster *r)
{
	for (size_t i = 0; i < l->n; i++) {
		int v = f->v0 + l->run[i].y;
		int a = f->u0 + l->run[i].x0, b = f->u0 + l->run[i].x1;
		if (v < 0 || v >= r->h)
			continue;
		a = a < 0 ? 0 : a;
		b = b >= r->w ? r->w - 1 : b;
		if (a <= b)
			memset(r->px + (size_t)v * r->stride + a, 0, (size_t)(b - a + 1));
	}
}

int hl_fill_region(const struct hl_fill *f, const struct hl_fill_layer *l, struct paths *region,
		   struct err *e)
{
	int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1, w, h;
	struct raster_map m = f->map;
	float *fld;
	int rc;

	paths_clear(region);
	for (size_t i = 0; i < l->n; i++) {
		x0 = l->run[i].x0 < x0 ? l->run[i].x0 : x0;
		x1 = l->run[i].x1 > x1 ? l->run[i].x1 : x1;
		y0 = l->run[i].y < y0 ? l->run[i].y : y0;
		y1 = l->run[i].y > y1 ? l->run[i].y : y1;
	}
	if (x1 < 0)
		return 0;
	w = x1 - x0 + 3;
	h = y1 - y0 + 3;
	fld = mem_calloc((size_t)w * (size_t)h, sizeof *fld);
	if (!fld)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill region)");
	for (size_t i = 0; i < l->n; i++)
		for (int x = l->run[i].x0; x <= l->run[i].x1; x++)
			fld[(size_t)(l->run[i].y - y0 + 1) * (size_t)w + (size_t)(x - x0 + 1)] = 1;
	/* field pixel (i, j) is image pixel (u0 + x0 - 1 + i, v0 + y0 - 1 + j) */
	m.b[0] -= f->u0 + x0 - 1;
	m.b[1] -= f->v0 + y0 - 1;
	rc = slice_field_contours(fld, w, h, 0.5f, &m, region, e);
	mem_free(fld);
	return rc;
}

/* ---- the offset stack C(k) ---- */

int hl_src_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	struct hl_src_ctx *c = ctx;

	return slice_at(c->s, (k + 0.5) * c->layer_mm, region, NULL, e);
}

struct eroded {
	struct slicer *s;
	struct hl_src_ctx sc;
	struct slice_eroder *er;
};

static int eroded_open(struct eroded *x, const struct mesh *m, double r_mm, double pixel_mm,
		       double layer_mm, int layer_count, const struct box3 *bb, struct err *e)
{
	struct slice_erode_params ep;
	struct slice_erode_source src;
	int rc;

	memset(x, 0, sizeof *x);
	rc = slice_new(m, &x->s, e);
	if (rc)
		return rc;
	x->sc.s = x->s;
	x->sc.layer_mm = layer_mm;
	src.layer = hl_src_layer;
	src.ctx = &x->sc; /* x outlives the eroder */
	memset(&ep, 0, sizeof ep);
	ep.r_mm = r_mm;
	ep.pixel_mm = pixel_mm;
	ep.layer_mm = layer_mm;
	ep.layer_count = layer_count;
	ep.x0_mm = bb->lo.x;
	ep.y0_mm = bb->lo.y;
	ep.x1_mm = bb->hi.x;
	ep.y1_mm = bb->hi.y;
	return slice_erode_new(&ep, &src, &x->er, e);
}

static void eroded_close(struct eroded *x)
{
	slice_erode_free(x->er);
	slice_free(x->s);
	memset(x, 0, sizeof *x);
}

/* C[k] (pixels of the grid map gm, w x h) for every print layer, as runs,
 * bottom-up (the eroders stream upward): centre-sampled erosions of the
 * part by wall_mm and of solid by wall_next_mm, intersected. */
static int offset_stack(const struct mesh *part, const struct mesh *solid,
			const struct hl_config *c, const struct raster_map *gm, int w, int h, int n,
			struct hl_fill_layer *C, struct err *e)
{
	struct eroded ep, es;
	struct box3 bb = box3_empty();
	struct raster *ra = raster_new(w, h), *rb = solid ? raster_new(w, h) : NULL;
	uint8_t *mask = mem_alloc((size_t)w * (size_t)h + 1);
	int rc = 0;

	memset(&ep, 0, sizeof ep);
	memset(&es, 0, sizeof es);
	if (!ra || !mask || (solid && !rb)) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill grid %d x %d)", w, h);
		goto out;
	}
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	rc = eroded_open(&ep, part, c->wall_mm, c->pixel_mm, c->print_layer_mm, n, &bb, e);
	if (!rc && solid)
		rc = eroded_open(&es, solid, c->wall_next_mm, c->pixel_mm, c->print_layer_mm, n, &bb,
				 e);
	for (int k = 0; !rc && k < n; k++) {
		size_t cap = 0;
		raster_clear(ra);
		rc = slice_erode_raster(ep.er, k, gm, 0, ra, e);
		if (!rc && solid) {
			raster_clear(rb);
			rc = slice_erode_raster(es.er, k, gm, 0, rb, e);
		}
		if (rc)
			break;
		for (int y = 0; y < h; y++) {
			const uint8_t *a = ra->px + (size_t)y * ra->stride;
			const uint8_t *b = rb ? rb->px + (size_t)y * rb->stride : a;
			uint8_t *m = mask + (size_t)y * (size_t)w;
			for (int x = 0; x < w; x++) {
				double px, py;
				m[x] = a[x] >= 128 && b[x] >= 128;
				if (!m[x] || !c->fill_keep_set)
					continue;
				map_inverse(gm, x + 0.5, y + 0.5, &px, &py);
				m[x] = c->fill_keep[0] * px + c->fill_keep[1] * py < c->fill_keep[2];
			}
		}
		rc = hl_grid_runs(mask, w, 0, 0, w, h, &C[k].run, &C[k].n, &cap, e);
	}
out:
	eroded_close(&ep);
	eroded_close(&es);
	raster_free(ra);
	raster_free(rb);
	mem_free(mask);
	return rc;
}

/* ---- components (4-connected in a layer, linked to the void directly
 * above and below: the verifier's void connectivity) ---- */

static uint32_t run_root(struct hl_run **at, uint32_t i)
{
	/* comp holds the union-find parent as a global run index */
	while (at[i]->comp != i) {
		at[i]->comp = at[at[i]->comp]->comp;
		i = at[i]->comp;
	}
	return i;
}

static void run_union(struct hl_run **at, uint32_t a, uint32_t b)
{
	a = run_root(at, a);
	b = run_root(at, b);
	if (a != b)
		at[a > b ? a : b]->comp = a < b ? a : b;
}

/* Link the runs of row list A (sorted by x) with those of B that overlap
 * in x; ia, ib: their global indices. */
static void link_rows(struct hl_run **at, const struct hl_run *A, size_t na, uint32_t ia,
		      const struct hl_run *B, size_t nb, uint32_t ib)
{
	size_t i = 0, j = 0;

	while (i < na && j < nb) {
		if (A[i].x0 <= B[j].x1 && B[j].x0 <= A[i].x1)
			run_union(at, ia + (uint32_t)i, ib + (uint32_t)j);
		if (A[i].x1 < B[j].x1)
			i++;
		else
			j++;
	}
}

/* First run of each row y (rs[y], rs[h] = n) of a row-major run list. */
static void row_starts(const struct hl_run *r, size_t n, int h, size_t *rs)
{
	size_t i = 0;

	for (int y = 0; y <= h; y++) {
		while (i < n && r[i].y < y)
			i++;
		rs[y] = i;
	}
}

static int components(struct hl_fill *f, double min_mm3, double px_area_mm2, struct err *e)
{
	size_t total = 0, *rs0 = NULL, *rs1 = NULL;
	struct hl_run **at = NULL;
	double *vol = NULL;
	uint32_t *off = NULL;
	int rc = 0;

	for (int k = 0; k < f->n; k++)
		total += f->layer[k].n;
	if (total >= UINT32_MAX - 1)
		return ERR_SET(e, ERR_LIMIT, "hollow: fill too fragmented (%zu runs)", total);
	at = mem_alloc((total + 1) * sizeof *at);
	vol = mem_calloc(total + 1, sizeof *vol);
	off = mem_alloc(((size_t)f->n + 1) * sizeof *off);
	rs0 = mem_alloc(((size_t)f->h + 1) * sizeof *rs0);
	rs1 = mem_alloc(((size_t)f->h + 1) * sizeof *rs1);
	if (!at || !vol || !off || !rs0 || !rs1) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory grouping the fill");
		goto out;
	}
	total = 0;
	for (int k = 0; k < f->n; k++) {
		off[k] = (uint32_t)total;
		for (size_t i = 0; i < f->layer[k].n; i++) {
			at[total] = &f->layer[k].run[i];
			at[total]->comp = (uint32_t)total;
			total++;
		}
	}
	off[f->n] = (uint32_t)total;
	for (int k = 0; k < f->n; k++) {
		const struct hl_fill_layer *L = &f->layer[k], *U = k + 1 < f->n ? &f->layer[k + 1] : NULL;
		row_starts(L->run, L->n, f->h, rs0);
		if (U)
			row_starts(U->run, U->n, f->h, rs1);
		for (int y = 0; y < f->h; y++) {
			size_t a = rs0[y], na = rs0[y + 1] - a;
			if (!na)
				continue;
			if (y + 1 < f->h)
				link_rows(at, L->run + a, na, off[k] + (uint32_t)a, L->run + rs0[y + 1],
					  rs0[y + 2] - rs0[y + 1], off[k] + (uint32_t)rs0[y + 1]);
			if (U)
				link_rows(at, L->run + a, na, off[k] + (uint32_t)a, U->run + rs1[y],
					  rs1[y + 1] - rs1[y], off[k + 1] + (uint32_t)rs1[y]);
		}
	}
	for (size_t i = 0; i < total; i++)
		at[i]->comp = run_root(at, (uint32_t)i); /* every comp a root */
	for (size_t i = 0; i < total; i++)
		vol[at[i]->comp] += (at[i]->x1 - at[i]->x0 + 1) * px_area_mm2 * f->layer_mm;
	f->voids = f->voids_small = 0;
	f->volume_mm3 = 0;
	for (size_t i = 0; i < total; i++) {
		if (at[i]->comp != i)
			continue;
		if (vol[i] < min_mm3) {
			f->voids_small++;
		} else {
			f->voids++;
			f->volume_mm3 += vol[i];
		}
	}
	/* drop the small components' runs (void turned solid: the safe side);
	 * every comp is a root now, so compacting keeps it valid */
	for (int k = 0; k < f->n; k++) {
		struct hl_fill_layer *L = &f->layer[k];
		size_t w = 0;
		for (size_t i = 0; i < L->n; i++)
			if (vol[L->run[i].comp] >= min_mm3)
				L->run[w++] = L->run[i];
		L->n = w;
	}
out:
	mem_free(at);
	mem_free(vol);
	mem_free(off);
	mem_free(rs0);
	mem_free(rs1);
	return rc;
}

/* ---- the greedy top-down construction on the grid ---- */

/* Beside a void of its region of C, a new void needs wall + dg + this
 * much (mm) of room: each void costs walls of wall_next down to its
 * floor, and within a few millimetres the neighbour's own growth (dd per
 * layer) fills the space anyway.  3 mm: measured on the cube (one groin
 * vault instead of five cells), camel, cow, elephant and armadillo
 * (docs/hollow.md); 1.5 mm gave the cow 54 % instead of 59 %. */
#define HL_FILL_LONE_MM 3.0

/* Scratch of one layer's window (ww x wh pixels, row stride ww). */
struct win {
	uint8_t *cm, *seed, *vw, *u, *ex, *v;
	float *dc2, *dv2, *su, *de2, *d1, *db2, *sn, *sw;
	int32_t *lab, *near, *lv;
	struct edt_scratch es;
};

static void win_fini(struct win *s)
{
	mem_free(s->cm);
	mem_free(s->seed);
	mem_free(s->vw);
	mem_free(s->u);
	mem_free(s->ex);
	mem_free(s->v);
	mem_free(s->dc2);
	mem_free(s->dv2);
	mem_free(s->su);
	mem_free(s->de2);
	mem_free(s->d1);
	mem_free(s->db2);
	mem_free(s->sn);
	mem_free(s->sw);
	mem_free(s->lab);
	mem_free(s->near);
	mem_free(s->lv);
	edt_scratch_fini(&s->es);
}

static int win_init(struct win *s, size_t np)
{
	memset(s, 0, sizeof *s);
	edt_scratch_init(&s->es);
	s->cm = mem_alloc(np);
	s->seed = mem_alloc(np);
	s->vw = mem_alloc(np);
	s->u = mem_alloc(np);
	s->ex = mem_alloc(np);
	s->v = mem_alloc(np);
	s->dc2 = mem_alloc(np * sizeof(float));
	s->dv2 = mem_alloc(np * sizeof(float));
	s->su = mem_alloc(np * sizeof(float));
	s->de2 = mem_alloc(np * sizeof(float));
	s->d1 = mem_alloc(np * sizeof(float));
	s->db2 = mem_alloc(np * sizeof(float));
	s->sn = mem_alloc(np * sizeof(float));
	s->sw = mem_alloc(np * sizeof(float));
	s->lab = mem_alloc(np * sizeof(int32_t));
	s->near = mem_alloc(np * sizeof(int32_t));
	s->lv = mem_alloc(np * sizeof(int32_t));
	return s->cm && s->seed && s->vw && s->u && s->ex && s->v && s->dc2 && s->dv2 && s->su &&
	       s->de2 && s->d1 && s->db2 && s->sn && s->sw && s->lab && s->near && s->lv;
}

/* Squared distance transform of seed (nonzero), or all INFINITY when
 * any == 0. */
static int dist2(struct win *s, const uint8_t *seed, int any, int ww, int wh, double px,
		 double py, float *out, struct err *e)
{
	if (!any) {
		for (size_t i = 0; i < (size_t)ww * (size_t)wh; i++)
			out[i] = INFINITY;
		return 0;
	}
	return edt_sq(seed, (size_t)ww, ww, wh, px, py, out, &s->es, e);
}

struct geo {
	double dd;    /* design shrink per layer: layer tan(alpha - margin) */
	double dg;    /* discrete reach: the verifier's layer tan(alpha) + 1 px, less 2 % px */
	double wall;  /* wall_next_mm between fill voids */
	double birth; /* inside distance of the free region a new void needs */
	int mv;       /* layers in wall_next: the vertical wall between voids */
	double lone;  /* a new void beside others keeps wall + dg + lone from them */
	double px, py, pmax;
};

/*
 * One layer: V(k) on the window from C(k) (s->cm) and V(k + 1) (s->vw),
 * s->sw = the inside distance of the design's solid of layer k + 1 (mm,
 * INFINITY where unknown).  Pixel sets throughout.  The verifier's rule:
 * every solid pixel of layer k + 1 over a void pixel of layer k lies
 * within dg of a solid pixel of layer k (centre to centre).  Voids only
 * grow here (births are born_cells()):
 *   E = pixels of C(k), solid in layer k + 1, whose inside distance
 *       su = min(dist(V(k + 1)), sig) exceeds dd: the solid the voids
 *       above cannot reach in one layer at the design slope; sig carries
 *       su down the layers, so the solid recedes by dd per layer on
 *       average even when dd is under a pixel (a sub-pixel slope, drawn
 *       as a staircase).  sig counts only while within 2 px of
 *       dist(V(k + 1)): farther, the void it was measured from has
 *       receded (a floor, keep_apart), and sig run down to 0 would turn
 *       solid far from any void into void: ghost cells a pixel or two
 *       wide, every layer, which keep_apart then walled off (the femur's
 *       head lost most of its void to them: 21.7 % -> 41.7 % without);
 *   R = pixels of C(k), solid in layer k + 1 and not in E, farther than
 *       dg from E u not C(k) (thin solid between voids, staircase
 *       corners): kept solid, so every solid pixel of layer k + 1 over a
 *       void of layer k is within dg of solid, exactly on the pixels;
 *   V(k) = C(k) \ (E u R), then kept apart (keep_apart).
 * The material outside C(k) supports but never turns void: a void does
 * not creep along a ceiling flatter than alpha (that left hair-thin fins
 * between a creeping band and the void it outran: docs/hollow.md).
 * Any subset of V(k) keeps the rule for layer k + 1 (void turned solid
 * only adds support), and layer k - 1 is built from the result.
 */
static int layer_below(struct win *s, int ww, int wh, const struct geo *g,
		       struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	int anyv = 0, rc;

	for (size_t i = 0; i < np; i++)
		anyv |= s->vw[i];
	rc = dist2(s, s->vw, anyv, ww, wh, g->px, g->py, s->dv2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++) {
		double dv = sqrt(s->dv2[i]);
		double su = dv > s->sw[i] + 2 * g->pmax ? dv : fmin(dv, s->sw[i]);
		s->su[i] = (float)su;
		s->ex[i] = s->cm[i] && !s->vw[i] && su > g->dd;
		s->seed[i] = s->ex[i] || !s->cm[i];
	}
	rc = dist2(s, s->seed, 1, ww, wh, g->px, g->py, s->de2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++) {
		int t = s->ex[i] || (s->cm[i] && !s->vw[i] && s->de2[i] > g->dg * g->dg);
		s->v[i] = s->cm[i] && !t;
		s->sn[i] = t ? (float)fmax(0, s->su[i] - g->dd) : INFINITY;
	}
	return 0;
}

/*
 * Vertical walls (on s->v): a pixel void in layer k and in some layer
 * k + 2 .. k + mv but solid in between would leave a horizontal wall
 * thinner than wall_next between two voids (a floor over a ceiling): it
 * stays solid.  A subset: safe.  O(pixels).
 */
static void vertical_walls(struct win *s, size_t np, const struct geo *g, int k)
{
	for (size_t i = 0; i < np; i++)
		if (s->v[i] && !s->vw[i] && s->lv[i] >= k + 2 && s->lv[i] <= k + g->mv) {
			s->v[i] = 0;
			s->sn[i] = 0;
		}
}

/* out[i] = allow[i] && pixel i lies on a ridge of the distance map d2
 * (squared, mm^2): d >= dmin and, along one of the four pixel directions,
 * neither neighbour is higher by more than px / 4 while the two together
 * are lower by at least px / 2 (a strict maximum across the ridge; a
 * straight edge, where neighbours along it are equal, is not a ridge).
 * The medial axis of a region, one or two pixels wide: the diagonals of a
 * square, the centre line of a strip.  Returns whether any pixel is set. */
static int ridge(const float *d2, const uint8_t *allow, int ww, int wh, double dmin, double px,
		 uint8_t *out)
{
	static const int dir[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
	int any = 0;

	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			double d = sqrt(d2[i]);
			int c = 0;
			if (allow[i] && d >= dmin && x > 0 && y > 0 && x + 1 < ww && y + 1 < wh)
				for (int q = 0; q < 4 && !c; q++) {
					size_t a = (size_t)(y + dir[q][1]) * (size_t)ww +
						   (size_t)(x + dir[q][0]);
					size_t b = (size_t)(y - dir[q][1]) * (size_t)ww +
						   (size_t)(x - dir[q][0]);
					double da = sqrt(d2[a]), db = sqrt(d2[b]);
					c = da <= d + 0.25 * px && db <= d + 0.25 * px &&
					    (d - da) + (d - db) >= 0.5 * px;
				}
			out[i] = (uint8_t)c;
			any |= c;
		}
	return any;
}

/*
 * New voids (on s->v, after keep_apart).  F = pixels of C(k) farther than
 * wall + dg from every void of layers k .. k + mv (s->lv holds each
 * pixel's last void layer), or farther than wall + dg + lone where their
 * component of C(k) already holds a void (its growth gets there first;
 * without this a square's ridge and the four triangles beside it became
 * five cells instead of one groin vault).  Where F's inside distance D is
 * >= birth, a void is born on F's ridge (ridge(): its medial axis), the
 * crest a groin vault's ceiling collapses to.  Each born pixel lies within
 * dg of a pixel of the ridge's complement, solid in layers k and k + 1
 * (pixels that do not stay solid), so the flat ceiling of the new void
 * spans at most 2 dg: the verifier's rule holds.  Below, layer_below()
 * widens it by dd per layer: a ceiling at the design slope, like the
 * paper's voids.  O(pixels).
 */
static int born_cells(struct win *s, int ww, int wh, const struct geo *g, int k, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	double far = g->wall + g->dg, lone = far + g->lone;
	int32_t nc = 0;
	uint8_t *occ;
	int any = 0, anyf = 0, anyb, rc;

	for (size_t i = 0; i < np; i++) {
		s->seed[i] = s->v[i] || s->vw[i] || s->lv[i] <= k + g->mv;
		any |= s->seed[i];
	}
	rc = dist2(s, s->seed, any, ww, wh, g->px, g->py, s->de2, e);
	if (rc)
		return rc;
	/* occupied components of C(k) (holding a void of layer k) take new
	 * voids only beyond lone: closer, their own voids get there first */
	rc = hl_grid_label(s->cm, ww, wh, s->lab, &nc, e);
	if (rc)
		return rc;
	occ = mem_calloc((size_t)nc + 1, 1);
	if (!occ)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill births)");
	for (size_t i = 0; i < np; i++)
		if (s->v[i])
			occ[s->lab[i]] = 1;
	for (size_t i = 0; i < np; i++) {
		double lim = occ[s->lab[i]] ? lone : far;
		s->u[i] = !(s->cm[i] && s->de2[i] > lim * lim); /* not F */
		anyf |= !s->u[i];
	}
	mem_free(occ);
	if (!anyf)
		return 0;
	rc = dist2(s, s->u, 1, ww, wh, g->px, g->py, s->db2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++)
		s->seed[i] = !s->u[i];
	anyb = ridge(s->db2, s->seed, ww, wh, g->birth, fmin(g->px, g->py), s->ex);
	if (!anyb)
		return 0;
	for (size_t i = 0; i < np; i++)
		s->seed[i] = !s->ex[i];
	rc = dist2(s, s->seed, 1, ww, wh, g->px, g->py, s->d1, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++)
		if (s->ex[i] && s->d1[i] <= g->dg * g->dg) {
			s->v[i] = 1;
			s->sn[i] = INFINITY;
		}
	return 0;
}

/*
 * Keep the voids apart (on s->v, given V(k + 1) = s->vw): without this the
 * greedy void grows into a foam of cells split by walls thinner than a
 * pixel (docs/hollow.md).  With d1 the distance to V(k + 1) and B the
 * pixels where the nearest component of V(k + 1) changes (its Voronoi
 * boundaries, where within reach), a void pixel stays void if
 *   - d1 >= wall + dg: a new cell, >= wall + dg from every component; or
 *   - d1 <= dg (growth of its nearest component) and it lies >= wall / 2
 *     + 1 px from B: two components stay >= wall apart, each on its side
 *     of their bisector.
 * Everything else turns solid (a subset: safe).  O(pixels).
 */
static int keep_apart(struct win *s, int ww, int wh, const struct geo *g, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	double cut = g->wall + 2 * g->dg + 2 * g->pmax, half = 0.5 * g->wall + g->pmax;
	int32_t count;
	int anyb = 0, rc;

	rc = hl_grid_label(s->vw, ww, wh, s->lab, &count, e);
	if (!rc)
		rc = hl_grid_nearest(s->lab, ww, wh, g->px, g->py, s->d1, s->near, e);
	if (rc)
		return rc;
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			int32_t l = s->near[i];
			s->seed[i] = l && s->d1[i] <= cut * cut &&
				     ((x > 0 && s->near[i - 1] != l) ||
				      (x + 1 < ww && s->near[i + 1] != l) ||
				      (y > 0 && s->near[i - (size_t)ww] != l) ||
				      (y + 1 < wh && s->near[i + (size_t)ww] != l));
			anyb |= s->seed[i];
		}
	rc = dist2(s, s->seed, anyb, ww, wh, g->px, g->py, s->db2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++) {
		double d1;
		if (!s->v[i])
			continue;
		d1 = sqrt(s->d1[i]);
		if (d1 >= g->wall + g->dg || (d1 <= g->dg && s->db2[i] >= half * half))
			continue;
		s->v[i] = 0;
		s->sn[i] = 0;
	}
	return 0;
}

/*
 * No floating islands: a solid component of layer k + 1 (8-connected, the
 * part's material and the outside counting as solid) with nothing solid
 * under any of its pixels would print onto liquid resin.  Its pixels stay
 * solid in layer k (on s->v): a pillar that the next layers carry down to
 * the floor (adding solid never breaks the overhang rule).  O(pixels).
 */
static int support_islands(struct win *s, int ww, int wh, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	uint8_t *held = NULL;
	int32_t count;
	int rc;

	for (size_t i = 0; i < np; i++)
		s->seed[i] = !s->vw[i];
	rc = hl_grid_label(s->seed, ww, wh, s->lab, &count, e);
	if (rc)
		return rc;
	held = mem_calloc((size_t)count + 1, 1);
	if (!held)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill islands)");
	for (size_t i = 0; i < np; i++)
		if (s->lab[i] && !s->v[i])
			held[s->lab[i]] = 1;
	for (size_t i = 0; i < np; i++)
		if (s->lab[i] && !held[s->lab[i]]) {
			s->v[i] = 0;
			s->sn[i] = 0;
		}
	mem_free(held);
	return 0;
}

/* Grid of map m over the part's box: *u0, *v0, *w, *h; pitches. */
static int grid_of(const struct mesh *part, const struct raster_map *m, struct hl_fill *f,
		   double *px, double *py, struct err *e)
{
	struct box3 bb = box3_empty();
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;

	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	*px = hypot(m->a[1][1], m->a[1][0]) / fabs(det);
	*py = hypot(m->a[0][1], m->a[0][0]) / fabs(det);
	for (int q = 0; q < 4; q++) {
		double u, v;
		raster_map_apply(m, q & 1 ? bb.hi.x : bb.lo.x, q & 2 ? bb.hi.y : bb.lo.y, &u, &v);
		umin = fmin(umin, u);
		umax = fmax(umax, u);
		vmin = fmin(vmin, v);
		vmax = fmax(vmax, v);
	}
	f->u0 = (int)floor(umin) - 2;
	f->v0 = (int)floor(vmin) - 2;
	f->w = (int)ceil(umax) - f->u0 + 2;
	f->h = (int)ceil(vmax) - f->v0 + 2;
	if (f->w > 65535 || f->h > 65535 || (double)f->w * f->h > 268435456.0)
		return ERR_SET(e, ERR_LIMIT, "hollow: fill grid %d x %d too large", f->w, f->h);
	return 0;
}

int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_config *c,
		  struct progress *prog, double f0, double f1, struct hl_fill *f, struct err *e)
{
	const struct raster_map *m = &c->fill_map;
	struct hl_fill r;
	struct hl_fill_layer *C = NULL;
	struct raster_map gm;
	struct win s;
	struct geo g;
	struct box3 bb = box3_empty();
	uint8_t *vup = NULL;
	float *sig = NULL;
	int32_t *lastv = NULL; /* per grid pixel: the lowest layer so far where it is void */
	int px0 = 0, py0 = 0, px1 = 0, py1 = 0, pad, rc = 0, n;
	double L = c->print_layer_mm;

	memset(&r, 0, sizeof r);
	memset(&s, 0, sizeof s);
	edt_scratch_init(&s.es);
	/* only an axis-aligned grid (rotations by quarter turns, mirrors) has
	 * rows and columns that are lines of the printer frame */
	if (!c->fill_map_set || !(L > 0) ||
	    !((m->a[0][1] == 0 && m->a[1][0] == 0) || (m->a[0][0] == 0 && m->a[1][1] == 0)))
		return 0;
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	n = (int)ceil(bb.hi.z / L - 1e-9);
	if (n < 1)
		return 0;
	rc = grid_of(part, m, &r, &g.px, &g.py, e);
	if (rc)
		return rc;
	r.n = n;
	r.layer_mm = L;
	r.map = *m;
	g.pmax = fmax(g.px, g.py);
	g.dd = L * tan(c->alpha_rad - c->margin_rad);
	g.dg = L * tan(c->alpha_rad) + 0.98 * g.pmax;
	g.wall = c->wall_next_mm;
	g.mv = (int)ceil(g.wall / L - 1e-9);
	g.birth = 0.5 * g.wall;
	g.lone = HL_FILL_LONE_MM;
	pad = (int)ceil((g.wall + 2 * g.dg + 2 * g.pmax) / fmin(g.px, g.py)) + 2;
	gm = *m;
	gm.b[0] -= r.u0;
	gm.b[1] -= r.v0;
	r.layer = mem_calloc((size_t)n, sizeof *r.layer);
	C = mem_calloc((size_t)n, sizeof *C);
	vup = mem_calloc((size_t)r.w * (size_t)r.h, 1);
	sig = mem_alloc((size_t)r.w * (size_t)r.h * sizeof *sig);
	lastv = mem_alloc((size_t)r.w * (size_t)r.h * sizeof *lastv);
	if (!r.layer || !C || !vup || !sig || !lastv || !win_init(&s, (size_t)r.w * (size_t)r.h)) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill)");
		goto out;
	}
	for (size_t i = 0; i < (size_t)r.w * (size_t)r.h; i++) {
		sig[i] = INFINITY;
		lastv[i] = INT32_MAX;
	}
	rc = offset_stack(part, solid, c, &gm, r.w, r.h, n, C, e);
	for (int k = n - 1; !rc && k >= 0; k--) {
		int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1, ww = 0, wh = 0;
		size_t cap = 0;
		if (prog && k % 16 == 0) {
			rc = progress_update(prog, f0 + (f1 - f0) * (n - k) / n, e);
			if (rc)
				break;
		}
		for (size_t i = 0; i < C[k].n; i++) {
			x0 = C[k].run[i].x0 < x0 ? C[k].run[i].x0 : x0;
			x1 = C[k].run[i].x1 > x1 ? C[k].run[i].x1 : x1;
			y0 = C[k].run[i].y < y0 ? C[k].run[i].y : y0;
			y1 = C[k].run[i].y > y1 ? C[k].run[i].y : y1;
		}
		if (x1 >= 0) {
			x0 = x0 - pad < 0 ? 0 : x0 - pad;
			y0 = y0 - pad < 0 ? 0 : y0 - pad;
			x1 = x1 + pad + 1 > r.w ? r.w : x1 + pad + 1;
			y1 = y1 + pad + 1 > r.h ? r.h : y1 + pad + 1;
			ww = x1 - x0;
			wh = y1 - y0;
			memset(s.cm, 0, (size_t)ww * (size_t)wh);
			for (size_t i = 0; i < C[k].n; i++)
				memset(s.cm + (size_t)(C[k].run[i].y - y0) * (size_t)ww +
					       (C[k].run[i].x0 - x0),
				       1, (size_t)(C[k].run[i].x1 - C[k].run[i].x0 + 1));
			for (int y = 0; y < wh; y++) {
				memcpy(s.vw + (size_t)y * (size_t)ww,
				       vup + (size_t)(y + y0) * (size_t)r.w + x0, (size_t)ww);
				memcpy(s.sw + (size_t)y * (size_t)ww,
				       sig + (size_t)(y + y0) * (size_t)r.w + x0,
				       (size_t)ww * sizeof *sig);
				memcpy(s.lv + (size_t)y * (size_t)ww,
				       lastv + (size_t)(y + y0) * (size_t)r.w + x0,
				       (size_t)ww * sizeof *lastv);
			}
			rc = layer_below(&s, ww, wh, &g, e);
			if (!rc)
				rc = keep_apart(&s, ww, wh, &g, e);
			if (!rc) {
				vertical_walls(&s, (size_t)ww * (size_t)wh, &g, k);
				rc = born_cells(&s, ww, wh, &g, k, e);
			}
			if (!rc)
				rc = support_islands(&s, ww, wh, e);
			if (!rc)
				rc = hl_grid_runs(s.v, ww, 0, 0, ww, wh, &r.layer[k].run, &r.layer[k].n,
						  &cap, e);
			for (size_t i = 0; !rc && i < r.layer[k].n; i++) {
				r.layer[k].run[i].y += y0;
				r.layer[k].run[i].x0 += x0;
				r.layer[k].run[i].x1 += x0;
			}
		}
		/* the state for layer k - 1: V(k) and the core's inside distance */
		for (int y = py0; y < py1; y++) {
			memset(vup + (size_t)y * (size_t)r.w + px0, 0, (size_t)(px1 - px0));
			for (int x = px0; x < px1; x++)
				sig[(size_t)y * (size_t)r.w + (size_t)x] = INFINITY;
		}
		px0 = py0 = px1 = py1 = 0;
		if (rc || x1 < 0)
			continue;
		for (int y = y0; y < y1; y++) {
			memcpy(vup + (size_t)y * (size_t)r.w + x0, s.v + (size_t)(y - y0) * (size_t)ww,
			       (size_t)ww);
			memcpy(sig + (size_t)y * (size_t)r.w + x0, s.sn + (size_t)(y - y0) * (size_t)ww,
			       (size_t)ww * sizeof *sig);
			for (int x = x0; x < x1; x++)
				if (s.v[(size_t)(y - y0) * (size_t)ww + (size_t)(x - x0)])
					lastv[(size_t)y * (size_t)r.w + (size_t)x] = k;
		}
		px0 = x0;
		py0 = y0;
		px1 = x1;
		py1 = y1;
		mem_free(C[k].run);
		C[k].run = NULL;
		C[k].n = 0;
	}
	if (!rc)
		rc = components(&r, c->min_void_mm3, g.px * g.py, e);
	if (!rc) {
		hl_fill_fini(f);
		*f = r;
		memset(&r, 0, sizeof r);
	}
out:
	for (int k = 0; C && k < n; k++)
		mem_free(C[k].run);
	mem_free(C);
	mem_free(vup);
	mem_free(sig);
	mem_free(lastv);
	win_fini(&s);
	hl_fill_fini(&r);
	return rc;
}
