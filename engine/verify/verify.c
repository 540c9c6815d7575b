/* verify.c - streaming layer-stack checker (see verify.h, docs/verify.md).
 *
 * Per layer, over a crop = bounding box of this and the previous layer's
 * solid pixels grown by the overhang reach plus two pixels (everything
 * outside the crop is void connected to the outside):
 *  1. void components, 8-connected (so solid walls are 4-connected: a
 *     void pixel that meets the outside only at a pixel corner IS the
 *     outside); each gets a union-find id; those touching the crop edge
 *     are the outside (id VX_OUT); with a reference stack, those holding
 *     a pixel it holds void are the part's own air (v->air), joined to
 *     the outside at the end once their overhangs are counted;
 *  2. vertical links: a void pixel above/below a void pixel joins their
 *     components (6-connectivity in 3D);
 *  3. overhangs: solid pixels over void pixels of the previous layer whose
 *     distance to that layer's solid exceeds the reach; counted per void
 *     component and resolved at the end (a component that later reaches
 *     the outside is not interior);
 *  4. islands: solid components (8-connected) with no solid beneath;
 *  5. distance transforms: to this layer's solid (for the next layer's
 *     overhang test) and to its outside void (wall thickness); fins:
 *     solid runs of <= VX_FIN_PX pixels between 2D-enclosed voids,
 *     counted per void component and resolved at the end like overhangs.
 *
 * Overhangs are measured at sub-pixel accuracy from the anti-aliased
 * layers (subpx.h, support.c): a pixel overhangs when a point of its
 * solid region lies farther than layer_mm * tan(alpha) + tolerance_px
 * pixels from the layer below's solid regions.
 *
 * Walls.  In-layer wall of an enclosed void component = min over its
 * pixels of the Euclidean distance between that pixel's centre and the
 * nearest centre of an outside void pixel of the same layer, minus one
 * pixel pitch (the half pixel of void on each side: a wall of N solid
 * pixels between two void pixels on a row reads exactly N pixels).  With
 * centre-sampled or coverage-thresholded layers each boundary is off by
 * up to half a pixel, so a true wall T reads within T +- 1 pixel.
 * Vertical wall = length of a column's solid run between an enclosed
 * void and the outside (or the open top), in whole layers.  Enclosure is
 * the 3D one (resolved in verify_finish).  Enclosed 3D components of at
 * most speck_voxels voxels (rasterisation specks) do not enter the
 * minima; they are counted apart (specks, speck_min_wall_mm).
 */
#include "engine/verify/verify.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/geom/edt.h"
#include "engine/geom/label.h"
#include "engine/geom/raster.h"
#include "engine/verify/between.h"
#include "engine/verify/contact.h"
#include "engine/verify/fins.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify_int.h"

void verify_report_fini(struct verify_report *r)
{
	mem_free(r->overhang_px);
	memset(r, 0, sizeof *r);
}

static void crop_fini(struct crop *c)
{
	mem_free(c->solid);
	mem_free(c->gray);
	mem_free(c->lab);
	mem_free(c->d2);
	mem_free(c->near);
	mem_free(c->any_d2);
	verify_subpx_fits_fini(&c->fits);
	memset(c, 0, sizeof *c);
}

void verify_free(struct verify *v)
{
	if (!v)
		return;
	crop_fini(&v->a);
	crop_fini(&v->b);
	mem_free(v->uf);
	mem_free(v->ov.v);
	mem_free(v->ovx.v);
	mem_free(v->aggx);
	mem_free(v->ovh);
	verify_fit_memo_free(v->memo);
	mem_free(v->wall.v);
	mem_free(v->vol.v);
	mem_free(v->vwall.v);
	mem_free(v->fin.v);
	mem_free(v->sliver.v);
	verify_fins_fini(&v->vf);
	mem_free(v->between.v);
	mem_free(v->shelf.v);
	verify_between_fini(&v->vb);
	verify_contact_fini(&v->ref);
	mem_free(v->wlab);
	mem_free(v->fcnt);
	mem_free(v->col);
	mem_free(v->col_id);
	mem_free(v->enc);
	mem_free(v->air);
	mem_free(v->prev_enc);
	mem_free(v->agg);
	mem_free(v->isl_lab);
	mem_free(v->isl_area);
	mem_free(v->isl_flag);
	mem_free(v->seed);
	mem_free(v->ext_d2);
	mem_free(v->cnt);
	edt_scratch_fini(&v->es);
	verify_report_fini(&v->r);
	mem_free(v);
}

