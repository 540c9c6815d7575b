/* support.c - what holds each layer up: interior overhangs at sub-pixel
 * accuracy (subpx.h) and floating islands (verify.c's head comment,
 * docs/verify.md). */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/geom/edt.h"
#include "engine/geom/label.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify_int.h"

/* Is component id (of the previous layer) 2D-enclosed there? */
int verify_prev_enclosed(const struct verify *v, uint32_t id)
{
	return id >= v->prev_first && id - v->prev_first < v->prev_enc_cap &&
	       v->prev_enc[id - v->prev_first];
}

/* verify_islands' flags per solid component */
#define ISL_SUPPORTED 1u /* a pixel over the previous layer's solid */
#define ISL_INNER 2u     /* a pixel over a void the previous layer encloses */
#define ISL_OWN 4u       /* a pixel near an island of the reference stack */

/* Islands: solid components (8-connected) without solid beneath.  Not
 * the dual of the 8-connected voids on purpose: this asks whether cured
 * resin is attached, and pixels meeting at a corner cure together; with
 * 4-connectivity every stair-step pixel of a rasterised slope with no
 * solid beneath would read as a floating part. */
int verify_islands(struct verify *v, int layer)
{
	struct crop *c = v->cur;
	int w = c->w, h = c->h, tol = (int)ceil(v->p.tolerance_px);
	size_t np = (size_t)w * (size_t)h;
	int32_t n = 0;
	double pa = v->p.pixel_x_mm * v->p.pixel_y_mm;
	struct err e;

	if (layer == 0)
		return 0;
	if (verify_grow_bytes((void **)&v->isl_lab, &v->isl_lab_cap, np * sizeof *v->isl_lab))
		return ERR_NOMEM;
	err_clear(&e);
	if (label_components8(c->solid, w, h, v->isl_lab, &n, &e))
		return ERR_NOMEM;
	if (n == 0)
		return 0;
	if (verify_grow_bytes((void **)&v->isl_area, &v->isl_area_cap,
			      (size_t)(n + 1) * sizeof *v->isl_area) ||
	    verify_grow_bytes((void **)&v->isl_flag, &v->isl_flag_cap, (size_t)(n + 1)))
		return ERR_NOMEM;
	memset(v->isl_area, 0, (size_t)(n + 1) * sizeof *v->isl_area);
	memset(v->isl_flag, 0, (size_t)(n + 1));
	/* the flags other than ISL_SUPPORTED only count on components that
	 * end unsupported, whose pixels are all read: a supported component
	 * stops paying for them at its first supported pixel */
	for (int y = 0; y < h; y++) {
		int gy = y + c->y0;
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x, pi;
			int32_t l = v->isl_lab[i];
			uint8_t *f = &v->isl_flag[l];
			if (l == 0)
				continue;
			v->isl_area[l]++;
			if (*f & ISL_SUPPORTED)
				continue;
			if (verify_crop_solid(v->prev, x + c->x0, gy, &pi)) {
				*f |= ISL_SUPPORTED;
				continue;
			}
			if (!(*f & ISL_INNER) && pi != SIZE_MAX &&
			    verify_prev_enclosed(v, v->prev->lab[pi]))
				*f |= ISL_INNER;
			if (!(*f & ISL_OWN) && v->r.has_reference &&
			    verify_contact_near(&v->ref, x + c->x0, gy, tol))
				*f |= ISL_OWN;
		}
	}
	for (int32_t l = 1; l <= n; l++) {
		double a_mm2 = (double)v->isl_area[l] * pa;
		if (v->isl_flag[l] & ISL_SUPPORTED)
			continue;
		v->r.islands++;
		v->r.island_mm2 += a_mm2;
		if (v->r.first_island_layer < 0)
			v->r.first_island_layer = layer;
		if (v->isl_flag[l] & ISL_INNER) {
			v->r.islands_interior++;
			v->r.island_interior_mm2 += a_mm2;
			if (v->r.first_interior_island_layer < 0)
				v->r.first_interior_island_layer = layer;
		}
		if (v->r.has_reference && !(v->isl_flag[l] & ISL_OWN)) {
			v->r.islands_added++;
			v->r.island_added_mm2 += a_mm2;
			if (v->r.first_added_island_layer < 0)
				v->r.first_added_island_layer = layer;
		}
	}
	return 0;
}


