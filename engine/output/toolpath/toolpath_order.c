/* toolpath_order.c - print order of a layer's toolpaths (tp_order() in
 * toolpath_int.h; docs/gcode.md, "ordering").
 *
 * Skirt first, then island by island, always moving to the nearest
 * unprinted island.  Inside an island: perimeter loops by depth (inner
 * loops first, so the external loop is laid against them; or outermost
 * first on request), each depth chained nearest-neighbour with the seam
 * at the nearest vertex (or the rear-most one); then thin walls and gap
 * fill, then sparse, bridge, solid and top infill, each chained
 * nearest-neighbour with lines reversed when their far end is nearer.
 * Consecutive infill lines whose joining segment lies inside their fill
 * area are joined into one zigzag path (no travel).  A travel retracts
 * when it is longer than min_travel_retract or crosses the layer's
 * outline.  Nearest-neighbour queries use a uniform grid over candidate
 * points with lazy removal: about O(n) for evenly spread points.
 */
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

/* ---- nearest-neighbour grid over candidate points -------------------- */

struct cand {
	struct pt2 p;
	uint32_t item; /* what choosing this point selects */
	uint32_t tag;  /* which point of it (vertex index, or 0/1 line end) */
};

struct nn {
	struct cand *c;
	size_t nc, cap_c;
	uint32_t *cell_start, *cell_n, *slot;
	size_t cap_cells, cap_cell_n, cap_slot;
	unsigned char *used;
	size_t cap_used, nitems, alive;
	struct pt2 lo;
	int64_t cell;
	int nx, ny;
};

static void nn_fini(struct nn *g)
{
	mem_free(g->c);
	mem_free(g->cell_start);
	mem_free(g->cell_n);
	mem_free(g->slot);
	mem_free(g->used);
	memset(g, 0, sizeof *g);
}

static int nn_reset(struct nn *g, size_t nitems)
{
	void *a = g->used;

	g->nc = 0;
	if (mem_grow(&a, &g->cap_used, nitems ? nitems : 1, 1))
		return ERR_NOMEM;
	g->used = a;
	memset(g->used, 0, nitems);
	g->nitems = g->alive = nitems;
	return 0;
}

static int nn_add(struct nn *g, struct pt2 p, uint32_t item, uint32_t tag)
{
	void *a = g->c;

	if (mem_grow(&a, &g->cap_c, g->nc + 1, sizeof *g->c))
		return ERR_NOMEM;
	g->c = a;
	g->c[g->nc++] = (struct cand){p, item, tag};
	return 0;
}


/* Bucket the candidates: about two per cell. */
static int nn_build(struct nn *g)
{
	struct pt2 lo, hi;
	size_t ncell;
	void *a;

	if (g->nc == 0)
		return 0;
	lo = hi = g->c[0].p;
	for (size_t i = 1; i < g->nc; i++) {
		struct pt2 p = g->c[i].p;
		if (p.x < lo.x) lo.x = p.x;
		if (p.y < lo.y) lo.y = p.y;
		if (p.x > hi.x) hi.x = p.x;
		if (p.y > hi.y) hi.y = p.y;
	}
	tp_grid_size(lo, hi, g->nc, 2.0, 50000, &g->cell, &g->nx, &g->ny);
	g->lo = lo;
	ncell = (size_t)g->nx * (size_t)g->ny;
	a = g->cell_start;
	if (mem_grow(&a, &g->cap_cells, ncell + 1, sizeof *g->cell_start))
		return ERR_NOMEM;
	g->cell_start = a;
	a = g->cell_n;
	if (mem_grow(&a, &g->cap_cell_n, ncell, sizeof *g->cell_n))
		return ERR_NOMEM;
	g->cell_n = a;
	a = g->slot;
	if (mem_grow(&a, &g->cap_slot, g->nc, sizeof *g->slot))
		return ERR_NOMEM;
	g->slot = a;
	memset(g->cell_n, 0, ncell * sizeof *g->cell_n);
	for (size_t i = 0; i < g->nc; i++) {
		struct pt2 p = g->c[i].p;
		size_t k = (size_t)tp_cell_of(p.y, lo.y, g->cell, g->ny) * (size_t)g->nx +
			   (size_t)tp_cell_of(p.x, lo.x, g->cell, g->nx);
		g->cell_n[k]++;
	}
	g->cell_start[0] = 0;
	for (size_t k = 0; k < ncell; k++) {
		g->cell_start[k + 1] = g->cell_start[k] + g->cell_n[k];
		g->cell_n[k] = 0;
	}
	for (size_t i = 0; i < g->nc; i++) {
		struct pt2 p = g->c[i].p;
		size_t k = (size_t)tp_cell_of(p.y, lo.y, g->cell, g->ny) * (size_t)g->nx +
			   (size_t)tp_cell_of(p.x, lo.x, g->cell, g->nx);
		g->slot[g->cell_start[k] + g->cell_n[k]++] = (uint32_t)i;
	}
	return 0;
}