int verify_new(const struct verify_params *p, struct verify **out, struct err *e)
{
	struct verify *v;
	double pmin;

	if (!(p->layer_mm > 0))
		return ERR_FIELD(e, "layer_mm", "verify: layer height must be > 0 (got %g)", p->layer_mm);
	if (!(p->alpha_deg > 0 && p->alpha_deg < 90))
		return ERR_FIELD(e, "alpha_deg", "verify: alpha must be in (0, 90) degrees (got %g)",
				 p->alpha_deg);
	if (!(p->pixel_x_mm > 0) || !(p->pixel_y_mm > 0))
		return ERR_FIELD(e, "pixel_mm", "verify: pixel pitch must be > 0 (got %g x %g)",
				 p->pixel_x_mm, p->pixel_y_mm);
	if (p->speck_voxels < 0)
		return ERR_FIELD(e, "speck_voxels", "verify: speck_voxels must be >= 0 (got %d)",
				 p->speck_voxels);
	if (p->tolerance_px < 0 || p->threshold < 0 || p->threshold > 255)
		return ERR_FIELD(e, "tolerance_px", "verify: bad tolerance or threshold");
	v = mem_calloc(1, sizeof *v);
	if (!v)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	v->p = *p;
	if (v->p.tolerance_px == 0)
		v->p.tolerance_px = VERIFY_TOLERANCE_PX;
	if (v->p.threshold == 0)
		v->p.threshold = VERIFY_THRESHOLD;
	if (v->p.speck_voxels == 0)
		v->p.speck_voxels = VERIFY_SPECK_VOXELS;
	pmin = fmin(p->pixel_x_mm, p->pixel_y_mm);
	v->slope_mm = p->layer_mm * tan(p->alpha_deg * M_PI / 180);
	v->reach_mm = v->slope_mm + v->p.tolerance_px * fmax(p->pixel_x_mm, p->pixel_y_mm);
	v->ext_reach_mm = v->slope_mm + fmax(p->pixel_x_mm, p->pixel_y_mm);
	v->margin = (int)ceil(fmax(v->reach_mm, v->ext_reach_mm) / pmin) + 2;
	v->prev = &v->a;
	v->cur = &v->b;
	edt_scratch_init(&v->es);
	verify_between_init(&v->vb);
	v->es.threads = v->vb.es.threads = p->threads;
	verify_fins_init(&v->vf);
	v->r.worst_layer = -1;
	v->r.first_island_layer = -1;
	v->r.first_added_island_layer = -1;
	v->r.first_interior_island_layer = -1;
	v->r.first_solid_layer = -1;
	verify_contact_init(&v->ref);
	v->r.min_wall_mm = INFINITY;
	v->r.min_wall_layer = -1;
	v->r.min_wall_vertical_mm = INFINITY;
	v->r.speck_min_wall_mm = INFINITY;
	v->r.min_wall_between_mm = INFINITY;
	v->r.min_wall_between_layer = -1;
	v->r.min_wall_between_vertical_mm = INFINITY;
	/* union-find: 0 unused, 1 = outside */
	v->ufcap = 1024;
	v->uf = mem_alloc(v->ufcap * sizeof *v->uf);
	v->memo = verify_fit_memo_new(0);
	if (!v->uf || !v->memo) {
		verify_free(v);
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	}
	v->uf[0] = 0;
	v->uf[1] = 1;
	v->nuf = 2;
	*out = v;
	return 0;
}

uint32_t verify_uf_find(struct verify *v, uint32_t a)
{
	while (v->uf[a] != a) {
		v->uf[a] = v->uf[v->uf[a]];
		a = v->uf[a];
	}
	return a;
}

static void uf_union(struct verify *v, uint32_t a, uint32_t b)
{
	a = verify_uf_find(v, a);
	b = verify_uf_find(v, b);
	if (a == b)
		return;
	/* the outside stays a root */
	if (a == VX_OUT)
		v->uf[b] = a;
	else
		v->uf[a] = b;
}

static int uf_new(struct verify *v, uint32_t *id)
{
	if (v->nuf == v->ufcap) {
		void *arr = v->uf;
		if (v->nuf >= UINT32_MAX - 1 || mem_grow(&arr, &v->ufcap, v->nuf + 1, sizeof *v->uf))
			return ERR_NOMEM;
		v->uf = arr;
	}
	*id = (uint32_t)v->nuf;
	v->uf[v->nuf] = (uint32_t)v->nuf;
	v->nuf++;
	return 0;
}

static int rec_add2(struct recs *r, uint32_t id, uint32_t id2, int layer, double val)
{
	if (r->n == r->cap) {
		void *arr = r->v;
		if (mem_grow(&arr, &r->cap, r->n + 1, sizeof *r->v))
			return ERR_NOMEM;
		r->v = arr;
	}
	r->v[r->n].id = id;
	r->v[r->n].id2 = id2;
	r->v[r->n].layer = layer;
	r->v[r->n].val = val;
	r->n++;
	return 0;
}

int verify_rec_add(struct recs *r, uint32_t id, int layer, double val)
{
	return rec_add2(r, id, 0, layer, val);
}

/* A solid run of t_mm along a column between void components a (above)
 * and b (below); at least one was 2D-enclosed.  Runs of one row of
 * pixels between the same two components collapse into one record. */
static int vwall_add(struct verify *v, uint32_t a, uint32_t b, int layer, double t_mm)
{
	struct rec *q = v->vwall.n ? &v->vwall.v[v->vwall.n - 1] : NULL;

	if (q && q->id == a && q->id2 == b && q->layer == layer) {
		q->val = fmin(q->val, t_mm);
		return 0;
	}
	return rec_add2(&v->vwall, a, b, layer, t_mm);
}

/* Shelves: n solid voxels in column runs of <= VX_FIN_PX layers between
 * 2D-enclosed void components a (above) and b (below); consecutive
 * columns of one row between the same two collapse into one record. */
static int shelf_add(struct verify *v, uint32_t a, uint32_t b, int layer, double n)
{
	struct rec *q = v->shelf.n ? &v->shelf.v[v->shelf.n - 1] : NULL;

	if (q && q->id == a && q->id2 == b && q->layer == layer) {
		q->val += n;
		return 0;
	}
	return rec_add2(&v->shelf, a, b, layer, n);
}

