/* path.h - 2D polygons in integer nanometres.
 *
 * All 2D polygon work (slicing output, offsets, booleans, toolpaths) uses
 * integer coordinates in nanometres in the printer frame (x right, y
 * away from the viewer, seen from +z).  Conversion from/to millimetres
 * happens only through geom_mm_to_nm()/geom_nm_to_mm().  At 1 nm a
 * 250 mm bed spans 2.5e8 units: products of two coordinates fit in
 * int64, sums of many products are accumulated in __int128/double.
 *
 * A struct path is a closed polygon (the closing edge last->first is
 * implied; no repeated end point) or, where a function says so, an open
 * polyline.  A region is a struct paths under the nonzero winding rule,
 * normalised (by clip_union) to outer boundaries counter-clockwise and
 * holes clockwise, with no self-overlap.
 */
#ifndef INFILLD_PATH_H
#define INFILLD_PATH_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define GEOM_NM_PER_MM 1000000.0

struct pt2 {
	int64_t x, y; /* nm */
};

struct path {
	struct pt2 *pts; /* owned */
	size_t n, cap;
};

struct paths {
	struct path *v; /* owned, each path owned */
	size_t n, cap;
};

static inline int64_t geom_mm_to_nm(double mm)
{
	return (int64_t)llround(mm * GEOM_NM_PER_MM);
}
static inline double geom_nm_to_mm(int64_t nm)
{
	return (double)nm / GEOM_NM_PER_MM;
}

void path_init(struct path *p);
void path_fini(struct path *p);
int path_push(struct path *p, struct pt2 q); /* 0 or ERR_NOMEM */
int path_copy(struct path *dst, const struct path *src);

void paths_init(struct paths *ps);
void paths_fini(struct paths *ps);
void paths_clear(struct paths *ps); /* n = 0, paths freed, array kept */
/* Append an empty path; returns it or NULL on ERR_NOMEM. */
struct path *paths_add(struct paths *ps);
/* Append a copy of n points. 0 or ERR_NOMEM. */
int paths_add_pts(struct paths *ps, const struct pt2 *pts, size_t n);
int paths_copy(struct paths *dst, const struct paths *src);
/* Move all paths of src to the end of dst (src left empty). */
int paths_append_move(struct paths *dst, struct paths *src);
size_t paths_point_count(const struct paths *ps);

/* Twice the signed area of a closed path in nm^2 (CCW > 0). */
__int128 path_area2_nm2(const struct path *p);
/* Signed area in mm^2 (CCW > 0). */
double path_area_mm2(const struct path *p);
/* Sum of signed areas in mm^2: the region's area when normalised. */
double paths_area_mm2(const struct paths *ps);
/* Perimeter length of a closed path in mm. */
double path_length_mm(const struct path *p, int closed);

void path_reverse(struct path *p);

/* Contribution of the directed edge a->b to the winding number around q
 * (crossings of a ray from q towards +x, half-open in y): +1, -1 or 0.
 * *on_edge is set to 1 when q lies on the edge (exact integer tests). */
int path_edge_winding(struct pt2 a, struct pt2 b, struct pt2 q, int *on_edge);

/* Winding number of the closed paths around q (a point on an edge counts
 * as inside: returns 1 for it under CCW, the caller's convention). */
int paths_winding(const struct paths *ps, struct pt2 q);

/* Bounding box of all points; returns 0 when ps has no points. */
int paths_bbox(const struct paths *ps, struct pt2 *lo, struct pt2 *hi);

/* One path measured once: twice its signed area (path_area2_nm2 as a
 * double: > 0 counter-clockwise, < 0 a hole, 0 under 3 points) and its
 * bounding box (lo > hi for a path without points). */
struct path_measure {
	double area2_nm2;
	struct pt2 lo, hi;
};

/* m[i] for each path i of ps (m: ps->n entries, caller-owned). */
void paths_measure(const struct paths *ps, struct path_measure *m);

/* Area in mm^2 of a measured path (signed, as path_area_mm2). */
double path_measure_mm2(const struct path_measure *m);

/* 1 when q lies in m's box and path p, measured as m, winds around it (a
 * point on an edge counts, as paths_winding). */
int path_holds(const struct path *p, const struct path_measure *m, struct pt2 q);

/* The outer loop of each hole of a normalised region.  owner[i] receives,
 * for each clockwise path i (a hole), the index of the smallest
 * counter-clockwise path whose inside holds the hole's first point, and
 * SIZE_MAX for counter-clockwise paths, paths of under 3 points or of zero
 * area, and holes that no loop holds.  m: ps's measures (paths_measure),
 * or NULL to take them here.  The winding test runs only on loops whose
 * box holds the point, so a layer of many voids costs holes x outers box
 * tests, not that many passes over every vertex.  owner has ps->n
 * entries, caller-owned.  Returns 0 or ERR_NOMEM (owner then undefined). */
int paths_hole_owners(const struct paths *ps, const struct path_measure *m, size_t *owner);

/* Distance in mm from q to the nearest edge of the closed paths. */
double paths_distance_mm(const struct paths *ps, struct pt2 q);

#endif
