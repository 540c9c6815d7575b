/* repair.c - the optimised voids' layer images mended to the verifier's
 * sub-pixel reading (repair.h).  Their polygons keep the support rule
 * (slopes.c), but drawn with grey edges a corner or a collapsed ceiling
 * can read a few tenths of a pixel beyond it, and drawn at pixel centres
 * (a mesh output's stepped voids) up to half a pixel (docs/hollow.md
 * "Mended images"); this adds the few grey levels of solid under such
 * pixels, top down, or takes such pixels of solid away, bottom up, so
 * that what is written is what the check passes.
 */
#include "engine/hollow/repair.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/label.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/slice.h"
#include "engine/verify/verify.h"

/* Paint frag's pixels of layer z_mm solid and fill's void into r (pixel
 * (0, 0) is image pixel (x0, y0)); either may be NULL. */
static void paint_fill(const struct hl_fill *fill, const struct hl_fill *frag, double z_mm,
		       int x0, int y0, struct raster *r)
{
	const struct hl_fill_layer *l;

	if (frag && (l = hl_fill_at(frag, z_mm)) != NULL) {
		struct hl_fill f = *frag; /* its pixels, shifted to r's origin */
		f.u0 -= x0;
		f.v0 -= y0;
		hl_fill_paint(&f, l, r, 255);
	}
	if (fill && (l = hl_fill_at(fill, z_mm)) != NULL) {
		struct hl_fill f = *fill;
		f.u0 -= x0;
		f.v0 -= y0;
		hl_fill_paint(&f, l, r, 0);
	}
}

int hl_layer_draw(const struct paths *region, const struct raster_map *map, int antialias,
		  const struct hl_fill *fill, const struct hl_fill *frag, double z_mm, int x0,
		  int y0, struct raster *r, struct err *e)
{
	struct raster_map m = *map;
	int rc;

	m.b[0] -= x0;
	m.b[1] -= y0;
	rc = slice_rasterize(region, &m, antialias, r, e);
	if (!rc)
		paint_fill(fill, frag, z_mm, x0, y0, r);
	return rc;
}

int hl_layer_draw_stepped(const struct paths *region, const struct paths *part,
			  const struct raster_map *map, int antialias, const struct hl_fill *fill,
			  const struct hl_fill *frag, double z_mm, int x0, int y0, struct raster *r,
			  struct raster *part_img, struct err *e)
{
	struct raster_map m = *map;
	int rc;

	if (r->w != part_img->w || r->h != part_img->h)
		return ERR_SET(e, ERR_PARAM, "hollow: a layer and its part drawn at different sizes");
	m.b[0] -= x0;
	m.b[1] -= y0;
	rc = slice_rasterize(part, &m, antialias, part_img, e);
	if (!rc)
		rc = slice_rasterize(region, &m, 0, r, e);
	if (rc)
		return rc;
	/* the outline as the part's own surface slices; inside it the voids'
	 * pixels (which keep wall_mm from it) */
	for (int y = 0; y < r->h; y++) {
		uint8_t *d = r->px + (size_t)y * r->stride;
		const uint8_t *p = part_img->px + (size_t)y * part_img->stride;
		for (int x = 0; x < r->w; x++)
			if (p[x] != 255)
				d[x] = p[x];
	}
	paint_fill(fill, frag, z_mm, x0, y0, r);
	return 0;
}

void hl_repair_fini(struct hl_repair *r)
{
	for (int k = 0; r->layer && k < r->n; k++)
		mem_free(r->layer[k].px);
	mem_free(r->layer);
	memset(r, 0, sizeof *r);
}

void hl_repair_apply(const struct hl_repair *rp, double z_mm, struct raster *r)
{
	int k;

	if (!rp->layer || !(rp->layer_mm > 0))
		return;
	k = (int)floor(z_mm / rp->layer_mm + 1e-9);
	if (k < 0 || k >= rp->n)
		return;
	for (size_t i = 0; i < rp->layer[k].n; i++) {
		const struct hl_mend *q = &rp->layer[k].px[i];
		uint8_t *p;
		if (q->x < 0 || q->y < 0 || q->x >= r->w || q->y >= r->h)
			continue;
		p = r->px + (size_t)q->y * r->stride + (size_t)q->x;
		*p = q->g;
	}
}