/* Scratch growth: the old contents are dropped, not copied. */
int verify_grow_bytes(void **p, size_t *cap, size_t need)
{
	if (need <= *cap)
		return 0;
	mem_free(*p);
	*p = mem_alloc(need);
	*cap = *p ? need : 0;
	return *p ? 0 : ERR_NOMEM;
}

static int crop_alloc(struct crop *c, size_t n)
{
	if (n <= c->cap)
		return 0;
	mem_free(c->solid);
	mem_free(c->gray);
	mem_free(c->lab);
	mem_free(c->d2);
	mem_free(c->near);
	mem_free(c->any_d2);
	c->solid = mem_alloc(n);
	c->gray = mem_alloc(n);
	c->lab = mem_alloc(n * sizeof *c->lab);
	c->d2 = mem_alloc(n * sizeof *c->d2);
	c->near = mem_alloc(n * sizeof *c->near);
	c->any_d2 = mem_alloc(n * sizeof *c->any_d2);
	c->cap = c->solid && c->gray && c->lab && c->d2 && c->near && c->any_d2 ? n : 0;
	return c->cap ? 0 : ERR_NOMEM;
}

/* Solid state of image pixel (x, y) in crop c: 1 solid, 0 void (outside the
 * crop is void). */
int verify_crop_solid(const struct crop *c, int x, int y, size_t *idx)
{
	int cx = x - c->x0, cy = y - c->y0;

	if (c->w == 0 || cx < 0 || cy < 0 || cx >= c->w || cy >= c->h) {
		*idx = SIZE_MAX;
		return 0;
	}
	*idx = (size_t)cy * (size_t)c->w + (size_t)cx;
	return c->solid[*idx];
}

/* Label void components (8-connected) of the current crop; see the head
 * comment for why 8 and not 4.  The components get union-find ids from
 * v->nuf on, in raster order of their first pixel (label.h); one that
 * touches the crop's border is joined to the outside.  One with a pixel
 * that ref (the same layer of the solid part, NULL: none) holds void is
 * the part's own air (a sealed pocket of its own, or a crevice that the
 * layers' linking reads as sealed): not 2D-enclosed, and marked in
 * v->air for verify_finish.  Scratch: v->seed (the void mask). */
static int label_voids(struct verify *v, const struct raster *ref, uint32_t *ncomp)
{
	struct crop *c = v->cur;
	int w = c->w, h = c->h;
	size_t np = (size_t)w * (size_t)h;
	uint32_t first = (uint32_t)v->nuf, id;
	int32_t n = 0, *lab = (int32_t *)c->lab;
	struct err e;

	if (verify_grow_bytes((void **)&v->seed, &v->scratch_cap, np))
		return ERR_NOMEM;
	for (size_t i = 0; i < np; i++)
		v->seed[i] = !c->solid[i];
	err_clear(&e);
	if (label_components8(v->seed, w, h, lab, &n, &e))
		return ERR_NOMEM;
	/* one 2D-enclosed flag per component: set, then cleared below for
	 * the components on the crop's border */
	if (n > 0 && mem_grow((void **)&v->enc, &v->enc_cap, (size_t)n, 1))
		return ERR_NOMEM;
	for (int32_t l = 0; l < n; l++) {
		if (uf_new(v, &id))
			return ERR_NOMEM;
		v->enc[l] = 1;
	}
	for (int y = 0; y < h; y++) {
		int step = y == 0 || y == h - 1 ? 1 : (w > 1 ? w - 1 : 1);
		for (int x = 0; x < w; x += step) {
			int32_t l = lab[(size_t)y * (size_t)w + (size_t)x];
			if (l > 0)
				v->enc[l - 1] = 0;
		}
	}
	if (ref) {
		if (mem_grow((void **)&v->air, &v->air_cap, v->nuf, 1))
			return ERR_NOMEM;
		memset(v->air + v->air_n, 0, v->nuf - v->air_n);
		v->air_n = v->nuf;
	}
	for (int y = 0; ref && y < h; y++) {
		const uint8_t *row = ref->px + (size_t)(y + c->y0) * ref->stride + c->x0;
		const int32_t *lr = lab + (size_t)y * (size_t)w;
		for (int x = 0; x < w; x++)
			if (lr[x] > 0 && row[x] < v->p.threshold && v->enc[lr[x] - 1]) {
				v->enc[lr[x] - 1] = 0;
				v->air[first + (uint32_t)(lr[x] - 1)] = 1;
			}
	}
	for (size_t i = 0; i < np; i++)
		c->lab[i] = lab[i] > 0 ? first + (uint32_t)(lab[i] - 1) : 0;
	for (int32_t l = 0; l < n; l++)
		if (!v->enc[l] && !(ref && v->air[first + (uint32_t)l]))
			uf_union(v, first + (uint32_t)l, VX_OUT);
	v->cur_first = first;
	*ncomp = (uint32_t)n;
	return 0;
}

/* In-layer walls between two 2D-enclosed void components of the current
 * crop: every void pixel is a seed (the outside too, so two cavities
 * with the outside between them are no pair); pairs of enclosed
 * components get a record (centre distance minus one pixel, as walls to
 * the outside), resolved in 3D in verify_finish.  The window is the
 * bounding box of the enclosed void pixels: the nearest pair of two
 * cavities and the midpoint between them lie in it, and seeds outside it
 * could only hide pairs, never make one closer (between.c). */
