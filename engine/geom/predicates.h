/* predicates.h - exact 2D orientation and in-circle tests on integer points.
 *
 * Points are struct pt2 (integer nanometres, path.h).  Both predicates are
 * evaluated exactly in __int128, so they never lie about a sign: the
 * Delaunay triangulation, convex hull and polygon triangulation built on
 * them are robust against collinear and cocircular input.  Exactness
 * needs every coordinate difference to stay within +-2^30 nm (about 1 m):
 * the in-circle determinant is then bounded by 12 * 2^120 < 2^127.
 * Callers check their input with geom_pred_range_ok() first.
 */
#ifndef INFILLD_PREDICATES_H
#define INFILLD_PREDICATES_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"

#define GEOM_PRED_MAX_RANGE_NM ((int64_t)1 << 30)

/* Sign of the doubled signed area of triangle abc: > 0 when a, b, c turn
 * counter-clockwise, < 0 clockwise, 0 collinear.  Needs differences
 * within +-2^62 (any nm coordinate on a printer). */
static inline int geom_orient2d(struct pt2 a, struct pt2 b, struct pt2 c)
{
	__int128 d = (__int128)(b.x - a.x) * (c.y - a.y) - (__int128)(b.y - a.y) * (c.x - a.x);
	return (d > 0) - (d < 0);
}

/* > 0 when d lies strictly inside the circle through a, b, c (given
 * counter-clockwise), < 0 strictly outside, 0 on it.  Differences must be
 * within +-2^30 (see above). */
static inline int geom_incircle(struct pt2 a, struct pt2 b, struct pt2 c, struct pt2 d)
{
	int64_t adx = a.x - d.x, ady = a.y - d.y;
	int64_t bdx = b.x - d.x, bdy = b.y - d.y;
	int64_t cdx = c.x - d.x, cdy = c.y - d.y;
	/* |.| <= 2^61 each: fits int64 before the products below */
	__int128 al = (__int128)adx * adx + (__int128)ady * ady;
	__int128 bl = (__int128)bdx * bdx + (__int128)bdy * bdy;
	__int128 cl = (__int128)cdx * cdx + (__int128)cdy * cdy;
	__int128 det = adx * (bdy * cl - cdy * bl) - ady * (bdx * cl - cdx * bl) +
		       al * ((__int128)bdx * cdy - (__int128)cdx * bdy);
	return (det > 0) - (det < 0);
}

/* 1 when the bounding box of n points spans at most GEOM_PRED_MAX_RANGE_NM
 * on both axes (then every difference is exact in geom_incircle). */
int geom_pred_range_ok(const struct pt2 *p, size_t n);

#endif