/* The pixels read over in one pass: crop pixels (i = y w + x). */
struct over {
	int32_t *at;
	size_t n, cap;
	int w;
};

static int note_over(void *ctx, int x, int y, double far_mm)
{
	struct over *o = ctx;
	void *arr = o->at;

	(void)far_mm;
	if (mem_grow(&arr, &o->cap, o->n + 1, sizeof *o->at))
		return ERR_NOMEM;
	o->at = arr;
	o->at[o->n++] = y * o->w + x;
	return 0;
}

/* The part alone at one layer, drawn when first needed: img's pixels
 * (255 = wholly inside the part) are where solid may be added. */
struct inside {
	struct slicer *part;
	const struct raster_map *map; /* shifted to the crop */
	int antialias, ready;
	double z_mm;
	struct paths *region;         /* scratch */
	struct raster *img;
};

static int inside_draw(struct inside *in, struct err *e)
{
	int rc;

	if (in->ready)
		return 0;
	raster_clear(in->img);
	rc = slice_at(in->part, in->z_mm, in->region, NULL, e);
	if (!rc)
		rc = slice_rasterize(in->region, in->map, in->antialias, in->img, e);
	in->ready = !rc;
	return rc;
}

/* Islands of layer k + 1 (above; above_drawn as drawn before it was
 * mended): a solid component (gray >= VERIFY_THRESHOLD, 8-connected, the
 * verifier's islands) with no solid pixel of layer k (cur) under any of
 * its pixels.  One that holds a mended pixel gets its mended pixels' gray
 * under them (the mending made it).  One drawn so, wholly inside the crop
 * (a speck of a collapsed top's gray, docs/hollow.md 3.8; one the crop's
 * border cuts may stand outside it), gets its own gray under its pixels
 * where the part alone is wholly solid at layer k (in: drawn here when
 * such an island is found): over the void, not over the part's outside,
 * whose own islands need external supports and stay as they are.  lab:
 * w h scratch.  0, ERR_NOMEM or inside_draw's error. */
/* What hold_islands reads of a component's pixels (flags). */
enum {
	HOLD_SEEN = 1,   /* a component */
	HOLD_MENDED = 2, /* holds a mended pixel */
	HOLD_STANDS = 4, /* stands on layer k: not an island */
	HOLD_BORDER = 8, /* touches the crop's border */
};

static int hold_islands(struct raster *cur, const struct raster *above,
			const struct raster *above_drawn, struct inside *in, int32_t *lab,
			struct err *e)
{
	size_t np = (size_t)cur->w * (size_t)cur->h;
	uint8_t *mask = mem_alloc(np), *need = NULL;
	int32_t count = 0;
	int rc, drawn = 0;

	if (!mask)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
	for (size_t i = 0; i < np; i++)
		mask[i] = above->px[i] >= VERIFY_THRESHOLD;
	rc = label_components8(mask, cur->w, cur->h, lab, &count, e);
	if (!rc && !(need = mem_calloc((size_t)count + 1, 1)))
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
	/* need: what each component's pixels show, one pass */
	for (int y = 0; !rc && y < cur->h; y++)
		for (int x = 0; x < cur->w; x++) {
			size_t i = (size_t)y * (size_t)cur->w + (size_t)x;
			uint8_t f = HOLD_SEEN;
			if (!lab[i])
				continue;
			f |= above->px[i] != above_drawn->px[i] ? HOLD_MENDED : 0;
			f |= cur->px[i] >= VERIFY_THRESHOLD ? HOLD_STANDS : 0;
			/* a component the crop's border cuts may stand outside it
			 * (the fill's solid crosses the optimised voids' box) */
			f |= x == 0 || y == 0 || x == cur->w - 1 || y == cur->h - 1 ? HOLD_BORDER : 0;
			need[lab[i]] |= f;
		}
	for (int32_t c = 1; !rc && c <= count && !drawn; c++)
		drawn = need[c] == HOLD_SEEN;
	if (drawn)
		rc = inside_draw(in, e);
	for (size_t i = 0; !rc && i < np; i++) {
		uint8_t c = lab[i] ? need[lab[i]] : 0;
		if (!c || (c & HOLD_STANDS) || above->px[i] <= cur->px[i])
			continue;
		if ((c & HOLD_MENDED) ? above->px[i] != above_drawn->px[i]
				      : !(c & HOLD_BORDER) && in->img->px[i] == 255)
			cur->px[i] = above->px[i];
	}
	mem_free(need);
	mem_free(mask);
	return rc;
}

