/* toolpath.c - FDM planner settings, plan storage, the move cursor and the
 * per-layer driver tp_plan_layer() (see toolpath.h; stages in
 * toolpath_int.h; design in docs/gcode.md).
 */
#include "engine/output/toolpath.h"
#include "engine/output/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/printer.h"

#include <math.h>
#include <string.h>

static const char *const role_names[TP_ROLE_COUNT] = {
	[TP_ROLE_SKIRT] = "Skirt/Brim",
	[TP_ROLE_EXT_PERIMETER] = "External perimeter",
	[TP_ROLE_PERIMETER] = "Perimeter",
	[TP_ROLE_GAP_FILL] = "Gap fill",
	[TP_ROLE_SPARSE] = "Internal infill",
	[TP_ROLE_SOLID] = "Solid infill",
	[TP_ROLE_TOP] = "Top solid infill",
	[TP_ROLE_BRIDGE] = "Bridge infill",
};

static const char *const role_keys[TP_ROLE_COUNT] = {
	[TP_ROLE_SKIRT] = "skirt",
	[TP_ROLE_EXT_PERIMETER] = "external_perimeter",
	[TP_ROLE_PERIMETER] = "perimeter",
	[TP_ROLE_GAP_FILL] = "gap_fill",
	[TP_ROLE_SPARSE] = "sparse_infill",
	[TP_ROLE_SOLID] = "solid_infill",
	[TP_ROLE_TOP] = "top_solid_infill",
	[TP_ROLE_BRIDGE] = "bridge_infill",
};

const char *tp_role_name(enum tp_role r)
{
	return r < TP_ROLE_COUNT ? role_names[r] : "Unknown";
}

const char *tp_role_key(enum tp_role r)
{
	return r < TP_ROLE_COUNT ? role_keys[r] : "unknown";
}

int64_t tp_spacing_nm(int64_t width_nm, double height_mm)
{
	return width_nm - geom_mm_to_nm(height_mm * (1.0 - M_PI / 4.0));
}

double tp_bead_area_mm2(double width_mm, double height_mm)
{
	return (width_mm - height_mm) * height_mm + M_PI * 0.25 * height_mm * height_mm;
}

int tp_config_init(struct tp_config *c, const struct fdm_printer *f, double layer_mm,
		   struct err *e)
{
	double hmax = layer_mm > f->first_layer_mm ? layer_mm : f->first_layer_mm;

	if (!(layer_mm > 0) || layer_mm > 0.8 * f->nozzle_mm)
		return ERR_FIELD(e, "layer_mm",
				 "layer_mm = %g cannot be printed with a %g mm nozzle (at most 80%% "
				 "of its diameter)",
				 layer_mm, f->nozzle_mm);
	if (f->line_width_mm <= hmax)
		return ERR_FIELD(e, "layer_mm",
				 "layer_mm = %g needs a line width above it (line_width_mm = %g)",
				 hmax, f->line_width_mm);
	memset(c, 0, sizeof *c);
	c->width_nm = geom_mm_to_nm(f->line_width_mm);
	c->nozzle_nm = geom_mm_to_nm(f->nozzle_mm);
	c->layer_mm = layer_mm;
	c->first_layer_mm = f->first_layer_mm;
	c->perimeters = f->perimeters;
	c->top_layers = f->top_layers;
	c->bottom_layers = f->bottom_layers;
	c->infill_frac = f->infill_pct / 100.0;
	c->infill_angle_rad = f->infill_angle_deg * M_PI / 180.0;
	c->external_first = f->external_perimeter_first;
	c->seam_rear = f->seam == FDM_SEAM_REAR;
	c->min_travel_retract_nm = geom_mm_to_nm(f->min_travel_retract_mm);
	c->skirt_loops = f->skirt_loops;
	c->skirt_distance_nm = geom_mm_to_nm(f->skirt_distance_mm);
	/* 12.5 um (PrusaSlicer's G-code resolution): Douglas-Peucker keeps
	 * every dropped vertex within it, below the checker's 0.02 mm
	 * containment tolerance (docs/gcode.md). */
	c->clean_nm = 12500;
	c->speed_mm_s[TP_ROLE_SKIRT] = f->print_speed_mm_s;
	c->speed_mm_s[TP_ROLE_EXT_PERIMETER] = f->external_perimeter_speed_mm_s;
	c->speed_mm_s[TP_ROLE_PERIMETER] = f->perimeter_speed_mm_s;
	c->speed_mm_s[TP_ROLE_GAP_FILL] = f->print_speed_mm_s;
	c->speed_mm_s[TP_ROLE_SPARSE] = f->infill_speed_mm_s;
	c->speed_mm_s[TP_ROLE_SOLID] = f->solid_infill_speed_mm_s;
	c->speed_mm_s[TP_ROLE_TOP] = f->top_solid_speed_mm_s;
	c->speed_mm_s[TP_ROLE_BRIDGE] = f->bridge_speed_mm_s;
	c->first_layer_speed_mm_s = f->first_layer_speed_mm_s;
	c->bed_lo = (struct pt2){0, 0};
	c->bed_hi = (struct pt2){geom_mm_to_nm(f->bed_x_mm), geom_mm_to_nm(f->bed_y_mm)};
	return 0;
}

