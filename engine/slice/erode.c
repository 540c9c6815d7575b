/* erode.c - exact 3D erosion of a streamed layer stack by a ball (see
 * erode.h; derivation and costs in docs/slicing.md "Erosion").
 *
 * Per layer k: (1) z pass: for each pixel inside layer k, the distance
 * to the nearest outside slab in its own column, from the start of its
 * current inside run and the first outside layer above it (bit planes of
 * the look-ahead window); (2)-(3) Felzenszwalb-Huttenlocher lower
 * envelopes along the inside runs of columns then rows, with the
 * voxel-box metric; (4) marching squares of D - r on the cavity's
 * bounding box.
 */
#include "engine/slice/erode.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/vec.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

int slice_mid_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	const struct slice_mid_source *m = ctx;

	return slice_at(m->slicer, (k + 0.5) * m->layer_mm, region, NULL, e);
}

#define HI_NONE INT32_MAX
#define ERODE_MAX_SIDE 65535
#define ERODE_MAX_PIXELS (1u << 28)

struct ebox {
	int i0, j0, i1, j1; /* half-open pixel box; empty when i0 >= i1 */
};

struct slice_eroder {
	struct slice_erode_params p;
	struct slice_erode_source src;
	int w, h;
	size_t npx;
	struct raster_map map; /* printer mm -> grid pixels */
	double cap_px;         /* distances are exact up to this many pixels */
	float cap2;            /* cap_px^2 */
	float r2;              /* (r / pixel)^2 */
	float lo2;             /* (r / pixel - 2)^2, 0 if negative: below it only
				  the sign of the field is kept */
	int R, P;              /* look-ahead layers; planes in the ring (R + 2) */
	uint64_t *planes;      /* P planes of npx bits, 1 = inside */
	size_t words;          /* 64-bit words per plane */
	int *slot_layer;       /* layer held by each plane, -1 = none */
	struct ebox *slot_box; /* its inside pixels' bounding box */
	int32_t *run;          /* where inside at cur: first layer of the inside run */
	int32_t *hi;           /* where inside at cur: first outside layer above, or HI_NONE */
	float *F, *E, *field, *sub;
	uint64_t *T;           /* layer k's bits, column-major (i * h + j) */
	struct ebox cav_box;   /* pixels with D >= r, grown by one */
	struct raster *scratch;
	struct paths reg;
	int cur, loaded, field_k;
	struct ebox field_box;
	/* 1D envelope workspace, max(w, h) + 2 long */
	int *ev;
	double *ez;
	float *env, *lin, *lout;
	double pixels;
};

static int box_empty(struct ebox b)
{
	return b.i0 >= b.i1 || b.j0 >= b.j1;
}

static int bit_get(const uint64_t *pl, size_t q)
{
	return (int)((pl[q >> 6] >> (q & 63)) & 1u);
}

/* Plane of layer j; NULL for layers outside the part (all outside). */
static const uint64_t *plane(const struct slice_eroder *er, int j)
{
	if (j < 0 || j >= er->p.layer_count)
		return NULL;
	return er->planes + (size_t)(j % er->P) * er->words;
}

static struct ebox layer_box(const struct slice_eroder *er, int j)
{
	struct ebox none = {0, 0, 0, 0};
	if (j < 0 || j >= er->p.layer_count)
		return none;
	return er->slot_box[j % er->P];
}

void slice_erode_free(struct slice_eroder *er)
{
	if (!er)
		return;
	mem_free(er->planes);
	mem_free(er->slot_layer);
	mem_free(er->slot_box);
	mem_free(er->run);
	mem_free(er->hi);
	mem_free(er->F);
	mem_free(er->E);
	mem_free(er->field);
	mem_free(er->sub);
	mem_free(er->T);
	mem_free(er->ev);
	mem_free(er->ez);
	mem_free(er->env);
	mem_free(er->lin);
	mem_free(er->lout);
	raster_free(er->scratch);
	paths_fini(&er->reg);
	mem_free(er);
}