/* The void component of the previous layer that a pixel of this layer
 * overhangs: the one under it, else (its pixel below is solid at the
 * threshold, but its region may still reach past the slope) the first
 * void 8-neighbour of that pixel; 0 when there is none. */
static uint32_t void_under(const struct crop *pc, int gx, int gy)
{
	size_t pi;

	if (!verify_crop_solid(pc, gx, gy, &pi))
		return pi == SIZE_MAX ? VX_OUT : pc->lab[pi];
	for (int dy = -1; dy <= 1; dy++)
		for (int dx = -1; dx <= 1; dx++) {
			size_t j;
			if (!verify_crop_solid(pc, gx + dx, gy + dy, &j))
				return j == SIZE_MAX ? VX_OUT : pc->lab[j];
		}
	return 0;
}

/* The readings of verify_overhangs, on any thread (parfor.h): stage 0
 * the upper bounds, stage 1 the sub-pixel readings of the pixels the
 * bound leaves open (the layers' corner fits are shared, subpx.h). */
struct ovh_read {
	struct verify *v;
	const struct verify_subpx_img *below, *above;
	int stage;
};

static void ovh_read(void *ctx, size_t k, int tid)
{
	const struct ovh_read *r = ctx;
	const struct crop *c = r->v->cur, *pc = r->v->prev;
	struct verify_ovh *o = &r->v->ovh[k];

	(void)tid;
	if (r->stage == 0) {
		o->u_mm = INFINITY;
		if (pc->near[o->pi] >= 0) {
			int32_t n = pc->near[o->pi];
			o->u_mm = sqrt(pc->d2[o->pi]) +
				  verify_subpx_gap_mm(r->below, n % pc->w + pc->x0,
						      n / pc->w + pc->y0);
		}
	} else if (o->u_mm > r->v->slope_mm) {
		o->far_mm = verify_subpx_far_bounded_mm(
			r->below, r->above, (int)(o->i % (size_t)c->w) + c->x0,
			(int)(o->i / (size_t)c->w) + c->y0, c->gray[o->i], o->u_mm,
			sqrt(pc->any_d2[o->pi]), r->v->reach_mm);
	}
}

/* 3. Overhangs of the current layer over the previous one (head comment,
 * docs/verify.md "Sub-pixel overhangs").  Over voids already known to be
 * the outside: the pixel-centre test with one pixel of slack, an
 * estimate of the support area.  Elsewhere, every pixel with some solid
 * (gray > 0) over a pixel that is not fully solid: an upper bound U on
 * the farthest point of its region from the previous layer's solid (the
 * centre distance to the nearest solid pixel plus that pixel's gap from
 * square to region) settles most pixels (U <= slope); a lower bound from
 * the distance to any grey pixel settles gross overhangs; the rest are
 * measured (subpx.h).  A pixel overhangs when its farthest point lies
 * beyond slope + tolerance; the largest excess over the slope is
 * recorded per component.  The pixels are found in one pass, read on
 * v->p.threads threads, then summed in one pass (the same report on any
 * number of threads). */