static int walls_between(struct verify *v, int layer, struct err *e)
{
	const struct crop *c = v->cur;
	double pmin = fmin(v->p.pixel_x_mm, v->p.pixel_y_mm);
	int x0 = c->w, y0 = c->h, x1 = -1, y1 = -1, ww, wh;

	for (int y = 0; y < c->h; y++)
		for (int x = 0; x < c->w; x++) {
			size_t i = (size_t)y * (size_t)c->w + (size_t)x;
			if (c->solid[i] || !v->enc[c->lab[i] - v->cur_first])
				continue;
			x0 = x < x0 ? x : x0;
			x1 = x > x1 ? x : x1;
			y0 = y < y0 ? y : y0;
			y1 = y > y1 ? y : y1;
		}
	ww = x1 - x0 + 1;
	wh = y1 - y0 + 1;
	/* window copies: seeds in v->seed, labels in v->wlab */
	if (verify_grow_bytes((void **)&v->wlab, &v->wlab_cap, (size_t)ww * (size_t)wh * sizeof *v->wlab))
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)(y + y0) * (size_t)c->w + (size_t)(x + x0);
			size_t o = (size_t)y * (size_t)ww + (size_t)x;
			v->seed[o] = !c->solid[i];
			v->wlab[o] = c->lab[i];
		}
	if (verify_between_pairs(v->seed, v->wlab, ww, wh, v->p.pixel_x_mm, v->p.pixel_y_mm,
				 &v->vb, e))
		return e ? e->code : ERR_NOMEM;
	for (size_t k = 0; k < v->vb.n; k++) {
		const struct verify_pair *q = &v->vb.pairs[k];
		if (q->a == VX_OUT || q->b == VX_OUT || !v->enc[q->a - v->cur_first] ||
		    !v->enc[q->b - v->cur_first])
			continue;
		if (rec_add2(&v->between, q->a, q->b, layer, q->d_mm - pmin))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
	}
	return 0;
}

int verify_layer(struct verify *v, const struct raster *r, struct err *e)
{
	return verify_layer_ref(v, r, NULL, e);
}

/* Join each void pixel of crop c (this layer) with what lies under it
 * in crop pc (the previous layer): its void component, or the outside
 * where pc has no pixel there; and each void pixel of pc outside c with
 * the outside (it sits under this layer's outside). */
static void link_layers(struct verify *v, const struct crop *c, const struct crop *pc)
{
	uint32_t la = 0, lb = 0;

	for (int y = 0; y < c->h; y++) {
		int py = y + c->y0 - pc->y0, rowin = pc->w > 0 && py >= 0 && py < pc->h;
		for (int x = 0; x < c->w; x++) {
			size_t i = (size_t)y * (size_t)c->w + (size_t)x;
			int px = x + c->x0 - pc->x0;
			uint32_t b = VX_OUT;
			if (c->solid[i])
				continue;
			if (rowin && px >= 0 && px < pc->w) {
				size_t pi = (size_t)py * (size_t)pc->w + (size_t)px;
				if (pc->solid[pi])
					continue;
				b = pc->lab[pi];
			}
			if (c->lab[i] == la && b == lb)
				continue;
			la = c->lab[i];
			lb = b;
			uf_union(v, la, lb);
		}
	}
	la = 0;
	for (int y = 0; y < pc->h; y++) {
		int cy = y + pc->y0 - c->y0, rowin = c->w > 0 && cy >= 0 && cy < c->h;
		for (int x = 0; x < pc->w; x++) {
			size_t i = (size_t)y * (size_t)pc->w + (size_t)x;
			int cx = x + pc->x0 - c->x0;
			if (pc->solid[i] || (rowin && cx >= 0 && cx < c->w) || pc->lab[i] == la)
				continue;
			la = pc->lab[i];
			uf_union(v, la, VX_OUT);
		}
	}
}

int verify_layer_ref(struct verify *v, const struct raster *r, const struct raster *ref,
		     struct err *e)
{
	struct crop *c, *pc;
	int x0 = INT32_MAX, y0 = INT32_MAX, x1 = -1, y1 = -1, layer = v->next;
	uint32_t ncomp = 0;
	size_t grey = 0; /* pixels 0 < gray < 255 in the crop */