static int check_params(const struct slice_erode_params *p, struct err *e)
{
	if (!(p->r_mm > 0) || !isfinite(p->r_mm))
		return ERR_FIELD(e, "r_mm", "erosion radius must be a positive number (got %g)",
				 p->r_mm);
	if (!(p->pixel_mm > 0) || !isfinite(p->pixel_mm))
		return ERR_FIELD(e, "pixel_mm", "erosion grid pitch must be positive (got %g)",
				 p->pixel_mm);
	if (!(p->layer_mm > 0) || !isfinite(p->layer_mm))
		return ERR_FIELD(e, "layer_mm", "layer height must be positive (got %g)",
				 p->layer_mm);
	if (p->layer_count < 1 || p->layer_count > LAYER_MAX_COUNT)
		return ERR_FIELD(e, "layer_count", "layer count %d is outside 1..%d",
				 p->layer_count, LAYER_MAX_COUNT);
	if (!isfinite(p->x0_mm) || !isfinite(p->y0_mm) || !isfinite(p->x1_mm) ||
	    !isfinite(p->y1_mm) || p->x1_mm < p->x0_mm || p->y1_mm < p->y0_mm)
		return ERR_FIELD(e, "box", "erosion box [%g, %g] x [%g, %g] is invalid", p->x0_mm,
				 p->x1_mm, p->y0_mm, p->y1_mm);
	return 0;
}

int slice_erode_new(const struct slice_erode_params *p, const struct slice_erode_source *src,
		    struct slice_eroder **out, struct err *e)
{
	struct slice_eroder *er;
	double wd, hd, cap_mm;
	size_t side;
	int rc;

