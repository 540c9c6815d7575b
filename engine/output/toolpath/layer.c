/* layer.c - the per-layer FDM planner: settings from the printer profile
 * (tp_config_init), region clean-up (tp_region_clean), and tp_plan_layer(),
 * which runs the stages of toolpath_int.h in order (regions -> fill ->
 * order) into a plan (plan.c).  Design in docs/gcode.md.
 */
#include "engine/output/toolpath/toolpath.h"
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/printer/printer.h"

#include <math.h>
#include <string.h>

int tp_config_check(const struct fdm_printer *f, double layer_mm, struct err *e)
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
	return 0;
}

int tp_config_init(struct tp_config *c, const struct fdm_printer *f, double layer_mm,
		   struct err *e)
{
	int rc = tp_config_check(f, layer_mm, e);

	if (rc)
		return rc;
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