void tp_plan_init(struct tp_plan *p)
{
	memset(p, 0, sizeof *p);
	p->speed_factor = 1.0;
}

void tp_plan_fini(struct tp_plan *p)
{
	mem_free(p->paths);
	mem_free(p->pts);
	mem_free(p->seg_w);
	tp_plan_init(p);
}

void tp_plan_reset(struct tp_plan *p)
{
	p->npaths = p->npts = p->nseg_w = 0;
	p->speed_factor = 1.0;
	p->min_speed_mm_s = 0;
	p->thin_regions = p->thin_dropped = 0;
	p->thin_dropped_mm2 = 0;
}

int tp_plan_add(struct tp_plan *p, enum tp_role role, int closed, int depth, int64_t width_nm,
		const struct pt2 *pts, size_t n, const int64_t *seg_w, struct err *e)
{
	void *a;
	struct tp_path *pa;
	size_t nw = seg_w ? (closed ? n : n - 1) : 0;

	if (n == 0)
		return 0;
	a = p->paths;
	if (mem_grow(&a, &p->cap_paths, p->npaths + 1, sizeof *p->paths))
		goto nomem;
	p->paths = a;
	a = p->pts;
	if (mem_grow(&a, &p->cap_pts, p->npts + n, sizeof *p->pts))
		goto nomem;
	p->pts = a;
	if (nw) {
		a = p->seg_w;
		if (mem_grow(&a, &p->cap_seg_w, p->nseg_w + nw, sizeof *p->seg_w))
			goto nomem;
		p->seg_w = a;
	}
	pa = &p->paths[p->npaths++];
	memset(pa, 0, sizeof *pa);
	pa->role = (uint8_t)role;
	pa->closed = (uint8_t)(closed != 0);
	pa->depth = (int16_t)depth;
	pa->width_nm = width_nm;
	pa->first = p->npts;
	pa->n = n;
	pa->seg_w = SIZE_MAX;
	memcpy(p->pts + p->npts, pts, n * sizeof *pts);
	p->npts += n;
	if (nw) {
		pa->seg_w = p->nseg_w;
		memcpy(p->seg_w + p->nseg_w, seg_w, nw * sizeof *seg_w);
		p->nseg_w += nw;
	}
	return 0;
nomem:
	return ERR_SET(e, ERR_NOMEM, "out of memory storing toolpaths");
}

/* Douglas-Peucker on the chain pts[i..j] (indices modulo n): marks in keep
 * the vertices needed so that no dropped vertex lies farther than tol
 * from the simplified chain.  Explicit stack: O(n log n) typical, O(n^2)
 * worst case. */
static int dp_chain(const struct pt2 *pts, size_t n, size_t i, size_t j, double tol,
		    unsigned char *keep, size_t *stack)
{
	size_t sp = 0;

	stack[sp++] = i;
	stack[sp++] = j;
	while (sp) {
		size_t b = stack[--sp], a = stack[--sp], best = SIZE_MAX;
		double ax = (double)pts[a % n].x, ay = (double)pts[a % n].y;
		double dx = (double)pts[b % n].x - ax, dy = (double)pts[b % n].y - ay;
		double len = sqrt(dx * dx + dy * dy), worst = tol;
		for (size_t k = a + 1; k < b; k++) {
			double px = (double)pts[k % n].x - ax, py = (double)pts[k % n].y - ay, d;
			if (len > 0) {
				double t = (px * dx + py * dy) / (len * len);
				if (t < 0)
					t = 0;
				if (t > 1)
					t = 1;
				d = hypot(px - t * dx, py - t * dy);
			} else {
				d = hypot(px, py);
			}
			if (d > worst) {
				worst = d;
				best = k;
			}
		}
		if (best != SIZE_MAX) {
			keep[best % n] = 1;
			stack[sp++] = a;
			stack[sp++] = best;
			stack[sp++] = best;
			stack[sp++] = b;
		}
	}
	return 0;
}