	if (v->failed || v->finished)
		return ERR_SET(e, ERR_INTERNAL, "verify: check already %s",
			       v->failed ? "failed" : "finished");
	if (layer == 0) {
		v->w = r->w;
		v->h = r->h;
		v->col_ok = 1;
		v->col = mem_calloc((size_t)r->w * (size_t)r->h, sizeof *v->col);
		v->col_id = mem_calloc((size_t)r->w * (size_t)r->h, sizeof *v->col_id);
		if (!v->col || !v->col_id)
			goto nomem;
	} else if (r->w != v->w || r->h != v->h) {
		return ERR_FIELD(e, "layer", "verify: layer %d is %dx%d, earlier layers %dx%d", layer,
				 r->w, r->h, v->w, v->h);
	}
	if (layer >= UINT16_MAX)
		v->col_ok = 0;
	if (layer == 0)
		v->r.has_reference = ref != NULL;
	if ((ref != NULL) != v->r.has_reference)
		return ERR_FIELD(e, "reference", "verify: layer %d %s a reference layer, layer 0 %s",
				 layer, ref ? "has" : "lacks", ref ? "did not" : "did");
	if (ref && (ref->w != r->w || ref->h != r->h))
		return ERR_FIELD(e, "reference", "verify: reference layer %d is %dx%d, the layers %dx%d",
				 layer, ref->w, ref->h, r->w, r->h);
	if (ref && verify_contact_layer(&v->ref, ref, v->p.threshold) != 0)
		goto nomem; /* sizes are equal to r's, checked above */
	/* swap: the current crop becomes the previous one */
	pc = v->cur;
	v->cur = v->prev;
	v->prev = pc;
	c = v->cur;
	{
		uint8_t *t = v->prev_enc;
		size_t tc = v->prev_enc_cap;
		v->prev_enc = v->enc;
		v->prev_enc_cap = v->enc_cap;
		v->enc = t;
		v->enc_cap = tc;
		v->prev_first = v->cur_first;
	}
	if (layer == 0)
		pc->w = 0;
	verify_subpx_fits_reset(&c->fits);
	v->cur_first = (uint32_t)v->nuf;
	/* solid bounding box of this layer: each row's first and last solid
	 * pixel, the stretch between them unread */
	for (int y = 0; y < r->h; y++) {
		const uint8_t *row = r->px + (size_t)y * r->stride;
		int a, b;
		if (!raster_row_span(row, r->w, v->p.threshold, &a, &b))
			continue;
		x0 = a < x0 ? a : x0;
		x1 = b > x1 ? b : x1;
		y0 = y < y0 ? y : y0;
		y1 = y;
	}
	c->sx0 = x0;
	c->sy0 = y0;
	c->sx1 = x1;
	c->sy1 = y1;
	if (x1 >= 0 && v->r.first_solid_layer < 0)
		v->r.first_solid_layer = layer;
	/* grow by the previous layer's solid (not its crop: crops would creep) */
	if (pc->w && pc->sx1 >= 0) {
		x0 = pc->sx0 < x0 ? pc->sx0 : x0;
		y0 = pc->sy0 < y0 ? pc->sy0 : y0;
		x1 = pc->sx1 > x1 ? pc->sx1 : x1;
		y1 = pc->sy1 > y1 ? pc->sy1 : y1;
	}
	if (x1 < 0) {
		c->w = c->h = 0; /* nothing on this layer or the previous one */
	} else {
		x0 = x0 - v->margin < 0 ? 0 : x0 - v->margin;
		y0 = y0 - v->margin < 0 ? 0 : y0 - v->margin;
		x1 = x1 + v->margin >= r->w ? r->w - 1 : x1 + v->margin;
		y1 = y1 + v->margin >= r->h ? r->h - 1 : y1 + v->margin;
		c->x0 = x0;
		c->y0 = y0;
		c->w = x1 - x0 + 1;
		c->h = y1 - y0 + 1;
		if (crop_alloc(c, (size_t)c->w * (size_t)c->h))
			goto nomem;
		for (int y = 0; y < c->h; y++) {
			const uint8_t *row = r->px + (size_t)(y + y0) * r->stride + x0;
			for (int x = 0; x < c->w; x++) {
				c->solid[(size_t)y * (size_t)c->w + (size_t)x] = row[x] >= v->p.threshold;
				c->gray[(size_t)y * (size_t)c->w + (size_t)x] = row[x];
				grey += row[x] > 0 && row[x] < 255;
			}
		}
		if (verify_subpx_fits_size(&c->fits, (size_t)c->w * (size_t)c->h, grey))
			goto nomem;
		c->any_ok = 0;
		if (label_voids(v, ref, &ncomp))
			goto nomem;
	}
	/* 2. vertical links (the plate closes the bottom of layer 0); a pair
	 * of labels joined already (the pixel before in the row) is skipped:
	 * union is idempotent */
	if (layer > 0)
		link_layers(v, c, pc);
	/* 3. overhangs of this layer over the previous one, per void component */
	if (layer > 0 && c->w && verify_overhangs(v, layer, e))
		goto fail;
	/* 4. islands */
	if (c->w && verify_islands(v, layer))
		goto nomem;
	/* 5a. distance to this layer's solid (next layer's overhang test) */
	if (c->w && edt_nearest_sq(c->solid, (size_t)c->w, c->w, c->h, v->p.pixel_x_mm,
				   v->p.pixel_y_mm, c->d2, c->near, &v->es, e))
		goto fail;
	/* 5b. walls: distance from enclosed voids to this layer's outside void */
	if (c->w && ncomp) {
		size_t n = (size_t)c->w * (size_t)c->h;
		int any = 0, nenc = 0;
		if (verify_grow_bytes((void **)&v->seed, &v->scratch_cap, n) ||
		    verify_grow_bytes((void **)&v->agg, &v->agg_cap, ncomp * sizeof *v->agg) ||
		    verify_grow_bytes((void **)&v->cnt, &v->cnt_cap, ncomp * sizeof *v->cnt) ||
		    verify_grow_bytes((void **)&v->ext_d2, &v->ext_cap, n * sizeof *v->ext_d2))
			goto nomem;
		for (size_t i = 0; i < n; i++) {
			uint32_t l = c->lab[i];
			v->seed[i] = !c->solid[i] && !v->enc[l - v->cur_first];
			any |= !c->solid[i] && v->enc[l - v->cur_first];
		}
		if (any) {
			if (edt_sq(v->seed, (size_t)c->w, c->w, c->h, v->p.pixel_x_mm, v->p.pixel_y_mm,
				   v->ext_d2, &v->es, e))
				goto fail;
			for (uint32_t k = 0; k < ncomp; k++) {
				v->agg[k] = INFINITY;
				v->cnt[k] = 0;
			}
			for (size_t i = 0; i < n; i++) {
				uint32_t l = c->lab[i];
				if (c->solid[i] || !v->enc[l - v->cur_first])
					continue;
				v->cnt[l - v->cur_first] += 1;
				if (v->ext_d2[i] < v->agg[l - v->cur_first])
					v->agg[l - v->cur_first] = v->ext_d2[i];
			}
			for (uint32_t k = 0; k < ncomp; k++) {
				if (!v->enc[k])
					continue;
				nenc++;
				/* centre-to-centre distance minus the two half pixels */
				if (isfinite(v->agg[k]) &&
				    verify_rec_add(&v->wall, v->cur_first + k, layer,
					    sqrt(v->agg[k]) - fmin(v->p.pixel_x_mm, v->p.pixel_y_mm)))
					goto nomem;
				if (verify_rec_add(&v->vol, v->cur_first + k, layer, v->cnt[k]))
					goto nomem;
			}
			/* fins: solid runs of <= VX_FIN_PX pixels between enclosed
			 * voids (resolved in 3D in verify_finish) */
			if (verify_grow_bytes((void **)&v->fcnt, &v->fcnt_cap, 2 * ncomp * sizeof *v->fcnt))
				goto nomem;
			for (uint32_t k = 0; k < 2 * ncomp; k++)
				v->fcnt[k] = 0;
			if (verify_fins(c->solid, c->lab, c->w, c->h, VX_OUT, v->enc, v->cur_first,
					VX_FIN_PX, v->fcnt, v->fcnt + ncomp, &v->vf, e))
				goto fail;
			for (uint32_t k = 0; k < ncomp; k++)
				if ((v->fcnt[k] > 0 &&
				     verify_rec_add(&v->fin, v->cur_first + k, layer, v->fcnt[k])) ||
				    (v->fcnt[ncomp + k] > 0 &&
				     verify_rec_add(&v->sliver, v->cur_first + k, layer, v->fcnt[ncomp + k])))
					goto nomem;
			if (nenc >= 2 && walls_between(v, layer, e))
				goto fail;
		}
	}
	/* 5c. walls along columns: solid runs with a 2D-enclosed void on at
	 * least one end; whether one end is the outside and the other an
	 * enclosed void is decided in 3D in verify_finish */
	if (v->col_ok && c->w) {
		for (int y = 0; y < c->h; y++)
			for (int x = 0; x < c->w; x++) {
				size_t i = (size_t)y * (size_t)c->w + (size_t)x, pi;
				int gx = x + c->x0, gy = y + c->y0, below_solid;
				size_t gi = (size_t)gy * (size_t)v->w + (size_t)gx;
				int enc_now = !c->solid[i] && v->enc[c->lab[i] - v->cur_first];
				below_solid = layer > 0 && verify_crop_solid(pc, gx, gy, &pi);
				if (c->solid[i]) {
					if (!below_solid) {
						/* a run starts: remember what is under it */
						int enc_below = layer > 0 && pi != SIZE_MAX &&
								verify_prev_enclosed(v, pc->lab[pi]);
						v->col[gi] = (uint16_t)layer;
						v->col_id[gi] = enc_below ? pc->lab[pi] : VX_OUT;
					}
					continue;
				}
				if (!below_solid)
					continue;
				/* a run ended: it separated what was below from this */
				if ((enc_now || v->col_id[gi] != VX_OUT) &&
				    vwall_add(v, enc_now ? c->lab[i] : VX_OUT, v->col_id[gi], layer,
					      (layer - v->col[gi]) * v->p.layer_mm))
					goto nomem;
				if (enc_now && v->col_id[gi] != VX_OUT &&
				    layer - v->col[gi] <= VX_FIN_PX &&
				    shelf_add(v, c->lab[i], v->col_id[gi], layer, layer - v->col[gi]))
					goto nomem;
			}
	}
	v->next++;
	return 0;
nomem:
	ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
fail:
	v->failed = 1;
	return e ? e->code : ERR_NOMEM;
}