/* Nearest candidate of an unused item: its index, or -1 when none. */
static long nn_nearest(struct nn *g, struct pt2 p)
{
	double best = INFINITY;
	long bi = -1;
	int cx, cy;

	if (g->alive == 0 || g->nc == 0)
		return -1;
	cx = tp_cell_of(p.x, g->lo.x, g->cell, g->nx);
	cy = tp_cell_of(p.y, g->lo.y, g->cell, g->ny);
	for (int r = 0;; r++) {
		int x0 = cx - r, x1 = cx + r, y0 = cy - r, y1 = cy + r;
		double bound;
		for (int y = y0; y <= y1; y++) {
			if (y < 0 || y >= g->ny)
				continue;
			for (int x = x0; x <= x1; x++) {
				size_t k;
				if (y != y0 && y != y1 && x != x0 && x != x1)
					x = x1; /* interior cells were seen at smaller r */
				if (x < 0 || x >= g->nx)
					continue;
				k = (size_t)y * (size_t)g->nx + (size_t)x;
				for (uint32_t t = 0; t < g->cell_n[k];) {
					uint32_t ci = g->slot[g->cell_start[k] + t];
					const struct cand *cd = &g->c[ci];
					double d;
					if (g->used[cd->item]) {
						/* lazy removal: swap out of the cell */
						g->slot[g->cell_start[k] + t] =
							g->slot[g->cell_start[k] + --g->cell_n[k]];
						continue;
					}
					d = tp_dist_nm(cd->p, p);
					if (d < best) {
						best = d;
						bi = (long)ci;
					}
					t++;
				}
			}
		}
		if (x0 <= 0 && y0 <= 0 && x1 >= g->nx - 1 && y1 >= g->ny - 1)
			break;
		/* Unseen cells lie outside the square of rings 0..r. */
		bound = (double)(p.x - (g->lo.x + (int64_t)x0 * g->cell));
		if ((double)(g->lo.x + (int64_t)(x1 + 1) * g->cell - p.x) < bound)
			bound = (double)(g->lo.x + (int64_t)(x1 + 1) * g->cell - p.x);
		if ((double)(p.y - (g->lo.y + (int64_t)y0 * g->cell)) < bound)
			bound = (double)(p.y - (g->lo.y + (int64_t)y0 * g->cell));
		if ((double)(g->lo.y + (int64_t)(y1 + 1) * g->cell - p.y) < bound)
			bound = (double)(g->lo.y + (int64_t)(y1 + 1) * g->cell - p.y);
		if (bi >= 0 && best <= bound)
			break;
	}
	return bi;
}

static void nn_take(struct nn *g, uint32_t item)
{
	if (!g->used[item]) {
		g->used[item] = 1;
		g->alive--;
	}
}

/* ---- ordering ---------------------------------------------------------- */

struct order {
	const struct tp_config *c;
	const struct tp_layer_in *in;
	const struct tp_plan *items;
	struct tp_plan *out;
	struct tp_index region_ix;
	struct tp_index area_ix[TP_ROLE_COUNT];
	unsigned char area_built[TP_ROLE_COUNT];
	const struct tp_areas *areas;
	struct pt2 pos; /* nozzle */
	int have_pos;
	struct nn nn;
	struct pt2 *tmp;
	size_t cap_tmp;
	int64_t *tmp_w;
	size_t cap_tmp_w;
	struct err *e;
};

static double role_speed(const struct order *o, enum tp_role r)
{
	return o->in->index == 0 ? o->c->first_layer_speed_mm_s : o->c->speed_mm_s[r];
}

/* Decide the travel to `to` and remember where the nozzle ends. */
static int travel_retracts(struct order *o, struct pt2 to)
{
	if (!o->have_pos)
		return 0;
	if (o->pos.x == to.x && o->pos.y == to.y)
		return 0;
	if (tp_dist_nm(o->pos, to) > (double)o->c->min_travel_retract_nm)
		return 1;
	return tp_index_crosses(&o->region_ix, o->pos, to);
}

/* Append item `it` starting at its point `start` (loops rotate to it;
 * open paths run from that end). */