	rc = check_params(p, e);
	if (rc)
		return rc;
	if (!src || !src->layer)
		return ERR_SET(e, ERR_INTERNAL, "erosion needs a layer source");
	wd = ceil((p->x1_mm - p->x0_mm) / p->pixel_mm - 1e-9) + 2;
	hd = ceil((p->y1_mm - p->y0_mm) / p->pixel_mm - 1e-9) + 2;
	if (wd > ERODE_MAX_SIDE || hd > ERODE_MAX_SIDE || wd * hd > ERODE_MAX_PIXELS)
		return ERR_SET(e, ERR_LIMIT,
			       "erosion grid of %.0f x %.0f pixels at %g mm is too large; use a "
			       "coarser pixel",
			       wd, hd, p->pixel_mm);
	er = mem_calloc(1, sizeof *er);
	if (!er)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the eroder");
	er->p = *p;
	er->src = *src;
	er->w = (int)wd;
	er->h = (int)hd;
	er->npx = (size_t)er->w * (size_t)er->h;
	/* u = (x - (x0 - pixel)) / pixel: one outside pixel all round */
	er->map.a[0][0] = 1.0 / p->pixel_mm;
	er->map.a[0][1] = 0;
	er->map.a[1][0] = 0;
	er->map.a[1][1] = 1.0 / p->pixel_mm;
	er->map.b[0] = -(p->x0_mm - p->pixel_mm) / p->pixel_mm;
	er->map.b[1] = -(p->y0_mm - p->pixel_mm) / p->pixel_mm;
	/* Exact up to r + 2 pixels: marching squares only interpolates
	 * between neighbours of a pixel with D < r, whose D < r + 1.5 px. */
	cap_mm = p->r_mm + 2 * p->pixel_mm;
	er->cap_px = cap_mm / p->pixel_mm;
	er->cap2 = (float)(er->cap_px * er->cap_px);
	er->r2 = (float)((p->r_mm / p->pixel_mm) * (p->r_mm / p->pixel_mm));
	{
		double lo = p->r_mm / p->pixel_mm - 2;
		er->lo2 = lo > 0 ? (float)(lo * lo) : 0.0f;
	}
	er->R = (int)ceil(cap_mm / p->layer_mm + 0.5);
	if (er->R > p->layer_count)
		er->R = p->layer_count;
	er->P = er->R + 2;
	er->words = (er->npx + 63) / 64;
	er->cur = -1;
	er->loaded = -1;
	er->field_k = -1;
	paths_init(&er->reg);
	side = (size_t)(er->w > er->h ? er->w : er->h) + 2;
	er->planes = mem_alloc((size_t)er->P * er->words * sizeof *er->planes);
	er->slot_layer = mem_alloc((size_t)er->P * sizeof *er->slot_layer);
	er->slot_box = mem_calloc((size_t)er->P, sizeof *er->slot_box);
	er->run = mem_alloc(er->npx * sizeof *er->run);
	er->hi = mem_alloc(er->npx * sizeof *er->hi);
	er->F = mem_alloc(er->npx * sizeof *er->F);
	er->E = mem_alloc(er->npx * sizeof *er->E);
	er->field = mem_alloc(er->npx * sizeof *er->field);
	er->sub = mem_alloc(er->npx * sizeof *er->sub);
	er->T = mem_alloc(er->words * sizeof *er->T);
	er->ev = mem_alloc(side * sizeof *er->ev);
	er->ez = mem_alloc(side * sizeof *er->ez);
	er->env = mem_alloc(side * sizeof *er->env);
	er->lin = mem_alloc(side * sizeof *er->lin);
	er->lout = mem_alloc(side * sizeof *er->lout);
	er->scratch = raster_new(er->w, er->h);
	if (!er->planes || !er->slot_layer || !er->slot_box || !er->run || !er->hi || !er->F ||
	    !er->E || !er->field || !er->sub || !er->T || !er->ev || !er->ez || !er->env || !er->lin ||
	    !er->lout || !er->scratch) {
		slice_erode_free(er);
		return ERR_SET(e, ERR_NOMEM, "out of memory for a %d x %d erosion grid", (int)wd,
			       (int)hd);
	}
	for (int s = 0; s < er->P; s++)
		er->slot_layer[s] = -1;
	for (size_t q = 0; q < er->npx; q++)
		er->field[q] = (float)-p->r_mm;
	*out = er;
	return 0;
}

void slice_erode_info(const struct slice_eroder *er, struct slice_erode_info *info)
{
	info->w = er->w;
	info->h = er->h;
	info->map = er->map;
	info->window_layers = er->R;
	info->bytes = sizeof *er + (size_t)(er->P + 1) * er->words * 8 + er->npx * (4 * 6 + 1) +
		      ((size_t)(er->w > er->h ? er->w : er->h) + 2) * 28;
	info->pixels = er->pixels;
}

/* ---- bit planes ---- */

/* Next run of set bits of pl within [from, end): 1 and [*a, *b), or 0. */
static int bits_run(const uint64_t *pl, size_t from, size_t end, size_t *a, size_t *b)
{
	size_t q = from;

	while (q < end) {
		uint64_t wd = pl[q >> 6] >> (q & 63);
		if (wd) {
			q += (size_t)__builtin_ctzll(wd);
			break;
		}
		q = (q | 63) + 1;
	}
	if (q >= end)
		return 0;
	*a = q;
	while (q < end) {
		uint64_t wd = ~pl[q >> 6] >> (q & 63);
		if (wd) {
			q += (size_t)__builtin_ctzll(wd);
			break;
		}
		q = (q | 63) + 1;
	}
	*b = q < end ? q : end;
	return 1;
}

/* ---- streaming the layers in ---- */

/* Pull layer m from the source into its bit plane (the grid's outer
 * ring stays outside).  Pixels inside at the current layer whose first
 * outside layer above is not known yet learn it here. */
