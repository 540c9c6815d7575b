/* chains.h - closing the open contour chains of an open mesh (internal to
 * engine/slice/; implementation in chains.c, rationale in
 * docs/slicing.md "Open meshes").
 */
#ifndef INFILLD_SLICE_CHAINS_H
#define INFILLD_SLICE_CHAINS_H

#include <stdint.h>

#include "engine/geom/path.h"

struct err;

/* open: open polylines (nm), each running from its head (first point) to
 * its tail (last point) with the material on its left.  key (may be
 * NULL): 2 per chain, the hole (mesh border loop) its head and its tail
 * lie on, UINT32_MAX when not on a border.  Greedy joining: starting from
 * a chain, repeatedly connect its current tail to a head coinciding with
 * it (within 1 um: a seam the weld missed), else to the nearest alive
 * head on the same hole (the missing surface spans that hole, so it
 * meets the plane between that hole's crossings), else to the nearest
 * alive head of any chain; the chain's own head is a candidate, and
 * reaching it closes the loop.  Each closed loop is appended to loops;
 * open is emptied.  Orientation is never reversed, so the joined loops
 * keep the mesh's inside-left convention.
 * Cost O(m log m) for m chains plus the nearest-head searches (heads
 * sorted by x, pruned by |dx|; heads of a hole scanned in their bucket).
 * 0 or ERR_NOMEM (loops may then hold some loops). */
int slice_chains_close(struct paths *open, const uint32_t *key, struct paths *loops,
		       struct err *e);

#endif
