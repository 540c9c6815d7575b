/* toolpath_index.c - a uniform grid over a region's edges for the
 * planner's segment-crossing, point-in-region and nearest-edge queries
 * (see toolpath_int.h).
 *
 * Each edge is registered in every cell its segment passes through
 * (row by row: the x-range of the segment inside each row band, so long
 * diagonal edges cost their length, not their bounding box).  Queries
 * visit the cells along their segment or ray and test the edges found
 * there exactly in integer arithmetic; a per-edge stamp skips edges seen
 * twice in one query.
 */
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

static int orient(struct pt2 a, struct pt2 b, struct pt2 q)
{
	__int128 c = (__int128)(b.x - a.x) * (q.y - a.y) - (__int128)(b.y - a.y) * (q.x - a.x);
	return (c > 0) - (c < 0);
}

void tp_grid_size(struct pt2 lo, struct pt2 hi, size_t n, double per_cell, int64_t min_cell_nm,
		  int64_t *cell_nm, int *nx, int *ny)
{
	double w = (double)(hi.x - lo.x) + 1, h = (double)(hi.y - lo.y) + 1;
	double cell = sqrt(per_cell * w * h / (double)(n ? n : 1));

	if (cell < (double)min_cell_nm)
		cell = (double)min_cell_nm;
	*cell_nm = (int64_t)cell;
	*nx = (int)(w / cell) + 1;
	*ny = (int)(h / cell) + 1;
}


/* Cells [x0, x1] of row band y covered by segment ab clipped to the band
 * [ylo, yhi] (inclusive, so edges on a cell border land in both cells). */
static void row_span(const struct tp_index *ix, struct pt2 a, struct pt2 b, int64_t ylo,
		     int64_t yhi, int *x0, int *x1)
{
	double xa, xb;

	if (a.y == b.y) {
		xa = (double)a.x;
		xb = (double)b.x;
	} else {
		double t0 = ((double)ylo - (double)a.y) / (double)(b.y - a.y);
		double t1 = ((double)yhi - (double)a.y) / (double)(b.y - a.y);
		if (t0 > t1) {
			double t = t0;
			t0 = t1;
			t1 = t;
		}
		if (t0 < 0)
			t0 = 0;
		if (t1 > 1)
			t1 = 1;
		xa = (double)a.x + t0 * (double)(b.x - a.x);
		xb = (double)a.x + t1 * (double)(b.x - a.x);
	}
	if (xa > xb) {
		double t = xa;
		xa = xb;
		xb = t;
	}
	*x0 = tp_cell_of((int64_t)floor(xa) - 1, ix->lo.x, ix->cell_nm, ix->nx);
	*x1 = tp_cell_of((int64_t)ceil(xb) + 1, ix->lo.x, ix->cell_nm, ix->nx);
}

/* Call visit(cell) for every cell segment ab passes through. */
#define FOR_SEGMENT_CELLS(ix, a, b, CELL, ...)                                                  \
	do {                                                                                    \
		int64_t ymin_ = (a).y < (b).y ? (a).y : (b).y;                                 \
		int64_t ymax_ = (a).y < (b).y ? (b).y : (a).y;                                 \
		int r0_ = tp_cell_of(ymin_ - 1, (ix)->lo.y, (ix)->cell_nm, (ix)->ny);             \
		int r1_ = tp_cell_of(ymax_ + 1, (ix)->lo.y, (ix)->cell_nm, (ix)->ny);             \
		for (int r_ = r0_; r_ <= r1_; r_++) {                                          \
			int64_t blo_ = (ix)->lo.y + (int64_t)r_ * (ix)->cell_nm - 1;           \
			int64_t bhi_ = blo_ + (ix)->cell_nm + 2;                               \
			int c0_, c1_;                                                          \
			if (r_ == 0)                                                           \
				blo_ = INT64_MIN / 4;                                          \
			if (r_ == (ix)->ny - 1)                                                \
				bhi_ = INT64_MAX / 4;                                          \
			if (blo_ < ymin_)                                                      \
				blo_ = ymin_;                                                  \
			if (bhi_ > ymax_)                                                      \
				bhi_ = ymax_;                                                  \
			row_span((ix), (a), (b), blo_, bhi_, &c0_, &c1_);                      \
			for (int c_ = c0_; c_ <= c1_; c_++) {                                  \
				size_t CELL = (size_t)r_ * (size_t)(ix)->nx + (size_t)c_;      \
				__VA_ARGS__                                                    \
			}                                                                      \
		}                                                                              \
	} while (0)