static int put(struct order *o, size_t it, size_t start)
{
	const struct tp_path *pa = &o->items->paths[it];
	const struct pt2 *src = o->items->pts + pa->first;
	size_t n = pa->n, nw = pa->seg_w == SIZE_MAX ? 0 : (pa->closed ? n : n - 1);
	void *a = o->tmp;
	int reverse = !pa->closed && start != 0;
	int rc, retract;
	struct tp_path *np;

	if (mem_grow(&a, &o->cap_tmp, n, sizeof *o->tmp))
		return ERR_SET(o->e, ERR_NOMEM, "out of memory ordering toolpaths");
	o->tmp = a;
	if (nw) {
		a = o->tmp_w;
		if (mem_grow(&a, &o->cap_tmp_w, nw, sizeof *o->tmp_w))
			return ERR_SET(o->e, ERR_NOMEM, "out of memory ordering toolpaths");
		o->tmp_w = a;
	}
	for (size_t k = 0; k < n; k++) {
		size_t from = pa->closed ? (start + k) % n : reverse ? n - 1 - k : k;
		o->tmp[k] = src[from];
	}
	for (size_t k = 0; k < nw; k++) {
		const int64_t *w = o->items->seg_w + pa->seg_w;
		/* segment k of the output joins output points k and k + 1 */
		size_t from = pa->closed ? (start + k) % n : reverse ? nw - 1 - k : k;
		o->tmp_w[k] = w[from];
	}
	retract = travel_retracts(o, o->tmp[0]);
	rc = tp_plan_add(o->out, (enum tp_role)pa->role, pa->closed, pa->depth, pa->width_nm,
			 o->tmp, n, nw ? o->tmp_w : NULL, o->e);
	if (rc)
		return rc;
	np = &o->out->paths[o->out->npaths - 1];
	np->retract = (uint8_t)retract;
	np->speed_mm_s = role_speed(o, (enum tp_role)pa->role);
	o->pos = pa->closed ? o->tmp[0] : o->tmp[n - 1];
	o->have_pos = 1;
	return 0;
}

/* The seam of loop `it` when reached from the nozzle at vertex `near`. */
static size_t seam_of(const struct order *o, size_t it, size_t near)
{
	const struct tp_path *pa = &o->items->paths[it];
	const struct pt2 *p = o->items->pts + pa->first;
	size_t best = near;

	if (!o->c->seam_rear || pa->role == TP_ROLE_SKIRT)
		return near;
	for (size_t k = 0; k < pa->n; k++)
		if (p[k].y > p[best].y || (p[k].y == p[best].y && p[k].x < p[best].x))
			best = k;
	return best;
}

/* Fill lines of one role may be joined into the path before them when
 * the joining segment stays inside their fill area. */
static int try_join(struct order *o, size_t it, size_t start)
{
	const struct tp_path *pa = &o->items->paths[it];
	const struct pt2 *src = o->items->pts + pa->first;
	struct tp_plan *out = o->out;
	struct tp_path *last;
	struct pt2 a, b;
	enum tp_role r = (enum tp_role)pa->role;
	int64_t s = tp_spacing_nm(o->c->width_nm, o->in->height_mm);
	double limit;
	void *arr;

	if (pa->n != 2 || out->npaths == 0)
		return 0;
	last = &out->paths[out->npaths - 1];
	if (last->role != pa->role || last->closed || last->first + last->n != out->npts)
		return 0;
	a = o->pos;
	b = src[start ? 1 : 0];
	/* Adjacent lines are one line spacing apart; allow a slanted
	 * boundary (up to 3 spacings of travel along it). */
	limit = 3.0 * (double)(r == TP_ROLE_SPARSE && o->c->infill_frac > 0
				       ? (double)s / o->c->infill_frac
				       : (double)s);
	if (tp_dist_nm(a, b) > limit)
		return 0;
	if (!o->area_built[r]) {
		int rc = tp_index_build(&o->area_ix[r], &o->areas->fill[r], o->e);
		if (rc)
			return rc;
		o->area_built[r] = 1;
	}
	if (!tp_index_segment_inside(&o->area_ix[r], a, b))
		return 0;
	arr = out->pts;
	if (mem_grow(&arr, &out->cap_pts, out->npts + 2, sizeof *out->pts))
		return ERR_SET(o->e, ERR_NOMEM, "out of memory ordering toolpaths");
	out->pts = arr;
	out->pts[out->npts++] = b;
	out->pts[out->npts++] = src[start ? 0 : 1];
	last->n += 2;
	o->pos = src[start ? 0 : 1];
	return 1;
}