static int load(struct slice_eroder *er, int m, struct err *e)
{
	int slot = m % er->P, rc;
	uint64_t *pl = er->planes + (size_t)slot * er->words;
	const uint64_t *pc = plane(er, er->cur);
	struct ebox lit = {er->w, er->h, 0, 0}, cb;
	struct pt2 lo, hi;

	paths_clear(&er->reg);
	rc = er->src.layer(er->src.ctx, m, &er->reg, e);
	if (rc)
		return rc;
	memset(pl, 0, er->words * sizeof *pl);
	if (paths_bbox(&er->reg, &lo, &hi)) {
		double u0, v0, u1, v1;
		int i0, i1, j0, j1;
		rc = slice_rasterize(&er->reg, &er->map, 0, er->scratch, e);
		if (rc)
			return rc;
		raster_map_apply(&er->map, geom_nm_to_mm(lo.x), geom_nm_to_mm(lo.y), &u0, &v0);
		raster_map_apply(&er->map, geom_nm_to_mm(hi.x), geom_nm_to_mm(hi.y), &u1, &v1);
		i0 = u0 < 0 ? 0 : u0 > er->w ? er->w : (int)floor(u0);
		j0 = v0 < 0 ? 0 : v0 > er->h ? er->h : (int)floor(v0);
		i1 = u1 < 0 ? 0 : u1 >= er->w ? er->w : (int)ceil(u1);
		j1 = v1 < 0 ? 0 : v1 >= er->h ? er->h : (int)ceil(v1);
		for (int j = j0; j < j1; j++) {
			uint8_t *row = er->scratch->px + (size_t)j * er->scratch->stride;
			int ring = j == 0 || j == er->h - 1;
			for (int i = i0; i < i1; i++) {
				size_t q;
				uint64_t eight;
				if (i + 8 <= i1) { /* skip empty stretches 8 pixels at a time */
					memcpy(&eight, row + i, 8);
					if (!eight) {
						i += 7;
						continue;
					}
				}
				if (!row[i])
					continue;
				row[i] = 0;
				if (ring || i == 0 || i == er->w - 1)
					continue;
				q = (size_t)j * (size_t)er->w + (size_t)i;
				pl[q >> 6] |= 1ull << (q & 63);
				lit.i0 = i < lit.i0 ? i : lit.i0;
				lit.i1 = i + 1 > lit.i1 ? i + 1 : lit.i1;
				lit.j0 = j < lit.j0 ? j : lit.j0;
				lit.j1 = j + 1 > lit.j1 ? j + 1 : lit.j1;
			}
		}
	}
	if (box_empty(lit))
		lit.i0 = lit.j0 = lit.i1 = lit.j1 = 0;
	er->slot_layer[slot] = m;
	er->slot_box[slot] = lit;
	er->loaded = m;
	cb = layer_box(er, er->cur);
	if (pc && !box_empty(cb)) {
		size_t w0 = ((size_t)cb.j0 * (size_t)er->w) >> 6;
		size_t w1 = (((size_t)cb.j1 * (size_t)er->w) + 63) >> 6;
		for (size_t wd = w0; wd < w1; wd++) {
			uint64_t c = pc[wd] & ~pl[wd]; /* inside now, outside at m */
			while (c) {
				size_t q = (wd << 6) + (size_t)__builtin_ctzll(c);
				c &= c - 1;
				if (er->hi[q] == HI_NONE)
					er->hi[q] = m;
			}
		}
	}
	return 0;
}

/* Make k (= cur + 1, loaded through min(k + R, last)) the current layer:
 * pixels that start an inside run here record it and look up their
 * first outside layer above in the planes. */