/* A box of crop pixels, [x0, x1] x [y0, y1]; empty while x1 < x0. */
struct pxbox {
	int x0, y0, x1, y1;
};

static struct pxbox pxbox_empty(void)
{
	return (struct pxbox){INT32_MAX, INT32_MAX, -1, -1};
}

static void pxbox_add(struct pxbox *b, int x, int y)
{
	b->x0 = x < b->x0 ? x : b->x0;
	b->y0 = y < b->y0 ? y : b->y0;
	b->x1 = x > b->x1 ? x : b->x1;
	b->y1 = y > b->y1 ? y : b->y1;
}

static int cmp_i32(const void *a, const void *b)
{
	int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;

	return (x > y) - (x < y);
}

/* The pixels of above that read over cur (o->at: crop indices, row by
 * row, as one read of the whole crop gives them), read as rd says (the
 * job's threads and fit memo).  reread (nonzero after a change): only the
 * box ch of the changed pixels, grown by infl pixels (no reading farther
 * from a change can change), is read again (verify_far_pixels_in: each
 * pixel as the whole crop reads it); prev (nprev) are the last read's
 * pixels, and those outside the box still read over. */
static int read_over(const struct raster *cur, const struct raster *above, int ox, int oy,
		     const struct verify_pair_read *rd, int reread, struct pxbox ch, int infl,
		     const int32_t *prev, size_t nprev, struct over *o, struct err *e)
{
	int w = cur->w, rc, bx0 = ch.x0 - infl, by0 = ch.y0 - infl, bx1 = ch.x1 + infl,
	    by1 = ch.y1 + infl;

	o->n = 0;
	o->w = w;
	if (!reread)
		return verify_far_pixels(cur, above, ox, oy, rd, note_over, o, e);
	rc = verify_far_pixels_in(cur, above, ox, oy, rd, bx0, by0, bx1, by1, note_over, o, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < nprev; i++) {
		int x = prev[i] % w, y = prev[i] / w;
		void *arr = o->at;
		if (x >= bx0 && x <= bx1 && y >= by0 && y <= by1)
			continue;
		if (mem_grow(&arr, &o->cap, o->n + 1, sizeof *o->at))
			return ERR_NOMEM;
		o->at = arr;
		o->at[o->n++] = prev[i];
	}
	qsort(o->at, o->n, sizeof *o->at, cmp_i32);
	return 0;
}

/* Mend layer k (cur, drawn; crop pixel (0, 0) is image pixel (ox, oy))
 * under layer k + 1 (above, final): first the islands of above, those
 * the mending made and those drawn over the void (hold_islands), then
 * passes of verify_far_pixels, raising each pixel read over, or when that
 * was not enough its neighbours, to above's gray where the part is wholly
 * solid.
 * *left: 1 when a pixel still reads over. */
