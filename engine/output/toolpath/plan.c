/* plan.c - the plan store (tp_plan: paths, points, per-segment widths),
 * role names, bead geometry, and the move cursor that replays a plan as
 * printer moves (see toolpath.h; design in docs/gcode.md).  The planning
 * stages (regions, fill, order, thin) append to a plan through
 * tp_plan_add(); the per-layer driver that runs them is layer.c.
 */
#include "engine/output/toolpath/toolpath.h"
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

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