/* Simplify one closed loop in place: split at vertex 0 and the vertex
 * farthest from it, Douglas-Peucker both halves. */
static int simplify_loop(struct path *p, double tol, unsigned char *keep, size_t *stack)
{
	size_t n = p->n, far = 0, k = 0;
	double fd = -1;

	for (size_t i = 1; i < n; i++) {
		double d = hypot((double)(p->pts[i].x - p->pts[0].x), (double)(p->pts[i].y - p->pts[0].y));
		if (d > fd) {
			fd = d;
			far = i;
		}
	}
	memset(keep, 0, n);
	keep[0] = keep[far] = 1;
	dp_chain(p->pts, n, 0, far, tol, keep, stack);
	dp_chain(p->pts, n, far, n, tol, keep, stack);
	for (size_t i = 0; i < n; i++)
		if (keep[i])
			p->pts[k++] = p->pts[i];
	p->n = k;
	return 0;
}

int tp_region_clean(const struct tp_config *c, struct paths *region, struct err *e)
{
	size_t k = 0, nmax = 0;
	unsigned char *keep;
	size_t *stack;

	for (size_t i = 0; i < region->n; i++)
		if (region->v[i].n > nmax)
			nmax = region->v[i].n;
	if (nmax == 0)
		return 0;
	keep = mem_alloc(nmax + 1);
	stack = mem_alloc((4 * nmax + 8) * sizeof *stack);
	if (!keep || !stack) {
		mem_free(keep);
		mem_free(stack);
		return ERR_SET(e, ERR_NOMEM, "out of memory simplifying a layer");
	}
	for (size_t i = 0; i < region->n; i++)
		if (region->v[i].n > 3)
			simplify_loop(&region->v[i], (double)c->clean_nm, keep, stack);
	mem_free(keep);
	mem_free(stack);
	/* Loops that collapsed below a triangle (slivers under the tolerance)
	 * are dropped. */
	for (size_t i = 0; i < region->n; i++) {
		if (region->v[i].n >= 3 && path_area2_nm2(&region->v[i]) != 0) {
			region->v[k++] = region->v[i];
		} else {
			path_fini(&region->v[i]);
		}
	}
	region->n = k;
	return 0;
}

void tp_areas_init(struct tp_areas *a)
{
	for (int r = 0; r < TP_ROLE_COUNT; r++)
		paths_init(&a->fill[r]);
}

void tp_areas_fini(struct tp_areas *a)
{
	for (int r = 0; r < TP_ROLE_COUNT; r++)
		paths_fini(&a->fill[r]);
}

int tp_plan_layer(const struct tp_config *c, const struct tp_layer_in *in, struct tp_plan *out,
		  struct err *e)
{
	static const enum tp_role fill_roles[] = {TP_ROLE_SPARSE, TP_ROLE_BRIDGE, TP_ROLE_SOLID,
						  TP_ROLE_TOP};
	struct tp_plan items;
	struct tp_areas areas;
	int64_t s = tp_spacing_nm(c->width_nm, in->height_mm);
	/* Alternate 90 degrees per layer; lines on a grid fixed to the printer
	 * origin so sparse lines of equal direction stack (docs/gcode.md). */
	double angle = c->infill_angle_rad + (in->index % 2 ? M_PI / 2 : 0);
	int rc;

	tp_plan_reset(out);
	tp_plan_init(&items);
	tp_areas_init(&areas);
	rc = tp_regions(c, in, &items, &areas, e);
	for (size_t i = 0; !rc && i < sizeof fill_roles / sizeof fill_roles[0]; i++) {
		enum tp_role r = fill_roles[i];
		int64_t d = s;
		if (areas.fill[r].n == 0)
			continue;
		if (r == TP_ROLE_SPARSE) {
			if (c->infill_frac <= 0)
				continue;
			/* Each line deposits a bead of spacing s, so lines s/p apart
			 * fill the fraction p of the area. */
			d = (int64_t)llround((double)s / c->infill_frac);
		}
		rc = tp_fill_lines(&areas.fill[r], angle, d, c->width_nm, r, c->width_nm, &items, e);
	}
	if (!rc)
		rc = tp_order(c, in, &items, &areas, out, e);
	if (!rc) {
		out->thin_regions = items.thin_regions;
		out->thin_dropped = items.thin_dropped;
		out->thin_dropped_mm2 = items.thin_dropped_mm2;
	}
	tp_plan_fini(&items);
	tp_areas_fini(&areas);
	return rc;
}