int tp_index_build(struct tp_index *ix, const struct paths *ps, struct err *e)
{
	struct pt2 lo, hi;
	size_t n = 0, k = 0, ncell;
	uint32_t *fill = NULL;

	memset(ix, 0, sizeof *ix);
	ix->cell_nm = 1;
	ix->nx = ix->ny = 1;
	for (size_t i = 0; i < ps->n; i++)
		n += ps->v[i].n >= 2 ? ps->v[i].n : 0;
	if (n >= UINT32_MAX / 4)
		return ERR_SET(e, ERR_LIMIT, "a layer with %zu edges is too large to plan", n);
	if (!paths_bbox(ps, &lo, &hi) || n == 0) {
		ix->start = mem_calloc(2, sizeof *ix->start);
		if (!ix->start)
			return ERR_SET(e, ERR_NOMEM, "out of memory indexing a region");
		return 0;
	}
	ix->edges = mem_alloc(n * sizeof *ix->edges);
	ix->stamp = mem_calloc(n, sizeof *ix->stamp);
	if (!ix->edges || !ix->stamp)
		goto nomem;
	for (size_t i = 0; i < ps->n; i++) {
		const struct path *p = &ps->v[i];
		if (p->n < 2)
			continue;
		for (size_t j = 0; j < p->n; j++)
			ix->edges[k++] = (struct tp_edge){p->pts[j], p->pts[(j + 1) % p->n]};
	}
	ix->nedges = n;
	/* About one edge per cell, at least 0.2 mm cells. */
	tp_grid_size(lo, hi, n, 1.0, 200000, &ix->cell_nm, &ix->nx, &ix->ny);
	ix->lo = lo;
	ncell = (size_t)ix->nx * (size_t)ix->ny;
	ix->start = mem_calloc(ncell + 1, sizeof *ix->start);
	fill = mem_calloc(ncell + 1, sizeof *fill);
	if (!ix->start || !fill)
		goto nomem;
	/* Two passes: count per cell, then place. */
	for (size_t i = 0; i < n; i++) {
		struct pt2 a = ix->edges[i].a, b = ix->edges[i].b;
		FOR_SEGMENT_CELLS(ix, a, b, cidx, { ix->start[cidx + 1]++; });
	}
	for (size_t c = 0; c < ncell; c++) {
		if (ix->start[c + 1] > UINT32_MAX - ix->start[c])
			goto limit;
		ix->start[c + 1] += ix->start[c];
	}
	ix->items = mem_alloc((size_t)ix->start[ncell] * sizeof *ix->items + 1);
	if (!ix->items)
		goto nomem;
	for (size_t i = 0; i < n; i++) {
		struct pt2 a = ix->edges[i].a, b = ix->edges[i].b;
		FOR_SEGMENT_CELLS(ix, a, b, cidx,
				  { ix->items[ix->start[cidx] + fill[cidx]++] = (uint32_t)i; });
	}
	mem_free(fill);
	return 0;
limit:
	mem_free(fill);
	tp_index_fini(ix);
	return ERR_SET(e, ERR_LIMIT, "a layer region is too complex to index");
nomem:
	mem_free(fill);
	tp_index_fini(ix);
	return ERR_SET(e, ERR_NOMEM, "out of memory indexing a region");
}

void tp_index_fini(struct tp_index *ix)
{
	mem_free(ix->edges);
	mem_free(ix->start);
	mem_free(ix->items);
	mem_free(ix->stamp);
	memset(ix, 0, sizeof *ix);
}

static uint32_t next_query(struct tp_index *ix)
{
	if (++ix->query == 0) {
		memset(ix->stamp, 0, ix->nedges * sizeof *ix->stamp);
		ix->query = 1;
	}
	return ix->query;
}

int tp_index_crosses(struct tp_index *ix, struct pt2 a, struct pt2 b)
{
	uint32_t q;

	if (ix->nedges == 0)
		return 0;
	q = next_query(ix);
	FOR_SEGMENT_CELLS(ix, a, b, cidx, {
		for (uint32_t t = ix->start[cidx]; t < ix->start[cidx + 1]; t++) {
			uint32_t id = ix->items[t];
			const struct tp_edge *ed = &ix->edges[id];
			if (ix->stamp[id] == q)
				continue;
			ix->stamp[id] = q;
			if (orient(a, b, ed->a) * orient(a, b, ed->b) < 0 &&
			    orient(ed->a, ed->b, a) * orient(ed->a, ed->b, b) < 0)
				return 1;
		}
	});
	return 0;
}