/* Chain the listed items nearest-neighbour from the nozzle. */
static int chain(struct order *o, const uint32_t *list, size_t n, int join)
{
	const struct tp_plan *it = o->items;
	int rc;

	if (n == 0)
		return 0;
	if (nn_reset(&o->nn, n))
		return ERR_SET(o->e, ERR_NOMEM, "out of memory ordering toolpaths");
	for (size_t i = 0; i < n; i++) {
		const struct tp_path *pa = &it->paths[list[i]];
		const struct pt2 *p = it->pts + pa->first;
		if (pa->closed) {
			for (size_t k = 0; k < pa->n; k++)
				if (nn_add(&o->nn, p[k], (uint32_t)i, (uint32_t)k))
					goto nomem;
		} else {
			if (nn_add(&o->nn, p[0], (uint32_t)i, 0) ||
			    (pa->n > 1 && nn_add(&o->nn, p[pa->n - 1], (uint32_t)i, 1)))
				goto nomem;
		}
	}
	if (nn_build(&o->nn))
		goto nomem;
	for (size_t done = 0; done < n; done++) {
		struct pt2 from = o->have_pos ? o->pos : o->in->start;
		long ci = nn_nearest(&o->nn, from);
		const struct cand *cd;
		size_t item, start;
		if (ci < 0)
			break;
		cd = &o->nn.c[ci];
		item = list[cd->item];
		nn_take(&o->nn, cd->item);
		if (it->paths[item].closed)
			start = seam_of(o, item, cd->tag);
		else
			start = cd->tag;
		rc = join && o->have_pos ? try_join(o, item, start) : 0;
		if (rc < 0)
			return rc;
		if (rc == 0) {
			rc = put(o, item, start);
			if (rc)
				return rc;
		}
	}
	return 0;
nomem:
	return ERR_SET(o->e, ERR_NOMEM, "out of memory ordering toolpaths");
}

struct island {
	size_t loop;            /* index of its outer loop in the region */
	struct path_measure m;  /* that loop's area and box */
	size_t first, n;        /* its items in by_island[] */
};

/* Index of the island containing q: the smallest outer loop around it
 * (islands inside another's hole are smaller).  Falls back to the island
 * with the nearest bounding box. */
static size_t locate(const struct paths *region, const struct island *is, size_t ni,
		     struct pt2 q)
{
	size_t best = SIZE_MAX, nearest = 0;
	double nd = INFINITY;

	for (size_t i = 0; i < ni; i++) {
		double dx = q.x < is[i].m.lo.x ? (double)(is[i].m.lo.x - q.x)
			    : q.x > is[i].m.hi.x ? (double)(q.x - is[i].m.hi.x) : 0;
		double dy = q.y < is[i].m.lo.y ? (double)(is[i].m.lo.y - q.y)
			    : q.y > is[i].m.hi.y ? (double)(q.y - is[i].m.hi.y) : 0;
		if (dx * dx + dy * dy < nd) {
			nd = dx * dx + dy * dy;
			nearest = i;
		}
		if (dx > 0 || dy > 0 ||
		    (best != SIZE_MAX && is[i].m.area2_nm2 >= is[best].m.area2_nm2))
			continue;
		if (path_holds(&region->v[is[i].loop], &is[i].m, q))
			best = i;
	}
	return best != SIZE_MAX ? best : nearest;
}