static int mend_layer(struct raster *cur, const struct raster *above,
		      const struct raster *above_drawn, int ox, int oy, struct inside *in,
		      int32_t *lab, const struct verify_pair_read *rd, int *left, struct err *e)
{
	struct over o = {NULL, 0, 0, cur->w};
	const uint8_t *inside;
	int32_t *prev = NULL;
	size_t nprev = 0, prev_cap = 0;
	int infl = verify_far_pad_px(rd->reach_mm, rd->px_mm, rd->py_mm); /* a reading's reach */
	struct pxbox ch = pxbox_empty(); /* the pixels the last pass raised */
	int rc = 0;

	*left = 0;
	rc = hold_islands(cur, above, above_drawn, in, lab, e);
	if (rc)
		return rc;
	/* a check, then a raise, HL_REPAIR_PASSES times; a last check */
	for (int pass = 0; pass <= HL_REPAIR_PASSES; pass++) {
		size_t mine = 0;
		int raised = 0;
		rc = read_over(cur, above, ox, oy, rd, pass > 0, ch, infl, prev, nprev, &o, e);
		if (rc == ERR_NOMEM)
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
		if (!rc && o.n > 0)
			rc = inside_draw(in, e);
		if (rc || o.n == 0)
			break;
		/* a pixel of the part's own outside (an overhang it needs
		 * supports for) is not the voids' to mend */
		inside = in->img->px;
		for (size_t i = 0; i < o.n; i++)
			if (inside[o.at[i]] == 255)
				o.at[mine++] = o.at[i];
		if (mine == 0)
			break;
		if (pass == HL_REPAIR_PASSES) {
			*left = 1;
			break;
		}
		ch = pxbox_empty();
		for (size_t i = 0; i < mine; i++) {
			int x = o.at[i] % cur->w, y = o.at[i] / cur->w;
			size_t c = (size_t)o.at[i];
			/* the pixel itself first: above's gray under it holds it
			 * (the same edge, a layer down); its neighbours only when
			 * it has that already */
			if (above->px[c] > cur->px[c]) {
				cur->px[c] = above->px[c];
				raised = 1;
				pxbox_add(&ch, x, y);
				continue;
			}
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					int u = x + dx, v = y + dy;
					size_t j;
					if (u < 0 || v < 0 || u >= cur->w || v >= cur->h)
						continue;
					j = (size_t)v * (size_t)cur->w + (size_t)u;
					if (inside[j] == 255 && above->px[j] > cur->px[j]) {
						cur->px[j] = above->px[j];
						raised = 1;
						pxbox_add(&ch, u, v);
					}
				}
		}
		if (!raised) {
			*left = 1; /* what reads over has above's gray all round */
			break;
		}
		/* the pixels read over this pass (the outside's dropped: they
		 * are dropped again every pass) */
		{
			void *arr = prev;
			if (mem_grow(&arr, &prev_cap, mine, sizeof *prev)) {
				rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
				break;
			}
			prev = arr;
			memcpy(prev, o.at, mine * sizeof *prev);
			nprev = mine;
		}
	}
	mem_free(o.at);
	mem_free(prev);
	return rc;
}

/* Carve layer k + 1 (cur, drawn; crop pixel (0, 0) is image pixel (ox,
 * oy)) over layer k (below, final; inside, inside_below: the part at
 * layers k + 1 and k): passes of verify_far_pixels clear each pixel of cur
 * read over where the part is wholly solid at both layers (so what it
 * hangs over is the voids', not the outside, and no cut opens the part's
 * surface) and, with guard (may be NULL), inside guard (>= 128: where a
 * cut keeps the wall to the outside), until none reads over or
 * HL_REPAIR_PASSES passes.  A pixel read over lies farther than the reach
 * from below's solid, so over below's void (carved or drawn): the cuts
 * never leave the footprint of the voids under them, and above a void's
 * top each layer's cuts lie a pixel and more inside the last layer's, so
 * a top rises only until it closes.  Solid taken from over a void asks
 * nothing of the layer below; the layer above is read against it in its
 * turn.  *left: 1 when a pixel still reads over. */
static int carve_layer(struct raster *cur, const struct raster *below, int ox, int oy,
		       const struct raster *inside, const struct raster *inside_below,
		       const struct raster *guard, const struct verify_pair_read *rd, int *left,
		       struct err *e)
{
	struct over o = {NULL, 0, 0, cur->w};
	int infl = verify_far_pad_px(rd->reach_mm, rd->px_mm, rd->py_mm);
	struct pxbox ch = pxbox_empty(); /* the pixels the last pass cleared */
	int rc = 0;

	*left = 0;
	for (int pass = 0; pass <= HL_REPAIR_PASSES; pass++) {
		size_t mine = 0;
		/* after a pass, only the box the carving can change (what read
		 * over outside it and was not carved is not the voids') */
		rc = read_over(below, cur, ox, oy, rd, pass > 0, ch, infl, NULL, 0, &o, e);
		if (rc == ERR_NOMEM)
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (carving layers)");
		if (rc || o.n == 0)
			break;
		for (size_t i = 0; i < o.n; i++) {
			size_t c = (size_t)o.at[i];
			if (inside->px[c] != 255 || inside_below->px[c] != 255)
				continue; /* the part's own overhang, not the voids' */
			if (guard && guard->px[c] < 128) {
				*left = 1; /* the voids', but the wall would thin */
				continue;
			}
			o.at[mine++] = o.at[i]; /* solid: verify_far_pixels reads no other */
		}
		if (mine == 0)
			break;
		if (pass == HL_REPAIR_PASSES) {
			*left = 1;
			break;
		}
		ch = pxbox_empty();
		for (size_t i = 0; i < mine; i++) {
			cur->px[o.at[i]] = 0;
			pxbox_add(&ch, o.at[i] % cur->w, o.at[i] / cur->w);
		}
	}
	mem_free(o.at);
	return rc;
}

