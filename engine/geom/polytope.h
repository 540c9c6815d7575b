/* polytope.h - convex polytopes given by half-spaces.
 *
 * The Chebyshev centre (centre of the largest inscribed ball) of
 * {x : n_i . x <= d_i} by a small dense simplex: used by the lattice
 * engine to bound vertex moves so no tetrahedron of a star inverts.
 */
#ifndef INFILLD_POLYTOPE_H
#define INFILLD_POLYTOPE_H

#include <stddef.h>

#include "engine/geom/vec.h"

/* Largest ball inside {x : n[i] . x <= d[i], i < m} (normals need not be
 * unit).  `start` must satisfy every inequality strictly (it anchors the
 * search and bounds it to a box of half-size box_mm around start).
 * Returns 0 with *center, *radius set; -1 if start is not strictly
 * inside, m exceeds 512, or the simplex fails to converge.  O(m^2) per
 * pivot, a few dozen pivots for m ~ 50. */
int geom_chebyshev_center(const struct vec3 *n, const double *d, size_t m, struct vec3 start,
			  double box_mm, struct vec3 *center, double *radius);

#endif