int tp_order(const struct tp_config *c, const struct tp_layer_in *in, const struct tp_plan *items,
	     const struct tp_areas *areas, struct tp_plan *out, struct err *e)
{
	static const enum tp_role fill_order[] = {TP_ROLE_SPARSE, TP_ROLE_BRIDGE, TP_ROLE_SOLID,
						  TP_ROLE_TOP};
	struct order o;
	struct island *is = NULL;
	struct path_measure *rm = NULL;
	size_t ni = 0, *owner = NULL, maxdepth = 0;
	uint32_t *by_island = NULL, *list = NULL, *cursor = NULL;
	unsigned char *island_done = NULL;
	int rc = 0;

	memset(&o, 0, sizeof o);
	o.c = c;
	o.in = in;
	o.items = items;
	o.out = out;
	o.areas = areas;
	o.e = e;
	if (items->npaths == 0)
		return 0;
	rc = tp_index_build(&o.region_ix, in->region, e);
	if (rc)
		goto out;
	is = mem_calloc(in->region->n + 1, sizeof *is);
	rm = mem_alloc((in->region->n + 1) * sizeof *rm);
	owner = mem_calloc(items->npaths, sizeof *owner);
	by_island = mem_calloc(items->npaths, sizeof *by_island);
	list = mem_calloc(items->npaths, sizeof *list);
	cursor = mem_calloc(in->region->n + 1, sizeof *cursor);
	island_done = mem_calloc(in->region->n + 1, 1);
	if (!is || !rm || !owner || !by_island || !list || !cursor || !island_done)
		goto nomem;
	paths_measure(in->region, rm);
	for (size_t i = 0; i < in->region->n; i++) {
		if (rm[i].area2_nm2 <= 0)
			continue;
		is[ni].loop = i;
		is[ni].m = rm[i];
		ni++;
	}
	/* Skirt first. */
	{
		size_t n = 0;
		for (size_t i = 0; i < items->npaths; i++)
			if (items->paths[i].role == TP_ROLE_SKIRT)
				list[n++] = (uint32_t)i;
		rc = chain(&o, list, n, 0);
		if (rc)
			goto out;
	}
	/* Group the rest by island (counting sort). */
	for (size_t i = 0; i < items->npaths; i++) {
		const struct tp_path *pa = &items->paths[i];
		owner[i] = SIZE_MAX;
		if (pa->role == TP_ROLE_SKIRT || ni == 0)
			continue;
		owner[i] = locate(in->region, is, ni, items->pts[pa->first]);
		is[owner[i]].n++;
		if (pa->depth > 0 && (size_t)pa->depth > maxdepth)
			maxdepth = (size_t)pa->depth;
	}
	for (size_t k = 0, acc = 0; k < ni; k++) {
		is[k].first = acc;
		acc += is[k].n;
		cursor[k] = (uint32_t)is[k].first;
	}
	for (size_t i = 0; i < items->npaths; i++)
		if (owner[i] != SIZE_MAX)
			by_island[cursor[owner[i]]++] = (uint32_t)i;
	for (size_t done = 0; done < ni; done++) {
		/* Nearest island: by the nearest vertex of its outline. */
		struct pt2 from = o.have_pos ? o.pos : in->start;
		size_t k = SIZE_MAX;
		double bd = INFINITY;
		for (size_t i = 0; i < ni; i++) {
			double dx, dy, d;
			if (island_done[i] || is[i].n == 0)
				continue;
			dx = from.x < is[i].m.lo.x ? (double)(is[i].m.lo.x - from.x)
			     : from.x > is[i].m.hi.x ? (double)(from.x - is[i].m.hi.x) : 0;
			dy = from.y < is[i].m.lo.y ? (double)(is[i].m.lo.y - from.y)
			     : from.y > is[i].m.hi.y ? (double)(from.y - is[i].m.hi.y) : 0;
			d = dx * dx + dy * dy;
			if (d < bd) {
				bd = d;
				k = i;
			}
		}
		if (k == SIZE_MAX)
			break;
		island_done[k] = 1;
		/* Loops by depth. */
		for (size_t step = 0; step <= maxdepth; step++) {
			int depth = c->external_first ? (int)step : (int)(maxdepth - step);
			size_t n = 0;
			for (size_t t = 0; t < is[k].n; t++) {
				uint32_t i = by_island[is[k].first + t];
				if (items->paths[i].closed && items->paths[i].depth == depth)
					list[n++] = i;
			}
			rc = chain(&o, list, n, 0);
			if (rc)
				goto out;
		}
		/* Thin walls and gap fill. */
		{
			size_t n = 0;
			for (size_t t = 0; t < is[k].n; t++) {
				uint32_t i = by_island[is[k].first + t];
				const struct tp_path *pa = &items->paths[i];
				if (pa->depth == -1 && (pa->role == TP_ROLE_EXT_PERIMETER ||
							pa->role == TP_ROLE_GAP_FILL))
					list[n++] = i;
			}
			rc = chain(&o, list, n, 0);
			if (rc)
				goto out;
		}
		for (size_t f = 0; f < sizeof fill_order / sizeof fill_order[0]; f++) {
			size_t n = 0;
			for (size_t t = 0; t < is[k].n; t++) {
				uint32_t i = by_island[is[k].first + t];
				if (items->paths[i].role == fill_order[f])
					list[n++] = i;
			}
			rc = chain(&o, list, n, 1);
			if (rc)
				goto out;
		}
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "out of memory ordering toolpaths");
out:
	tp_index_fini(&o.region_ix);
	for (int r = 0; r < TP_ROLE_COUNT; r++)
		if (o.area_built[r])
			tp_index_fini(&o.area_ix[r]);
	nn_fini(&o.nn);
	mem_free(o.tmp);
	mem_free(o.tmp_w);
	mem_free(is);
	mem_free(rm);
	mem_free(owner);
	mem_free(by_island);
	mem_free(list);
	mem_free(cursor);
	mem_free(island_done);
	return rc;
}