static void advance(struct slice_eroder *er, int k)
{
	struct ebox b = layer_box(er, k);
	const uint64_t *pk = plane(er, k), *pp = plane(er, k - 1);

	if (pk && !box_empty(b)) {
		size_t w0 = ((size_t)b.j0 * (size_t)er->w) >> 6;
		size_t w1 = (((size_t)b.j1 * (size_t)er->w) + 63) >> 6;
		for (size_t wd = w0; wd < w1; wd++) {
			uint64_t c = pk[wd] & ~(pp ? pp[wd] : 0);
			while (c) {
				size_t q = (wd << 6) + (size_t)__builtin_ctzll(c);
				c &= c - 1;
				er->run[q] = k;
				er->hi[q] = HI_NONE;
				for (int m = k + 1; m <= er->loaded; m++) {
					if (!bit_get(plane(er, m), q)) {
						er->hi[q] = m;
						break;
					}
				}
			}
		}
	}
	er->cur = k;
}

/* ---- distance passes ---- */

/* gbox(d) below: the squared distance along one axis from a pixel
 * centre to the pixel box d pixels away, (|d| - 1/2)^2 for d != 0 and 0
 * for d = 0 (the voxel-box metric; docs/slicing.md "Erosion"). */

/* One inside run of n pixels: f[1..n] (> 0, <= cap^2) between the
 * outside pixels f[0] = f[n+1] = 0.  o[y] = min(cap^2, min over x of
 * gbox(|y - x|) + f[x]) (gbox(0) = 0), y in 1..n.  Outside pixels hide
 * everything beyond them, so a run is an independent problem.
 * o[y] = min(f[y], Env(y - 1/2), Env(y + 1/2)) with Env the lower
 * envelope of the parabolas (t - x)^2 + f[x] (Felzenszwalb-Huttenlocher):
 * for x < y, (y - 1/2 - x)^2 is exactly gbox(y - x), symmetrically for
 * x > y, and every other evaluation only overestimates a term.  Samples
 * at the cap cannot bring anything below it and stay out of the
 * envelope.  O(n). */
static void edt_run(struct slice_eroder *er, const float *f, float *o, int n)
{
	int k = 0;
	const float cap2 = er->cap2;

	er->ev[0] = 0;
	er->ez[0] = -HUGE_VAL;
	er->ez[1] = HUGE_VAL;
	for (int q = 1; q <= n + 1; q++) {
		double fq = f[q], sx;
		if (fq >= cap2)
			continue;
		for (;;) {
			int vk = er->ev[k];
			sx = ((fq - f[vk]) + (double)(q - vk) * (double)(q + vk)) / (2.0 * (q - vk));
			if (sx > er->ez[k])
				break;
			k--;
		}
		k++;
		er->ev[k] = q;
		er->ez[k] = sx;
		er->ez[k + 1] = HUGE_VAL;
	}
	k = 0;
	for (int m = 1; m <= n + 1; m++) {
		double y = m - 0.5, d;
		while (er->ez[k + 1] < y)
			k++;
		d = y - er->ev[k];
		er->env[m] = (float)(d * d + f[er->ev[k]]);
	}
	for (int y = 1; y <= n; y++) {
		float d = f[y];
		if (er->env[y] < d)
			d = er->env[y];
		if (er->env[y + 1] < d)
			d = er->env[y + 1];
		o[y] = d < cap2 ? d : cap2;
	}
}

/* Fill field for layer k (cur == k).  Work is proportional to the
 * layer's inside pixels (plus a word scan of its bounding box rows). */