int verify_overhangs(struct verify *v, int layer, struct err *e)
{
	struct crop *c = v->cur, *pc = v->prev;
	size_t np = pc->w ? (size_t)(v->nuf - v->prev_first) : 0, no = 0, open = 0;
	double pa = v->p.pixel_x_mm * v->p.pixel_y_mm;
	double ext2 = v->ext_reach_mm * v->ext_reach_mm;
	struct verify_subpx_img below = {pc->gray, pc->x0, pc->y0, pc->w, pc->h, v->p.pixel_x_mm,
					 v->p.pixel_y_mm, 0, &pc->fits, v->memo};
	struct verify_subpx_img above = {c->gray, c->x0, c->y0, c->w, c->h, v->p.pixel_x_mm,
					 v->p.pixel_y_mm, 0, &c->fits, v->memo};
	struct ovh_read job = {v, &below, &above, 0};
	long long out_px = 0;

	if (np && (verify_grow_bytes((void **)&v->agg, &v->agg_cap, np * sizeof *v->agg) ||
		   verify_grow_bytes((void **)&v->aggx, &v->aggx_cap, np * sizeof *v->aggx)))
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
	for (size_t k = 0; k < np; k++) {
		v->agg[k] = 0;
		v->aggx[k] = -INFINITY;
	}
	for (int y = 0; y < c->h; y++)
		for (int x = 0; x < c->w; x++) {
			size_t i = (size_t)y * (size_t)c->w + (size_t)x, pi;
			int gx = x + c->x0, gy = y + c->y0, gb;
			uint32_t id;
			if (c->gray[i] == 0)
				continue;
			verify_crop_solid(pc, gx, gy, &pi);
			if (pi == SIZE_MAX) {
				if (c->solid[i])
					out_px++; /* over the outside, beyond the reach by the margin */
				continue;
			}
			gb = pc->gray[pi];
			if (gb == 255 || !(id = void_under(pc, gx, gy)))
				continue;
			if (id == VX_OUT || verify_uf_find(v, id) == VX_OUT) {
				if (c->solid[i] && !pc->solid[pi] && pc->d2[pi] > ext2)
					out_px++;
				continue;
			}
			if (id < v->prev_first)
				continue; /* cannot happen: labels of the previous layer */
			if (mem_grow((void **)&v->ovh, &v->ovh_cap, no + 1, sizeof *v->ovh))
				return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d",
					       layer);
			v->ovh[no].i = i;
			v->ovh[no].pi = pi;
			v->ovh[no++].id = id;
		}
	v->r.exterior_overhang_mm2 += (double)out_px * pa;
	parfor_run(no, v->p.threads, 64, ovh_read, &job);
	for (size_t k = 0; k < no; k++)
		open += v->ovh[k].u_mm > v->slope_mm;
	if (open && !pc->any_ok) {
		size_t n = (size_t)pc->w * (size_t)pc->h;
		if (verify_grow_bytes((void **)&v->seed, &v->scratch_cap, n))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
		for (size_t k = 0; k < n; k++)
			v->seed[k] = pc->gray[k] > 0;
		if (edt_sq(v->seed, (size_t)pc->w, pc->w, pc->h, v->p.pixel_x_mm, v->p.pixel_y_mm,
			   pc->any_d2, &v->es, e))
			return e ? e->code : ERR_NOMEM;
		pc->any_ok = 1;
	}
	job.stage = 1;
	if (open)
		parfor_run(no, v->p.threads, 16, ovh_read, &job);
	for (size_t k = 0; k < no; k++) {
		const struct verify_ovh *o = &v->ovh[k];
		size_t at = o->id - v->prev_first;
		if (!(o->u_mm > v->slope_mm))
			continue;
		if (o->far_mm - v->slope_mm > v->aggx[at])
			v->aggx[at] = o->far_mm - v->slope_mm;
		if (o->far_mm > v->reach_mm)
			v->agg[at] += 1;
	}
	for (size_t k = 0; k < np; k++) {
		if (v->agg[k] > 0 && verify_rec_add(&v->ov, v->prev_first + (uint32_t)k, layer, v->agg[k]))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
		if (v->aggx[k] > 0 &&
		    verify_rec_add(&v->ovx, v->prev_first + (uint32_t)k, layer, v->aggx[k]))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
	}
	return 0;
}
