/* support.c - what holds each layer up: interior overhangs at sub-pixel
 * accuracy (subpx.h) and floating islands (verify.c's head comment,
 * docs/verify.md). */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify_int.h"

/* Is component id (of the previous layer) 2D-enclosed there? */
int verify_prev_enclosed(const struct verify *v, uint32_t id)
{
	return id >= v->prev_first && id - v->prev_first < v->prev_enc_cap &&
	       v->prev_enc[id - v->prev_first];
}

/* Islands: solid components (8-connected) without solid beneath.  Not
 * the dual of the 8-connected voids on purpose: this asks whether cured
 * resin is attached, and pixels meeting at a corner cure together; with
 * 4-connectivity every stair-step pixel of a rasterised slope with no
 * solid beneath would read as a floating part. */
int verify_islands(struct verify *v, int layer)
{
	struct crop *c = v->cur;
	int w = c->w, h = c->h, tol = (int)ceil(v->p.tolerance_px);
	uint8_t *seen;

	if (layer == 0)
		return 0;
	if (verify_grow_bytes((void **)&v->seed, &v->scratch_cap, (size_t)w * (size_t)h))
		return ERR_NOMEM;
	seen = v->seed;
	memset(seen, 0, (size_t)w * (size_t)h);
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x, sp = 0, area = 0;
			int supported = 0, own = 0; /* own: touches an island of the reference */
			int inner = 0; /* over a void the previous layer encloses */
			if (!c->solid[i] || seen[i])
				continue;
			seen[i] = 1;
			if (verify_push(v, sp++, (int)i))
				return ERR_NOMEM;
			while (sp) {
				int q = v->stack[--sp], qx = q % w, qy = q / w;
				size_t pi;
				area++;
				if (!supported && verify_crop_solid(v->prev, qx + c->x0, qy + c->y0, &pi))
					supported = 1;
				if (!supported && !inner && pi != SIZE_MAX &&
				    verify_prev_enclosed(v, v->prev->lab[pi]))
					inner = 1;
				/* checked only while unsupported: a supported component
				 * (nearly all) stops paying for it at its first such pixel */
				if (!supported && !own && v->r.has_reference &&
				    verify_contact_near(&v->ref, qx + c->x0, qy + c->y0, tol))
					own = 1;
				for (int dy = -1; dy <= 1; dy++)
					for (int dx = -1; dx <= 1; dx++) {
						int nx = qx + dx, ny = qy + dy;
						size_t j;
						if (nx < 0 || ny < 0 || nx >= w || ny >= h)
							continue;
						j = (size_t)ny * (size_t)w + (size_t)nx;
						if (!c->solid[j] || seen[j])
							continue;
						seen[j] = 1;
						if (verify_push(v, sp++, (int)j))
							return ERR_NOMEM;
					}
			}
			if (!supported) {
				v->r.islands++;
				v->r.island_mm2 += (double)area * v->p.pixel_x_mm * v->p.pixel_y_mm;
				if (v->r.first_island_layer < 0)
					v->r.first_island_layer = layer;
				if (inner) {
					v->r.islands_interior++;
					v->r.island_interior_mm2 +=
						(double)area * v->p.pixel_x_mm * v->p.pixel_y_mm;
					if (v->r.first_interior_island_layer < 0)
						v->r.first_interior_island_layer = layer;
				}
				if (v->r.has_reference && !own) {
					v->r.islands_added++;
					v->r.island_added_mm2 +=
						(double)area * v->p.pixel_x_mm * v->p.pixel_y_mm;
					if (v->r.first_added_island_layer < 0)
						v->r.first_added_island_layer = layer;
				}
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
 * recorded per component. */
int verify_overhangs(struct verify *v, int layer, struct err *e)
{
	struct crop *c = v->cur, *pc = v->prev;
	size_t np = pc->w ? (size_t)(v->nuf - v->prev_first) : 0;
	double pa = v->p.pixel_x_mm * v->p.pixel_y_mm;
	double ext2 = v->ext_reach_mm * v->ext_reach_mm;
	struct verify_subpx_img below = {pc->gray, pc->x0, pc->y0, pc->w, pc->h, v->p.pixel_x_mm,
					 v->p.pixel_y_mm, 0, &pc->fits};
	struct verify_subpx_img above = {c->gray, c->x0, c->y0, c->w, c->h, v->p.pixel_x_mm,
					 v->p.pixel_y_mm, 0, &c->fits};
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
			double u, far;
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
			u = INFINITY;
			if (pc->near[pi] >= 0) {
				int32_t n = pc->near[pi];
				u = sqrt(pc->d2[pi]) + verify_subpx_gap_mm(&below, n % pc->w + pc->x0,
									   n / pc->w + pc->y0);
			}
			if (u <= v->slope_mm)
				continue;
			if (!pc->any_ok) {
				size_t n = (size_t)pc->w * (size_t)pc->h;
				if (verify_grow_bytes((void **)&v->seed, &v->scratch_cap, n))
					return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d",
						       layer);
				for (size_t k = 0; k < n; k++)
					v->seed[k] = pc->gray[k] > 0;
				if (edt_sq(v->seed, (size_t)pc->w, pc->w, pc->h, v->p.pixel_x_mm,
					   v->p.pixel_y_mm, pc->any_d2, &v->es, e))
					return e ? e->code : ERR_NOMEM;
				pc->any_ok = 1;
			}
			far = verify_subpx_far_bounded_mm(&below, &above, gx, gy, c->gray[i], u,
							  sqrt(pc->any_d2[pi]), v->reach_mm);
			if (far - v->slope_mm > v->aggx[id - v->prev_first])
				v->aggx[id - v->prev_first] = far - v->slope_mm;
			if (far > v->reach_mm)
				v->agg[id - v->prev_first] += 1;
		}
	v->r.exterior_overhang_mm2 += (double)out_px * pa;
	for (size_t k = 0; k < np; k++) {
		if (v->agg[k] > 0 && verify_rec_add(&v->ov, v->prev_first + (uint32_t)k, layer, v->agg[k]))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
		if (v->aggx[k] > 0 &&
		    verify_rec_add(&v->ovx, v->prev_first + (uint32_t)k, layer, v->aggx[k]))
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory at layer %d", layer);
	}
	return 0;
}