static void compute_field(struct slice_eroder *er, int k)
{
	struct ebox b = layer_box(er, k), cav = {er->w, er->h, 0, 0};
	const uint64_t *pk = plane(er, k);
	const double dz_px = er->p.layer_mm / er->p.pixel_mm;
	const float neg = (float)-er->p.r_mm;
	const size_t w = (size_t)er->w, h = (size_t)er->h;
	int last = er->p.layer_count - 1;
	float maxF = 0;
	size_t a, c;

	for (int j = er->field_box.j0; j < er->field_box.j1; j++)
		for (int i = er->field_box.i0; i < er->field_box.i1; i++)
			er->field[(size_t)j * w + (size_t)i] = neg;
	er->field_box = b;
	er->cav_box.i0 = er->cav_box.j0 = er->cav_box.i1 = er->cav_box.j1 = 0;
	if (box_empty(b) || !pk)
		return;
	/* Early exit: an inside pixel is at most half the box's width or
	 * height (in voxel-box distance) from the outside ring.  Exits leave
	 * -r where every D < r - 2 pixels (only the sign is promised). */
	{
		int bw = b.i1 - b.i0, bh = b.j1 - b.j0, m = bw < bh ? bw : bh;
		float lat = (float)((m + 1) / 2) - 0.5f;
		if (lat * lat < er->lo2)
			return;
	}
	/* (1) z: squared distance (px^2) to the nearest outside slab in the
	 * pixel's own column, (n - 1/2) layers for the n-th layer away;
	 * also the column-major copy of the layer's bits for pass (2). */
	memset(er->T, 0, er->words * sizeof *er->T);
	for (int j = b.j0; j < b.j1; j++) {
		size_t from = (size_t)j * w + (size_t)b.i0, end = (size_t)j * w + (size_t)b.i1;
		while (bits_run(pk, from, end, &a, &c)) {
			for (size_t q = a; q < c; q++) {
				double below = (double)k - er->run[q] + 1, above, n, tz;
				size_t t = (q - (size_t)j * w) * h + (size_t)j;
				float f;
				if (er->hi[q] != HI_NONE)
					above = (double)er->hi[q] - k;
				else
					above = er->loaded == last ? (double)(last + 1 - k) : HUGE_VAL;
				n = below < above ? below : above;
				tz = (n - 0.5) * dz_px;
				f = tz * tz < er->cap2 ? (float)(tz * tz) : er->cap2;
				er->F[q] = f;
				maxF = f > maxF ? f : maxF;
				er->T[t >> 6] |= 1ull << (t & 63);
			}
			from = c;
		}
	}
	if (maxF < er->lo2)
		return; /* within r - 2 pixels of a floor or ceiling everywhere */
	/* (2) columns, over their inside runs */
	for (int i = b.i0; i < b.i1; i++) {
		size_t from = (size_t)i * h + (size_t)b.j0, end = (size_t)i * h + (size_t)b.j1;
		while (bits_run(er->T, from, end, &a, &c)) {
			int n = (int)(c - a);
			size_t j0 = a - (size_t)i * h;
			er->lin[0] = er->lin[n + 1] = 0;
			for (int y = 0; y < n; y++)
				er->lin[y + 1] = er->F[(j0 + (size_t)y) * w + (size_t)i];
			edt_run(er, er->lin, er->lout, n);
			for (int y = 0; y < n; y++)
				er->E[(j0 + (size_t)y) * w + (size_t)i] = er->lout[y + 1];
			from = c;
		}
	}
	/* (3) rows, over their inside runs, written as D - r */
	for (int j = b.j0; j < b.j1; j++) {
		size_t from = (size_t)j * w + (size_t)b.i0, end = (size_t)j * w + (size_t)b.i1;
		while (bits_run(pk, from, end, &a, &c)) {
			int n = (int)(c - a);
			er->lin[0] = er->lin[n + 1] = 0;
			memcpy(er->lin + 1, er->E + a, (size_t)n * sizeof *er->lin);
			edt_run(er, er->lin, er->lout, n);
			for (int y = 0; y < n; y++) {
				float d2 = er->lout[y + 1];
				er->field[a + (size_t)y] =
					(float)(sqrt((double)d2) * er->p.pixel_mm - er->p.r_mm);
				if (d2 >= er->r2) {
					int i = (int)(a - (size_t)j * w) + y;
					cav.i0 = i < cav.i0 ? i : cav.i0;
					cav.i1 = i + 1 > cav.i1 ? i + 1 : cav.i1;
					cav.j0 = j < cav.j0 ? j : cav.j0;
					cav.j1 = j + 1 > cav.j1 ? j + 1 : cav.j1;
				}
			}
			er->pixels += n;
			from = c;
		}
	}
	if (!box_empty(cav)) { /* grown by one so crossings interpolate real samples */
		cav.i0--, cav.j0--, cav.i1++, cav.j1++;
		er->cav_box = cav;
	}
}