/* ---- cursor ------------------------------------------------------------ */

void tp_cursor_init(struct tp_cursor *cu, const struct tp_plan *p, int hop)
{
	memset(cu, 0, sizeof *cu);
	cu->plan = p;
	cu->hop = hop;
}

static double path_speed(const struct tp_plan *p, const struct tp_path *pa)
{
	double v = pa->speed_mm_s * p->speed_factor;
	double floor_v = pa->speed_mm_s < p->min_speed_mm_s ? pa->speed_mm_s : p->min_speed_mm_s;

	return v > floor_v ? v : floor_v;
}

/* Stages of a path: travel events (0..5), feature (6), extrusion (7). */
enum { ST_RETRACT, ST_HOP_UP, ST_TRAVEL, ST_HOP_DOWN, ST_UNRETRACT, ST_FEATURE, ST_EXTRUDE };

int tp_cursor_next(struct tp_cursor *cu, struct tp_ev *ev)
{
	const struct tp_plan *p = cu->plan;

	while (cu->path < p->npaths) {
		const struct tp_path *pa = &p->paths[cu->path];
		const struct pt2 *pts = p->pts + pa->first;
		int travel = cu->path > 0, retract = travel && pa->retract;

		if (cu->stage == 0 && travel) {
			/* Skip the travel when the previous path ends here. */
			struct pt2 at;
			const struct tp_path *pv = &p->paths[cu->path - 1];
			at = pv->closed ? p->pts[pv->first] : p->pts[pv->first + pv->n - 1];
			if (at.x == pts[0].x && at.y == pts[0].y && !retract)
				travel = 0;
		}
		switch (cu->stage) {
		case ST_RETRACT:
			cu->stage++;
			if (retract) {
				ev->kind = TP_EV_RETRACT;
				return 1;
			}
			/* fall through */
		case ST_HOP_UP:
			cu->stage++;
			if (retract && cu->hop) {
				ev->kind = TP_EV_HOP_UP;
				return 1;
			}
			/* fall through */
		case ST_TRAVEL:
			cu->stage++;
			if (travel) {
				ev->kind = TP_EV_TRAVEL;
				ev->to = pts[0];
				return 1;
			}
			/* fall through */
		case ST_HOP_DOWN:
			cu->stage++;
			if (retract && cu->hop) {
				ev->kind = TP_EV_HOP_DOWN;
				return 1;
			}
			/* fall through */
		case ST_UNRETRACT:
			cu->stage++;
			if (retract) {
				ev->kind = TP_EV_UNRETRACT;
				return 1;
			}
			/* fall through */
		case ST_FEATURE:
			cu->stage++;
			cu->pt = 1;
			ev->kind = TP_EV_FEATURE;
			ev->role = (enum tp_role)pa->role;
			ev->speed_mm_s = path_speed(p, pa);
			ev->width_nm = tp_seg_width(p, pa, 0);
			return 1;
		default: {
			size_t last = pa->closed ? pa->n : pa->n - 1;
			if (cu->pt <= last && pa->n > 1) {
				ev->kind = TP_EV_EXTRUDE;
				ev->to = pts[cu->pt % pa->n];
				ev->width_nm = tp_seg_width(p, pa, cu->pt - 1);
				ev->role = (enum tp_role)pa->role;
				cu->pt++;
				return 1;
			}
			cu->path++;
			cu->stage = 0;
		}
		}
	}
	return 0;
}

int tp_plan_start(const struct tp_plan *p, struct pt2 *at)
{
	if (p->npaths == 0)
		return 0;
	*at = p->pts[p->paths[0].first];
	return 1;
}

int tp_plan_end(const struct tp_plan *p, struct pt2 *at)
{
	const struct tp_path *pa;

	if (p->npaths == 0)
		return 0;
	pa = &p->paths[p->npaths - 1];
	*at = pa->closed ? p->pts[pa->first] : p->pts[pa->first + pa->n - 1];
	return 1;
}