static int cmp_rec_layer(const void *a, const void *b)
{
	const struct rec *x = a, *y = b;
	return (x->layer > y->layer) - (x->layer < y->layer);
}

int verify_finish(struct verify *v, struct verify_report *out, struct err *e)
{
	struct crop *c = v->cur;
	double pa = v->p.pixel_x_mm * v->p.pixel_y_mm, *vox;

	if (v->failed)
		return ERR_SET(e, ERR_INTERNAL, "verify: check failed earlier");
	v->finished = 1;
	/* the space above the last layer is open: void components there reach
	 * the outside, and solid runs over enclosed voids end at the outside */
	for (size_t i = 0; c->w && i < (size_t)c->w * (size_t)c->h; i++) {
		if (!c->solid[i]) {
			uf_union(v, c->lab[i], VX_OUT);
		} else if (v->col_ok) {
			size_t gx = i % (size_t)c->w + (size_t)c->x0, gy = i / (size_t)c->w + (size_t)c->y0;
			size_t gi = gy * (size_t)v->w + gx;
			if (v->col_id[gi] != VX_OUT &&
			    vwall_add(v, VX_OUT, v->col_id[gi], v->next,
				      (v->next - v->col[gi]) * v->p.layer_mm))
				return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
		}
	}
	/* the part's own air (label_voids): its overhangs are the part's,
	 * then it is the outside for all that follows */
	if (v->air_n) {
		uint8_t *root_air = mem_calloc(v->nuf, 1);
		if (!root_air)
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
		for (uint32_t k = 2; k < v->air_n; k++)
			if (v->air[k])
				root_air[verify_uf_find(v, k)] = 1;
		for (size_t k = 0; k < v->ov.n; k++) {
			uint32_t root = verify_uf_find(v, v->ov.v[k].id);
			if (root != VX_OUT && root_air[root]) {
				v->r.part_overhang_mm2 += v->ov.v[k].val * pa;
				v->ov.v[k].val = 0; /* nor exterior below */
			}
		}
		for (uint32_t k = 2; k < v->air_n; k++)
			if (v->air[k])
				uf_union(v, k, VX_OUT);
		mem_free(root_air);
	}
	v->r.layers = v->next;
	v->r.tolerance_px = v->p.tolerance_px;
	v->r.width = v->w;
	v->r.height = v->h;
	v->r.overhang_px = mem_calloc((size_t)v->next + 1, sizeof *v->r.overhang_px);
	if (!v->r.overhang_px)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	if (v->ov.n)
		qsort(v->ov.v, v->ov.n, sizeof *v->ov.v, cmp_rec_layer);
	for (size_t k = 0; k < v->ov.n; k++) {
		const struct rec *q = &v->ov.v[k];
		if (verify_uf_find(v, q->id) == VX_OUT) {
			v->r.exterior_overhang_mm2 += q->val * pa;
			continue;
		}
		v->r.overhang_px[q->layer] += (long long)q->val;
		v->r.interior_overhang_px += (long long)q->val;
	}
	for (int l = 0; l < v->next; l++) {
		if (!v->r.overhang_px[l])
			continue;
		v->r.overhang_layers++;
		if (v->r.overhang_px[l] > v->r.worst_layer_px) {
			v->r.worst_layer_px = v->r.overhang_px[l];
			v->r.worst_layer = l;
		}
	}
	v->r.interior_overhang_mm2 = (double)v->r.interior_overhang_px * pa;
	for (size_t k = 0; k < v->ovx.n; k++)
		if (verify_uf_find(v, v->ovx.v[k].id) != VX_OUT &&
		    v->ovx.v[k].val > v->r.slope_excess_mm)
			v->r.slope_excess_mm = v->ovx.v[k].val;
	v->r.slope_excess_px = v->r.slope_excess_mm / fmax(v->p.pixel_x_mm, v->p.pixel_y_mm);
	/* voxels per enclosed 3D component (indexed by root id): every layer
	 * component of an enclosed 3D component is 2D-enclosed, so it has a
	 * vol record */
	vox = mem_calloc(v->nuf, sizeof *vox);
	if (!vox)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	for (size_t k = 0; k < v->vol.n; k++) {
		uint32_t root = verify_uf_find(v, v->vol.v[k].id);
		if (root == VX_OUT)
			continue;
		v->r.enclosed_void_mm3 += v->vol.v[k].val * pa * v->p.layer_mm;
		vox[root] += v->vol.v[k].val;
	}
	for (uint32_t k = 2; k < v->nuf; k++)
		if (verify_uf_find(v, k) == k && vox[k] > 0 && vox[k] <= v->p.speck_voxels)
			v->r.specks++;
	for (size_t k = 0; k < v->fin.n; k++)
		if (verify_uf_find(v, v->fin.v[k].id) != VX_OUT)
			v->r.fin_px += (long long)v->fin.v[k].val;
	v->r.fin_mm3 = (double)v->r.fin_px * pa * v->p.layer_mm;
	for (size_t k = 0; k < v->sliver.n; k++)
		if (verify_uf_find(v, v->sliver.v[k].id) != VX_OUT)
			v->r.sliver_px += (long long)v->sliver.v[k].val;
	v->r.sliver_mm3 = (double)v->r.sliver_px * pa * v->p.layer_mm;
	for (size_t k = 0; k < v->shelf.n; k++)
		if (verify_uf_find(v, v->shelf.v[k].id) != VX_OUT && verify_uf_find(v, v->shelf.v[k].id2) != VX_OUT)
			v->r.shelf_px += (long long)v->shelf.v[k].val;
	v->r.shelf_mm3 = (double)v->r.shelf_px * pa * v->p.layer_mm;
	for (size_t k = 0; k < v->wall.n; k++) {
		const struct rec *q = &v->wall.v[k];
		uint32_t root = verify_uf_find(v, q->id);
		if (root == VX_OUT)
			continue;
		if (vox[root] <= v->p.speck_voxels) {
			v->r.speck_min_wall_mm = fmin(v->r.speck_min_wall_mm, q->val);
			continue;
		}
		if (q->val < v->r.min_wall_mm) {
			v->r.min_wall_mm = q->val;
			v->r.min_wall_layer = q->layer;
		}
	}
	/* walls between two cavities: both ends enclosed, in different 3D
	 * components, neither a speck (a partition inside one cavity is not
	 * counted here; thin ones are fins) */
	for (size_t k = 0; k < v->between.n; k++) {
		const struct rec *q = &v->between.v[k];
		uint32_t ra = verify_uf_find(v, q->id), rb = verify_uf_find(v, q->id2);
		if (ra == VX_OUT || rb == VX_OUT || ra == rb || vox[ra] <= v->p.speck_voxels ||
		    vox[rb] <= v->p.speck_voxels)
			continue;
		if (q->val < v->r.min_wall_between_mm) {
			v->r.min_wall_between_mm = q->val;
			v->r.min_wall_between_layer = q->layer;
		}
	}
	/* a vertical wall separates an enclosed void from the outside: exactly
	 * one end's 3D component is enclosed; two enclosed ends in different
	 * cavities are a wall between them */
	for (size_t k = 0; k < v->vwall.n; k++) {
		const struct rec *q = &v->vwall.v[k];
		uint32_t ra = verify_uf_find(v, q->id), rb = verify_uf_find(v, q->id2), in;
		if (ra != VX_OUT && rb != VX_OUT && ra != rb && vox[ra] > v->p.speck_voxels &&
		    vox[rb] > v->p.speck_voxels)
			v->r.min_wall_between_vertical_mm =
				fmin(v->r.min_wall_between_vertical_mm, q->val);
		if ((ra == VX_OUT) == (rb == VX_OUT))
			continue;
		in = ra == VX_OUT ? rb : ra;
		if (vox[in] <= v->p.speck_voxels)
			v->r.speck_min_wall_mm = fmin(v->r.speck_min_wall_mm, q->val);
		else
			v->r.min_wall_vertical_mm = fmin(v->r.min_wall_vertical_mm, q->val);
	}
	mem_free(vox);
	verify_report_fini(out);
	*out = v->r;
	memset(&v->r, 0, sizeof v->r);
	return 0;
}