int tp_index_inside(struct tp_index *ix, struct pt2 q)
{
	int w = 0, r;
	uint32_t s;

	if (ix->nedges == 0)
		return 0;
	if (q.y < ix->lo.y || q.y > ix->lo.y + (int64_t)ix->ny * ix->cell_nm ||
	    q.x > ix->lo.x + (int64_t)ix->nx * ix->cell_nm)
		return 0;
	s = next_query(ix);
	r = tp_cell_of(q.y, ix->lo.y, ix->cell_nm, ix->ny);
	/* Ray towards +x: every edge crossing it at x >= q.x lies in a cell of
	 * row r at or right of q's column. */
	for (int c = tp_cell_of(q.x, ix->lo.x, ix->cell_nm, ix->nx); c < ix->nx; c++) {
		size_t cidx = (size_t)r * (size_t)ix->nx + (size_t)c;
		for (uint32_t t = ix->start[cidx]; t < ix->start[cidx + 1]; t++) {
			uint32_t id = ix->items[t];
			int on = 0;
			if (ix->stamp[id] == s)
				continue;
			ix->stamp[id] = s;
			w += path_edge_winding(ix->edges[id].a, ix->edges[id].b, q, &on);
			if (on)
				return 1;
		}
	}
	return w != 0;
}

int tp_index_segment_inside(struct tp_index *ix, struct pt2 a, struct pt2 b)
{
	struct pt2 m = {a.x + (b.x - a.x) / 2, a.y + (b.y - a.y) / 2};

	return !tp_index_crosses(ix, a, b) && tp_index_inside(ix, m);
}

/* Closest point to p on segment ab (doubles, nm). */
static void closest_on_segment(struct pt2 a, struct pt2 b, struct pt2 p, double *qx, double *qy)
{
	double dx = (double)(b.x - a.x), dy = (double)(b.y - a.y);
	double l2 = dx * dx + dy * dy;
	double t = l2 > 0 ? ((double)(p.x - a.x) * dx + (double)(p.y - a.y) * dy) / l2 : 0;

	if (t < 0)
		t = 0;
	if (t > 1)
		t = 1;
	*qx = (double)a.x + t * dx;
	*qy = (double)a.y + t * dy;
}

int tp_index_nearest(struct tp_index *ix, struct pt2 p, int64_t max_nm, struct pt2 *q)
{
	double best = (double)max_nm * (double)max_nm, bx = 0, by = 0;
	int found = 0, c0, c1, r0, r1;
	uint32_t s;

	if (ix->nedges == 0)
		return 0;
	s = next_query(ix);
	c0 = tp_cell_of(p.x - max_nm, ix->lo.x, ix->cell_nm, ix->nx);
	c1 = tp_cell_of(p.x + max_nm, ix->lo.x, ix->cell_nm, ix->nx);
	r0 = tp_cell_of(p.y - max_nm, ix->lo.y, ix->cell_nm, ix->ny);
	r1 = tp_cell_of(p.y + max_nm, ix->lo.y, ix->cell_nm, ix->ny);
	for (int r = r0; r <= r1; r++) {
		for (int c = c0; c <= c1; c++) {
			size_t cidx = (size_t)r * (size_t)ix->nx + (size_t)c;
			for (uint32_t t = ix->start[cidx]; t < ix->start[cidx + 1]; t++) {
				uint32_t id = ix->items[t];
				double qx, qy, d2;
				if (ix->stamp[id] == s)
					continue;
				ix->stamp[id] = s;
				closest_on_segment(ix->edges[id].a, ix->edges[id].b, p, &qx, &qy);
				d2 = (qx - (double)p.x) * (qx - (double)p.x) +
				     (qy - (double)p.y) * (qy - (double)p.y);
				if (d2 <= best) {
					best = d2;
					bx = qx;
					by = qy;
					found = 1;
				}
			}
		}
	}
	if (found)
		*q = (struct pt2){(int64_t)llround(bx), (int64_t)llround(by)};
	return found;
}

