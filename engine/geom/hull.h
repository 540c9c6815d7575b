/* hull.h - convex hulls and convex polygons in the plane.
 *
 * Andrew's monotone chain with the exact orientation test of
 * predicates.h (O(n log n)), plus the few operations on convex polygons
 * the engines need: inward offset (half-plane intersection: exact
 * Minkowski erosion for a convex set), inscribed-circle radius, point
 * containment and signed distance to the boundary.  Convex polygons here
 * are counter-clockwise, in millimetres (struct hull_pt).
 */
#ifndef INFILLD_HULL_H
#define INFILLD_HULL_H

#include <stddef.h>

#include "engine/geom/path.h"

struct err;

struct hull_pt {
	double x, y; /* mm */
};

/* Convex hull of n points (nm): counter-clockwise, no collinear vertices.
 * *out (caller frees with mem_free) gets *nout points: 0 for no input, 1
 * or 2 for degenerate input.  ERR_NOMEM. */
int hull_convex(const struct pt2 *p, size_t n, struct hull_pt **out, size_t *nout,
		struct err *e);

/* Signed area (mm^2, > 0 counter-clockwise). */
double hull_area_mm2(const struct hull_pt *h, size_t n);

/* Signed distance (mm) from q to the boundary of convex CCW polygon h:
 * > 0 inside, < 0 outside.  n >= 3. */
double hull_signed_distance_mm(const struct hull_pt *h, size_t n, struct hull_pt q);

/* Closest point of the convex polygon (boundary or interior) to q; returns
 * the distance (0 inside).  Sets *edge to the edge index the point lies on,
 * or -1 when q is inside; *vertex to 1 when that point is the edge's start
 * vertex (a corner region), else 0.  n >= 3. */
double hull_closest_mm(const struct hull_pt *h, size_t n, struct hull_pt q, struct hull_pt *c,
		       int *edge, int *vertex);

/* Shrink convex CCW polygon h by d_mm >= 0 (every edge moved inward by
 * d_mm).  *out (caller frees) gets the result, *nout = 0 when it vanishes.
 * ERR_NOMEM. */
int hull_offset_in(const struct hull_pt *h, size_t n, double d_mm, struct hull_pt **out,
		   size_t *nout, struct err *e);

/* Radius (mm) of the largest circle inside convex CCW polygon h, and its
 * centre (may be NULL); bisection on hull_offset_in to 1e-9 relative. */
double hull_inradius_mm(const struct hull_pt *h, size_t n, struct hull_pt *center);

#endif