int hl_repair_build(const struct mesh *res, struct slicer *res_slicer, size_t part_nv,
		    size_t part_nt, const struct raster_map *map, int antialias, const struct hl_fill *fill,
		    const struct hl_fill *frag, double layer_mm, double px_mm, double py_mm,
		    double reach_mm, double wall_mm, int carve, int threads, struct hl_repair *r,
		    struct err *e)
{
	struct mesh part = {res->v, res->tri, part_nv, part_nt};
	struct slicer *sp = NULL;
	struct slice_mid_source gsrc = {NULL, layer_mm}; /* carving: the guard's slices */
	struct slice_eroder *ger = NULL;                /* carving: the part eroded */
	struct raster *guard = NULL;
	struct raster *cur = NULL, *last = NULL, *orig = NULL, *last_orig = NULL, *inside = NULL;
	struct raster *last_part = NULL; /* carving: the part at the layer below */
	struct paths preg;               /* carving: the part's section */
	int32_t *lab = NULL;
	struct paths reg;
	struct box3 bp = box3_empty(), bv = box3_empty(); /* the part's, the voids' */
	struct hl_fill box;
	double gpx, gpy, t0 = progress_now_s();
	int x0, y0, w, h, k0, k1, n, pad, rc = 0, have_last = 0;
	struct verify_pair_read rd = {px_mm, py_mm, reach_mm, threads, NULL};

