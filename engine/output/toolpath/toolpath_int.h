/* toolpath_int.h - internal to toolpath*.c: the planner's stages.
 *
 * tp_plan_layer() (layer.c) runs: region analysis (toolpath_regions.c:
 * perimeter loops, thin pieces via toolpath_thin.c, skin/sparse areas),
 * infill lines (toolpath_fill.c), then ordering (toolpath_order.c) with
 * segment queries on an edge grid (toolpath_index.c).
 */
#ifndef INFILLD_TOOLPATH_INT_H
#define INFILLD_TOOLPATH_INT_H

#include "engine/output/toolpath/toolpath.h"

/* Fill areas of a layer, by role (only the infill roles are used). */
struct tp_areas {
	struct paths fill[TP_ROLE_COUNT];
};

void tp_areas_init(struct tp_areas *a);
void tp_areas_fini(struct tp_areas *a);

/* Append a path of n points to p (unordered "items" use depth for loops,
 * -1 for open paths).  seg_w: NULL for constant width, else n - 1 widths
 * (n when closed).  0 or ERR_NOMEM. */
int tp_plan_add(struct tp_plan *p, enum tp_role role, int closed, int depth, int64_t width_nm,
		const struct pt2 *pts, size_t n, const int64_t *seg_w, struct err *e);

/* Region analysis: perimeter loops (closed, depth k) and thin walls / gap
 * fill (open, variable width) into items; fill areas into areas; thin
 * piece counts into items' stats. */
int tp_regions(const struct tp_config *c, const struct tp_layer_in *in, struct tp_plan *items,
	       struct tp_areas *areas, struct err *e);

/* Centrelines of thin pieces (each narrower than about a line width):
 * every piece is shrunk to a sliver around its medial axis, the sliver is
 * cut into a polyline, and each vertex is re-centred between the two
 * walls it sits between, with the local wall distance as its bead width
 * (docs/gcode.md, "thin walls").  Pieces whose widest part is narrower
 * than min_w_nm are counted as dropped.  Appends open paths to items. */
int tp_thin(const struct paths *pieces, enum tp_role role, int64_t min_w_nm, int64_t max_w_nm,
	    struct tp_plan *items, struct err *e);

/* Straight infill lines: direction angle_rad, spacing_nm apart, on a grid
 * anchored at the printer origin (line m sits at perpendicular offset
 * (m + 1/2) spacing), clipped to area (nonzero rule) by a scanline sweep;
 * pieces shorter than min_len_nm are dropped.  Appends 2-point open paths
 * of the given role and width to items.  O(E log E + lines). */
int tp_fill_lines(const struct paths *area, double angle_rad, int64_t spacing_nm,
		  int64_t min_len_nm, enum tp_role role, int64_t width_nm, struct tp_plan *items,
		  struct err *e);

/* Ordering: items (unordered, from the stages above) into out, in print
 * order, with speeds and travel decisions.  region: the layer's material
 * (travels that leave it retract). */
int tp_order(const struct tp_config *c, const struct tp_layer_in *in, const struct tp_plan *items,
	     const struct tp_areas *areas, struct tp_plan *out, struct err *e);

/* ---- Uniform grids (edge index, nearest-neighbour search) ------------ */

/* Cell size and counts for n items spread over [lo, hi]: about per_cell
 * items per cell, cells no smaller than min_cell_nm. */
void tp_grid_size(struct pt2 lo, struct pt2 hi, size_t n, double per_cell, int64_t min_cell_nm,
		  int64_t *cell_nm, int *nx, int *ny);

/* Cell index of coordinate v on an axis starting at lo, clamped to
 * [0, n). */
static inline int tp_cell_of(int64_t v, int64_t lo, int64_t cell, int n)
{
	int64_t k = v < lo ? -1 : (v - lo) / cell;
	return k < 0 ? 0 : k >= n ? n - 1 : (int)k;
}

/* ---- Edge grid: segment and point queries against a region ---------- */

struct tp_edge {
	struct pt2 a, b;
};

struct tp_index {
	struct tp_edge *edges;
	size_t nedges;
	struct pt2 lo;
	int64_t cell_nm;
	int nx, ny;
	uint32_t *start; /* nx * ny + 1 offsets into items */
	uint32_t *items; /* edge ids per cell */
	uint32_t *stamp; /* per edge: last query that visited it */
	uint32_t query;
};

/* Index the closed paths of ps (copied).  0 or ERR_NOMEM. */
int tp_index_build(struct tp_index *ix, const struct paths *ps, struct err *e);
void tp_index_fini(struct tp_index *ix);
/* Nonzero when segment ab properly crosses an edge (touching at a or b,
 * or running along an edge, does not count). */
int tp_index_crosses(struct tp_index *ix, struct pt2 a, struct pt2 b);
/* Nonzero winding of the indexed paths around q (q on an edge: inside). */
int tp_index_inside(struct tp_index *ix, struct pt2 q);
/* Segment ab lies inside the region (closure): no proper crossing and its
 * midpoint inside. */
int tp_index_segment_inside(struct tp_index *ix, struct pt2 a, struct pt2 b);

/* Nearest point of the indexed edges to p within max_nm: 1 and *q, or 0
 * when none is that close. */
int tp_index_nearest(struct tp_index *ix, struct pt2 p, int64_t max_nm, struct pt2 *q);
/* Distance from segment ab to the nearest indexed edge, nm, or max_nm
 * when none is nearer (0 when ab meets an edge).  Visits the cells of
 * ab's bounding box grown by max_nm. */
double tp_index_seg_clearance(struct tp_index *ix, struct pt2 a, struct pt2 b, double max_nm);
/* First point where segment ab meets an edge, ignoring meetings closer to
 * a than skip_nm: 1 and *hit, or 0. */
int tp_index_first_hit(struct tp_index *ix, struct pt2 a, struct pt2 b, int64_t skip_nm,
		       struct pt2 *hit);

static inline double tp_dist_nm(struct pt2 a, struct pt2 b)
{
	double dx = (double)(a.x - b.x), dy = (double)(a.y - b.y);
	return sqrt(dx * dx + dy * dy);
}

#endif
