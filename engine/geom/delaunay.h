/* delaunay.h - 2D Delaunay triangulation and Voronoi vertices of points.
 *
 * Incremental Bowyer-Watson insertion with a "ghost" vertex at infinity
 * (every convex-hull edge has a ghost triangle behind it), so no finite
 * bounding triangle distorts the result near the hull.  All decisions use
 * the exact integer predicates of predicates.h: collinear and cocircular
 * input (resampled straight edges, circles) is handled without epsilons;
 * among cocircular points the triangulation is one valid Delaunay
 * triangulation.  Points are inserted in Hilbert-curve order and located
 * by a visibility walk from the last new triangle: O(n log n) for the sort
 * plus near-constant expected work per point on curve samples.
 * Used by the hollow engine for the Voronoi poles of contour samples.
 */
#ifndef INFILLD_DELAUNAY_H
#define INFILLD_DELAUNAY_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"

struct err;

#define DT_NONE UINT32_MAX

struct dt_tri {
	uint32_t v[3];  /* point indices, counter-clockwise */
	uint32_t nb[3]; /* triangle across the edge opposite v[i]; DT_NONE = hull edge */
};

struct delaunay {
	size_t n;            /* input points */
	struct dt_tri *tri;  /* finite triangles, owned */
	size_t nt;
	uint32_t *vtri;      /* per point: one incident triangle; DT_NONE for a
				duplicate (see dup) or when nt == 0 */
	uint32_t *dup;       /* per point: the index it duplicates, else itself */
};

void delaunay_init(struct delaunay *dt);
void delaunay_fini(struct delaunay *dt);

/* Triangulate n points (borrowed; nm).  Exact duplicates are merged (dup[]).
 * All points collinear (or fewer than 3 distinct): success with nt = 0.
 * Fails with ERR_LIMIT when the points span more than 2^30 nm or n is
 * over 2^31, ERR_NOMEM.  dt is replaced only on success. */
int delaunay_build(const struct pt2 *p, size_t n, struct delaunay *dt, struct err *e);

/* Triangles around point v in counter-clockwise order, written to out
 * (at most max).  Returns the count (0 for duplicates); *closed = 1 when
 * v is interior (the fan is a full cycle), 0 on the hull (then the first
 * and last triangles touch hull edges). */
size_t delaunay_fan(const struct delaunay *dt, uint32_t v, uint32_t *out, size_t max,
		    int *closed);

/* Circumcentre of triangle t in mm (the Voronoi vertex dual to t). */
void delaunay_circumcenter_mm(const struct delaunay *dt, const struct pt2 *p, uint32_t t,
			      double *x_mm, double *y_mm);

#endif