int verify_report_metrics(const struct verify_report *r, const char *prefix, struct metrics *m,
			  struct err *e)
{
	char k[128];
	int rc = 0;
#define KEY(s) (snprintf(k, sizeof k, "%s.%s", prefix, s), k)
	rc |= metrics_num(m, KEY("interior_overhang_mm2"), r->interior_overhang_mm2);
	rc |= metrics_int(m, KEY("interior_overhang_px"), r->interior_overhang_px);
	rc |= metrics_int(m, KEY("overhang_layers"), r->overhang_layers);
	rc |= metrics_int(m, KEY("worst_layer"), r->worst_layer);
	rc |= metrics_int(m, KEY("worst_layer_px"), r->worst_layer_px);
	rc |= metrics_num(m, KEY("slope_excess_mm"), r->slope_excess_mm);
	rc |= metrics_num(m, KEY("slope_excess_px"), r->slope_excess_px);
	rc |= metrics_num(m, KEY("tolerance_px"), r->tolerance_px);
	rc |= metrics_num(m, KEY("exterior_overhang_mm2"), r->exterior_overhang_mm2);
	rc |= metrics_int(m, KEY("islands"), r->islands);
	rc |= metrics_num(m, KEY("island_mm2"), r->island_mm2);
	rc |= metrics_int(m, KEY("first_island_layer"), r->first_island_layer);
	rc |= metrics_int(m, KEY("islands_interior"), r->islands_interior);
	rc |= metrics_num(m, KEY("island_interior_mm2"), r->island_interior_mm2);
	rc |= metrics_int(m, KEY("first_interior_island_layer"), r->first_interior_island_layer);
	rc |= metrics_int(m, KEY("islands_part"), r->islands - r->islands_interior);
	if (r->has_reference) {
		rc |= metrics_int(m, KEY("islands_added"), r->islands_added);
		rc |= metrics_num(m, KEY("island_added_mm2"), r->island_added_mm2);
		rc |= metrics_int(m, KEY("first_added_island_layer"), r->first_added_island_layer);
		rc |= metrics_num(m, KEY("part_overhang_mm2"), r->part_overhang_mm2);
	}
	rc |= metrics_int(m, KEY("first_solid_layer"), r->first_solid_layer);
	rc |= metrics_num(m, KEY("min_wall_mm"), r->min_wall_mm);
	rc |= metrics_int(m, KEY("min_wall_layer"), r->min_wall_layer);
	rc |= metrics_num(m, KEY("min_wall_vertical_mm"), r->min_wall_vertical_mm);
	rc |= metrics_num(m, KEY("enclosed_void_mm3"), r->enclosed_void_mm3);
	rc |= metrics_int(m, KEY("specks"), r->specks);
	rc |= metrics_num(m, KEY("speck_min_wall_mm"), r->speck_min_wall_mm);
	rc |= metrics_num(m, KEY("min_wall_between_mm"), r->min_wall_between_mm);
	rc |= metrics_int(m, KEY("min_wall_between_layer"), r->min_wall_between_layer);
	rc |= metrics_num(m, KEY("min_wall_between_vertical_mm"), r->min_wall_between_vertical_mm);
	rc |= metrics_int(m, KEY("fin_px"), r->fin_px);
	rc |= metrics_num(m, KEY("fin_mm3"), r->fin_mm3);
	rc |= metrics_int(m, KEY("sliver_px"), r->sliver_px);
	rc |= metrics_num(m, KEY("sliver_mm3"), r->sliver_mm3);
	rc |= metrics_int(m, KEY("shelf_px"), r->shelf_px);
	rc |= metrics_num(m, KEY("shelf_mm3"), r->shelf_mm3);
	rc |= metrics_int(m, KEY("layers"), r->layers);
#undef KEY
	return rc ? ERR_SET(e, ERR_NOMEM, "verify: out of memory recording metrics") : 0;
}