static int ensure(struct slice_eroder *er, int k, struct err *e)
{
	int rc, last = er->p.layer_count - 1;

	if (k < 0 || k > last)
		return ERR_SET(e, ERR_PARAM, "erosion asked for layer %d of %d", k,
			       er->p.layer_count);
	if (k == er->field_k)
		return 0;
	if (k <= er->cur)
		return ERR_SET(e, ERR_PARAM,
			       "erosion layers must be asked in increasing order (%d after %d)", k,
			       er->cur);
	while (er->cur < k) {
		int t = er->cur + 1, need = t + er->R < last ? t + er->R : last;
		while (er->loaded < need) {
			rc = load(er, er->loaded + 1, e);
			if (rc)
				return rc;
		}
		advance(er, t);
	}
	compute_field(er, k);
	er->field_k = k;
	return 0;
}

int slice_erode_field(struct slice_eroder *er, int k, const float **field, struct err *e)
{
	int rc = ensure(er, k, e);

	if (rc)
		return rc;
	*field = er->field;
	return 0;
}

int slice_erode_layer(struct slice_eroder *er, int k, struct paths *region, struct err *e)
{
	struct ebox b;
	struct raster_map m;
	int rc = ensure(er, k, e), bw, bh;

	if (rc)
		return rc;
	b = er->cav_box;
	if (box_empty(b)) {
		paths_clear(region);
		return 0;
	}
	/* Contour the cavity's box grown by one pixel only: every sample
	 * outside it is below 0, and the ring keeps crossings interpolated. */
	bw = b.i1 - b.i0;
	bh = b.j1 - b.j0;
	for (int j = 0; j < bh; j++)
		memcpy(er->sub + (size_t)j * (size_t)bw,
		       er->field + (size_t)(b.j0 + j) * (size_t)er->w + (size_t)b.i0,
		       (size_t)bw * sizeof *er->sub);
	m = er->map;
	m.b[0] -= b.i0;
	m.b[1] -= b.j0;
	return slice_field_contours(er->sub, bw, bh, 0.0f, &m, region, e);
}

int slice_erode_raster(struct slice_eroder *er, int k, const struct raster_map *map,
		       int antialias, struct raster *r, struct err *e)
{
	struct paths reg;
	int rc;

	paths_init(&reg);
	rc = slice_erode_layer(er, k, &reg, e);
	if (!rc)
		rc = slice_rasterize(&reg, map, antialias, r, e);
	paths_fini(&reg);
	return rc;
}

int slice_erode_mesh_new(const struct mesh *m, double r_mm, double pixel_mm, double layer_mm,
			 int layer_count, const struct box3 *bb, struct slice_mid_source *src,
			 struct slice_eroder **out, struct err *e)
{
	struct slice_erode_params ep;
	struct slice_erode_source es;
	int rc;

	*out = NULL;
	src->slicer = NULL;
	src->layer_mm = layer_mm;
	rc = slice_new(m, &src->slicer, e);
	if (rc)
		return rc;
	memset(&ep, 0, sizeof ep);
	ep.r_mm = r_mm;
	ep.pixel_mm = pixel_mm;
	ep.layer_mm = layer_mm;
	ep.layer_count = layer_count;
	ep.x0_mm = bb->lo.x;
	ep.y0_mm = bb->lo.y;
	ep.x1_mm = bb->hi.x;
	ep.y1_mm = bb->hi.y;
	es.layer = slice_mid_layer;
	es.ctx = src; /* the caller's, outliving the eroder */
	return slice_erode_new(&ep, &es, out, e);
}