int tp_index_first_hit(struct tp_index *ix, struct pt2 a, struct pt2 b, int64_t skip_nm,
		       struct pt2 *hit)
{
	double dx = (double)(b.x - a.x), dy = (double)(b.y - a.y);
	double len = sqrt(dx * dx + dy * dy), best = 2.0, tmin;
	uint32_t s;

	if (ix->nedges == 0 || len <= 0)
		return 0;
	tmin = (double)skip_nm / len;
	s = next_query(ix);
	FOR_SEGMENT_CELLS(ix, a, b, cidx, {
		for (uint32_t t = ix->start[cidx]; t < ix->start[cidx + 1]; t++) {
			uint32_t id = ix->items[t];
			struct pt2 ea = ix->edges[id].a, eb = ix->edges[id].b;
			double ex = (double)(eb.x - ea.x), ey = (double)(eb.y - ea.y);
			double den = dx * ey - dy * ex, u, v;
			if (ix->stamp[id] == s)
				continue;
			ix->stamp[id] = s;
			if (den == 0)
				continue; /* parallel: a grazing edge is met by its neighbours */
			u = ((double)(ea.x - a.x) * ey - (double)(ea.y - a.y) * ex) / den;
			v = ((double)(ea.x - a.x) * dy - (double)(ea.y - a.y) * dx) / den;
			if (u > tmin && u < best && v >= 0 && v <= 1)
				best = u;
		}
	});
	if (best > 1.0)
		return 0;
	hit->x = a.x + (int64_t)llround(best * dx);
	hit->y = a.y + (int64_t)llround(best * dy);
	return 1;
}

/* Distance between segments ab and cd, nm: 0 when they meet, else the
 * smallest of the four endpoint-to-segment distances. */
static double seg_seg_dist(struct pt2 a, struct pt2 b, struct pt2 c, struct pt2 d)
{
	int o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a), o4 = orient(c, d, b);
	double best, qx, qy, t;

	/* A crossing or a touch; four collinear points meet only when their
	 * extents overlap (else the endpoint distances below are exact). */
	if (o1 * o2 <= 0 && o3 * o4 <= 0 && (o1 || o2 || o3 || o4))
		return 0;
	closest_on_segment(c, d, a, &qx, &qy);
	best = hypot(qx - (double)a.x, qy - (double)a.y);
	closest_on_segment(c, d, b, &qx, &qy);
	t = hypot(qx - (double)b.x, qy - (double)b.y);
	best = t < best ? t : best;
	closest_on_segment(a, b, c, &qx, &qy);
	t = hypot(qx - (double)c.x, qy - (double)c.y);
	best = t < best ? t : best;
	closest_on_segment(a, b, d, &qx, &qy);
	t = hypot(qx - (double)d.x, qy - (double)d.y);
	return t < best ? t : best;
}

double tp_index_seg_clearance(struct tp_index *ix, struct pt2 a, struct pt2 b, double max_nm)
{
	double best = max_nm;
	int64_t m = (int64_t)ceil(max_nm);
	int c0, c1, r0, r1;
	uint32_t s;

	if (ix->nedges == 0)
		return max_nm;
	s = next_query(ix);
	c0 = tp_cell_of((a.x < b.x ? a.x : b.x) - m, ix->lo.x, ix->cell_nm, ix->nx);
	c1 = tp_cell_of((a.x < b.x ? b.x : a.x) + m, ix->lo.x, ix->cell_nm, ix->nx);
	r0 = tp_cell_of((a.y < b.y ? a.y : b.y) - m, ix->lo.y, ix->cell_nm, ix->ny);
	r1 = tp_cell_of((a.y < b.y ? b.y : a.y) + m, ix->lo.y, ix->cell_nm, ix->ny);
	for (int r = r0; r <= r1; r++) {
		for (int c = c0; c <= c1; c++) {
			size_t cidx = (size_t)r * (size_t)ix->nx + (size_t)c;
			for (uint32_t t = ix->start[cidx]; t < ix->start[cidx + 1]; t++) {
				uint32_t id = ix->items[t];
				double d;
				if (ix->stamp[id] == s)
					continue;
				ix->stamp[id] = s;
				d = seg_seg_dist(a, b, ix->edges[id].a, ix->edges[id].b);
				if (d < best)
					best = d;
			}
		}
	}
	return best;
}
