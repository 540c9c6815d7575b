/* topdown.c - the top-down support-free fill: the void a greedy top-down
 * construction fits inside the offset stack, one print layer at a time, on
 * the very pixel grid the verifier reads (distance transforms, O(pixels)
 * per layer whatever the shape); the hollow engine's fallback where the
 * optimiser (nlp.c) leaves space unhollowed.  Derivation and why it is a
 * deviation from paper 004: docs/hollow.md "Top-down fill".
 */
#include "engine/hollow/fill/fill_int.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/edt.h"
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
			const struct hl_span *q = &f->layer[j].run[i];
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

void hl_fill_paint(const struct hl_fill *f, const struct hl_fill_layer *l, struct raster *r,
		   uint8_t val)
{
	for (size_t i = 0; i < l->n; i++) {
		int v = f->v0 + l->run[i].y;
		int a = f->u0 + l->run[i].x0, b = f->u0 + l->run[i].x1;
		if (v < 0 || v >= r->h)
			continue;
		a = a < 0 ? 0 : a;
		b = b >= r->w ? r->w - 1 : b;
		if (a <= b)
			memset(r->px + (size_t)v * r->stride + a, val, (size_t)(b - a + 1));
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

/* A mesh's eroded print layers: the eroder and the slicer it pulls from
 * (both owned). */
struct eroded {
	struct slice_mid_source sc;
	struct slice_eroder *er;
};

static int eroded_open(struct eroded *x, const struct mesh *m, double r_mm, double pixel_mm,
		       double layer_mm, int layer_count, const struct box3 *bb, struct err *e)
{
	memset(x, 0, sizeof *x);
	return slice_erode_mesh_new(m, r_mm, pixel_mm, layer_mm, layer_count, bb, &x->sc, &x->er,
				    e);
}

static void eroded_close(struct eroded *x)
{
	slice_erode_free(x->er);
	slice_free(x->sc.slicer);
	memset(x, 0, sizeof *x);
}

/* C[k] (pixels of the grid map gm, w x h) for every print layer, as runs,
 * bottom-up (the eroders stream upward): centre-sampled erosions of the
 * part by wall_mm and of solid by wall_next_mm, intersected. */
static int offset_stack(const struct mesh *part, const struct mesh *solid,
			const struct hl_fill_params *c, const struct raster_map *gm, int w, int h, int n,
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
	rc = eroded_open(&ep, part, c->wall_mm, c->pixel_mm, c->layer_mm, n, &bb, e);
	if (!rc && solid)
		rc = eroded_open(&es, solid, c->wall_next_mm, c->pixel_mm, c->layer_mm, n, &bb,
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
				if (!m[x] || !c->keep_set)
					continue;
				map_inverse(gm, x + 0.5, y + 0.5, &px, &py);
				m[x] = c->keep[0] * px + c->keep[1] * py < c->keep[2];
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

static uint32_t run_root(struct hl_span **at, uint32_t i)
{
	/* comp holds the union-find parent as a global run index */
	while (at[i]->comp != i) {
		at[i]->comp = at[at[i]->comp]->comp;
		i = at[i]->comp;
	}
	return i;
}

static void run_union(struct hl_span **at, uint32_t a, uint32_t b)
{
	a = run_root(at, a);
	b = run_root(at, b);
	if (a != b)
		at[a > b ? a : b]->comp = a < b ? a : b;
}

/* Link the runs of row list A (sorted by x) with those of B that overlap
 * in x, or (diag 1) touch at a corner; ia, ib: their global indices.
 * Touching at a corner is overlap of the runs each lengthened by one
 * pixel to the right, so one merge pass serves both. */
static void link_rows(struct hl_span **at, const struct hl_span *A, size_t na, uint32_t ia,
		      const struct hl_span *B, size_t nb, uint32_t ib, int diag)
{
	size_t i = 0, j = 0;

	while (i < na && j < nb) {
		if (A[i].x0 <= B[j].x1 + diag && B[j].x0 <= A[i].x1 + diag)
			run_union(at, ia + (uint32_t)i, ib + (uint32_t)j);
		if (A[i].x1 < B[j].x1)
			i++;
		else
			j++;
	}
}

int hl_fill_label(struct hl_fill *f, int diag, size_t *runs, struct err *e)
{
	size_t total = 0, *rs0 = NULL, *rs1 = NULL;
	struct hl_span **at = NULL;
	uint32_t *off = NULL;
	int rc = 0;

	for (int k = 0; k < f->n; k++)
		total += f->layer[k].n;
	*runs = total;
	if (total >= UINT32_MAX - 1)
		return ERR_SET(e, ERR_LIMIT, "hollow: fill too fragmented (%zu runs)", total);
	at = mem_alloc((total + 1) * sizeof *at);
	off = mem_alloc(((size_t)f->n + 1) * sizeof *off);
	rs0 = mem_alloc(((size_t)f->h + 1) * sizeof *rs0);
	rs1 = mem_alloc(((size_t)f->h + 1) * sizeof *rs1);
	if (!at || !off || !rs0 || !rs1) {
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
		hl_grid_row_starts(L->run, L->n, f->h, rs0);
		if (U)
			hl_grid_row_starts(U->run, U->n, f->h, rs1);
		for (int y = 0; y < f->h; y++) {
			size_t a = rs0[y], na = rs0[y + 1] - a;
			if (!na)
				continue;
			if (y + 1 < f->h)
				link_rows(at, L->run + a, na, off[k] + (uint32_t)a, L->run + rs0[y + 1],
					  rs0[y + 2] - rs0[y + 1], off[k] + (uint32_t)rs0[y + 1], diag);
			if (U)
				link_rows(at, L->run + a, na, off[k] + (uint32_t)a, U->run + rs1[y],
					  rs1[y + 1] - rs1[y], off[k + 1] + (uint32_t)rs1[y], 0);
		}
	}
	for (size_t i = 0; i < total; i++)
		at[i]->comp = run_root(at, (uint32_t)i); /* every comp a root */
out:
	mem_free(at);
	mem_free(off);
	mem_free(rs0);
	mem_free(rs1);
	return rc;
}

int hl_fill_components(struct hl_fill *f, double min_mm3, double px_area_mm2, int keep_small,
		       struct err *e)
{
	size_t total = 0;
	double *vol = NULL;
	int rc = hl_fill_label(f, 0, &total, e);

	if (rc)
		return rc;
	vol = mem_calloc(total + 1, sizeof *vol);
	if (!vol)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory grouping the fill");
	for (int k = 0; k < f->n; k++)
		for (size_t i = 0; i < f->layer[k].n; i++) {
			const struct hl_span *r = &f->layer[k].run[i];
			vol[r->comp] += (r->x1 - r->x0 + 1) * px_area_mm2 * f->layer_mm;
		}
	f->voids = f->voids_small = 0;
	f->volume_mm3 = 0;
	total = 0;
	for (int k = 0; k < f->n; k++)
		for (size_t i = 0; i < f->layer[k].n; i++, total++) {
			if (f->layer[k].run[i].comp != total)
				continue;
			if ((vol[total] < min_mm3) != (keep_small != 0)) {
				f->voids_small++;
			} else {
				f->voids++;
				f->volume_mm3 += vol[total];
			}
		}
	/* drop the other components' runs; every comp is a root's global
	 * index, which compacting leaves as it is */
	for (int k = 0; k < f->n; k++) {
		struct hl_fill_layer *L = &f->layer[k];
		size_t w = 0;
		for (size_t i = 0; i < L->n; i++)
			if ((vol[L->run[i].comp] < min_mm3) == (keep_small != 0))
				L->run[w++] = L->run[i];
		L->n = w;
	}
	mem_free(vol);
	return 0;
}

int hl_fill_grid(const struct vec3 *pts, size_t nv, const struct raster_map *m, struct hl_fill *f,
		 double *px, double *py, struct err *e)
{
	struct box3 bb = box3_empty();
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;

	for (size_t i = 0; i < nv; i++)
		box3_add(&bb, pts[i]);
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

int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_fill_params *c,
		  struct progress *prog, double f0, double f1, struct hl_fill *f, struct err *e)
{
	const struct raster_map *m = &c->map;
	struct hl_fill r;
	struct hl_fill_layer *C = NULL;
	struct raster_map gm;
	struct hl_win s;
	struct hl_geo g;
	struct box3 bb = box3_empty();
	uint8_t *vup = NULL;
	float *sig = NULL;
	int32_t *lastv = NULL; /* per grid pixel: the lowest layer so far where it is void */
	int px0 = 0, py0 = 0, px1 = 0, py1 = 0, pad, rc = 0, n;
	double L = c->layer_mm;

	memset(&r, 0, sizeof r);
	memset(&s, 0, sizeof s);
	edt_scratch_init(&s.edt);
	/* only an axis-aligned grid (rotations by quarter turns, mirrors) has
	 * rows and columns that are lines of the printer frame */
	if (!(L > 0) ||
	    !((m->a[0][1] == 0 && m->a[1][0] == 0) || (m->a[0][0] == 0 && m->a[1][1] == 0)))
		return 0;
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	n = (int)ceil(bb.hi.z / L - 1e-9);
	if (n < 1)
		return 0;
	rc = hl_fill_grid(part->v, part->nv, m, &r, &g.px, &g.py, e);
	if (rc)
		return rc;
	r.n = n;
	r.layer_mm = L;
	r.map = *m;
	g.pmax = fmax(g.px, g.py);
	g.dd = L * tan(c->alpha_rad - c->margin_rad);
	/* the exact rule on the pixels: centre to centre within L tan(alpha),
	 * which bounds every point of a solid pixel square by the same distance
	 * from the square below (docs/verify.md "Sub-pixel overhangs") */
	g.dg = L * tan(c->alpha_rad) + 1e-9;
	g.wall = c->wall_next_mm;
	g.mv = (int)ceil(g.wall / L - 1e-9);
	g.birth = 0.5 * g.wall;
	g.lone = HL_FILL_LONE_MM;
	g.lean = c->lean;
	g.corners = c->corners;
	g.half = 0.5 * g.wall / cos(c->alpha_rad - c->margin_rad);
	pad = (int)ceil((g.wall + 2 * g.dg + 2 * g.pmax) / fmin(g.px, g.py)) + 2;
	gm = *m;
	gm.b[0] -= r.u0;
	gm.b[1] -= r.v0;
	r.layer = mem_calloc((size_t)n, sizeof *r.layer);
	C = mem_calloc((size_t)n, sizeof *C);
	vup = mem_calloc((size_t)r.w * (size_t)r.h, 1);
	sig = mem_alloc((size_t)r.w * (size_t)r.h * sizeof *sig);
	lastv = mem_alloc((size_t)r.w * (size_t)r.h * sizeof *lastv);
	if (!r.layer || !C || !vup || !sig || !lastv || !hl_win_init(&s, (size_t)r.w * (size_t)r.h)) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill)");
		goto out;
	}
	s.edt.threads = c->threads; /* after hl_win_init, which resets the scratch */
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
			/* the window's inputs (struct hl_win): C(k), V(k + 1), sig,
			 * the lowest void layer */
			memset(s.region, 0, (size_t)ww * (size_t)wh);
			for (size_t i = 0; i < C[k].n; i++)
				memset(s.region + (size_t)(C[k].run[i].y - y0) * (size_t)ww +
					       (C[k].run[i].x0 - x0),
				       1, (size_t)(C[k].run[i].x1 - C[k].run[i].x0 + 1));
			for (int y = 0; y < wh; y++) {
				memcpy(s.void_above + (size_t)y * (size_t)ww,
				       vup + (size_t)(y + y0) * (size_t)r.w + x0, (size_t)ww);
				memcpy(s.sig_above_mm + (size_t)y * (size_t)ww,
				       sig + (size_t)(y + y0) * (size_t)r.w + x0,
				       (size_t)ww * sizeof *sig);
				memcpy(s.last_void + (size_t)y * (size_t)ww,
				       lastv + (size_t)(y + y0) * (size_t)r.w + x0,
				       (size_t)ww * sizeof *lastv);
			}
			rc = hl_step_grow(&s, ww, wh, &g, e);
			if (!rc)
				rc = hl_step_keep_apart(&s, ww, wh, &g, e);
			if (!rc) {
				rc = hl_step_vertical_walls(&s, ww, wh, &g, k, e);
			}
			if (!rc && g.lean)
				rc = hl_step_prune(&s, ww, wh, &g, k);
			if (!rc) {
				rc = hl_step_born(&s, ww, wh, &g, k, e);
			}
			if (!rc)
				rc = hl_step_islands(&s, ww, wh, e);
			if (!rc)
				rc = hl_grid_runs(s.void_out, ww, 0, 0, ww, wh, &r.layer[k].run,
						  &r.layer[k].n, &cap, e);
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
			memcpy(vup + (size_t)y * (size_t)r.w + x0,
			       s.void_out + (size_t)(y - y0) * (size_t)ww, (size_t)ww);
			memcpy(sig + (size_t)y * (size_t)r.w + x0,
			       s.sig_out_mm + (size_t)(y - y0) * (size_t)ww,
			       (size_t)ww * sizeof *sig);
			for (int x = x0; x < x1; x++)
				if (s.void_out[(size_t)(y - y0) * (size_t)ww + (size_t)(x - x0)])
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
	/* small voids dropped first (no wall is cut for them), then the
	 * walls between the rest, then what the cuts left too small */
	if (!rc)
		rc = hl_fill_components(&r, c->min_void_mm3, g.px * g.py, 0, e);
	if (!rc)
		rc = hl_fill_apart(&r, g.wall, g.px, g.py, c->threads, &r.apart_cut_px,
				   &r.apart_left_layers, e);
	if (!rc && r.apart_cut_px) {
		size_t dropped = r.voids_small;
		rc = hl_fill_components(&r, c->min_void_mm3, g.px * g.py, 0, e);
		r.voids_small += dropped;
	}
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
	hl_win_fini(&s);
	hl_fill_fini(&r);
	return rc;
}