	hl_repair_fini(r);
	if (res->nv <= part_nv || !(layer_mm > 0))
		return 0;
	for (size_t i = 0; i < res->nv; i++)
		box3_add(i < part_nv ? &bp : &bv, res->v[i]);
	/* the voids' image box (the fill's grid of them), grown by the reach */
	memset(&box, 0, sizeof box);
	rc = hl_fill_grid(res->v + part_nv, res->nv - part_nv, map, &box, &gpx, &gpy, e);
	if (rc)
		return rc;
	pad = (int)ceil(reach_mm / fmin(px_mm, py_mm)) + 1;
	x0 = box.u0 - pad;
	y0 = box.v0 - pad;
	w = box.w + 2 * pad;
	h = box.h + 2 * pad;
	n = (int)ceil(fmax(bp.hi.z, bv.hi.z) / layer_mm - 1e-9);
	k0 = (int)floor(bv.lo.z / layer_mm) - 1;
	k1 = (int)ceil(bv.hi.z / layer_mm) + 1;
	k0 = k0 < 0 ? 0 : k0;
	k1 = k1 >= n ? n - 1 : k1;
	if (n < 1 || k1 < k0)
		return 0;
	if (w > 65535 || h > 65535 || (double)w * h > (double)(1 << 28))
		return ERR_SET(e, ERR_LIMIT, "hollow: the optimised voids span %d x %d pixels, too "
				  "many to mend", w, h);
	paths_init(&reg);
	paths_init(&preg);
	r->layer = mem_calloc((size_t)n, sizeof *r->layer);
	cur = raster_new(w, h);
	last = raster_new(w, h);
	orig = raster_new(w, h);
	last_orig = raster_new(w, h);
	inside = raster_new(w, h);
	last_part = carve ? raster_new(w, h) : NULL;
	lab = mem_alloc((size_t)w * (size_t)h * sizeof *lab);
	rd.memo = verify_fit_memo_new(0);
	if (!r->layer || !cur || !last || !orig || !last_orig || !inside || !lab || !rd.memo ||
	    (carve && !last_part)) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
		goto out;
	}
	r->n = n;
	r->layer_mm = layer_mm;
	rc = slice_new(&part, &sp, e);
	if (!rc && carve && wall_mm - HL_CARVE_SLACK_PX * fmax(px_mm, py_mm) > 0) {
		/* the guard: the part eroded in 3D, read a layer at a time
		 * through the crop's map, over the crop's part of the part only
		 * (a pixel of the crop lies farther than the wall from this
		 * box's edge, so the edge, read as outside, changes no pixel's
		 * answer) */
		double g = wall_mm + (pad + 2) * fmax(px_mm, py_mm);
		struct box3 bg = bp;
		bg.lo.x = fmax(bp.lo.x, bv.lo.x - g);
		bg.lo.y = fmax(bp.lo.y, bv.lo.y - g);
		bg.hi.x = fmin(bp.hi.x, bv.hi.x + g);
		bg.hi.y = fmin(bp.hi.y, bv.hi.y + g);
		rc = slice_erode_mesh_new(&part, wall_mm - HL_CARVE_SLACK_PX * fmax(px_mm, py_mm),
					  fmin(px_mm, py_mm), layer_mm, n, &bg, &gsrc, &ger, e);
		if (!rc && !(guard = raster_new(w, h)))
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (carving layers)");
	}
	/* mending: top down, each layer under its mended one; carving: bottom
	 * up, each layer over its carved one (last: the layer done before,
	 * last_orig its drawing), and on past the voids' layers while a layer
	 * loses solid (a top rising until it closes) */
	for (int step = 0, cut = 0; !rc; step++) {
		int k = carve ? k0 + step : k1 - step;
		double z = (k + 0.5) * layer_mm;
		struct raster_map m = *map;
		int left = 0;
		size_t cnt = 0;
		if (carve ? k >= n || (k > k1 && !cut) : k < k0)
			break;
		raster_clear(cur);
		if ((rc = slice_at(res_slicer, z, &reg, NULL, e)) != 0)
			break;
		if (carve) {
			/* inside: this layer's part, kept as the next one's below */
			raster_clear(inside);
			if ((rc = slice_at(sp, z, &preg, NULL, e)) != 0 ||
			    (rc = hl_layer_draw_stepped(&reg, &preg, map, antialias, fill, frag, z, x0,
							y0, cur, inside, e)) != 0)
				break;
		} else if ((rc = hl_layer_draw(&reg, map, antialias, fill, frag, z, x0, y0, cur,
					       e)) != 0) {
			break;
		}
		memcpy(orig->px, cur->px, (size_t)w * (size_t)h);
		if (have_last && carve) {
			if (guard) {
				struct raster_map gm = *map;
				gm.b[0] -= x0;
				gm.b[1] -= y0;
				raster_clear(guard);
				rc = slice_erode_raster(ger, k, &gm, 0, guard, e);
				if (rc)
					break;
			}
			rc = carve_layer(cur, last, x0, y0, inside, last_part, guard, &rd, &left, e);
			if (rc)
				break;
		} else if (have_last) {
			struct inside in = {sp, &m, antialias, 0, z, &reg, inside};
			m.b[0] -= x0;
			m.b[1] -= y0;
			rc = mend_layer(cur, last, last_orig, x0, y0, &in, lab, &rd, &left, e);
			if (rc)
				break;
		}
		for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
			cnt += cur->px[i] != orig->px[i];
		if (cnt) {
			struct hl_mend *q = mem_alloc(cnt * sizeof *q);
			if (!q) {
				rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (mending layers)");
				break;
			}
			r->layer[k].px = q;
			for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
				if (cur->px[i] != orig->px[i]) {
					r->mm3 += ((double)cur->px[i] - orig->px[i]) / 255.0 * px_mm *
						  py_mm * layer_mm;
					q->x = x0 + (int32_t)(i % (size_t)w);
					q->y = y0 + (int32_t)(i / (size_t)w);
					q->g = cur->px[i];
					q++;
				}
			r->layer[k].n = cnt;
			r->pixels += (long long)cnt;
			r->layers++;
		}
		r->layers_left += left;
		cut = carve && cnt > 0;
		{
			/* cur, mended or carved, is the next layer's last */
			struct raster *t = last;
			if (carve) {
				t = last_part;
				last_part = inside;
				inside = t;
				t = last;
			}
			last = cur;
			cur = t;
			t = last_orig;
			last_orig = orig;
			orig = t;
		}
		have_last = 1;
	}
out:
	r->seconds = progress_now_s() - t0;
	slice_free(sp);
	raster_free(cur);
	raster_free(last);
	raster_free(orig);
	raster_free(last_orig);
	raster_free(inside);
	raster_free(last_part);
	raster_free(guard);
	slice_erode_free(ger);
	slice_free(gsrc.slicer);
	mem_free(lab);
	verify_fit_memo_free(rd.memo);
	paths_fini(&reg);
	paths_fini(&preg);
	if (rc)
		hl_repair_fini(r);
	return rc;
}
