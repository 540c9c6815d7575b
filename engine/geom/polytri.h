/* polytri.h - triangulation of a simple polygon by ear clipping.
 *
 * For caps of generated surfaces (the hollow engine closes each void's
 * floor and ceiling with it).  O(n^2) in the worst case, near O(n k) for
 * k reflex vertices; double-precision orientation tests.  Degenerate or
 * slightly self-intersecting input (a ceiling collapsed to zero area)
 * still yields exactly n - 2 triangles that use only the polygon's edges
 * on the boundary, so a closed mesh stays closed; such triangles may have
 * zero or negative area.
 */
#ifndef INFILLD_POLYTRI_H
#define INFILLD_POLYTRI_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Triangulate the polygon xy[0..2n) (x, y interleaved, any unit,
 * counter-clockwise).  Writes n - 2 triangles as index triples into tri
 * (room for 3 * (n - 2)), each counter-clockwise when the polygon is
 * simple.  n >= 3.  Returns 0, ERR_PARAM (n < 3) or ERR_NOMEM. */
int polytri_ears(const double *xy, size_t n, uint32_t *tri, struct err *e);

#endif
