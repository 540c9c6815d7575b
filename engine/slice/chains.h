/* chains.h - closing the open contour chains of an open mesh (internal to
 * engine/slice/; implementation in chains.c, rationale in
 * docs/slicing.md "Open meshes").
 */
#ifndef INFILLD_SLICE_CHAINS_H
#define INFILLD_SLICE_CHAINS_H

#include "engine/geom/path.h"

struct err;

/* open: open polylines (nm), each running from its head (first point) to
 * its tail (last point) with the material on its left.  Greedy
 * nearest-end joining: starting from a chain, repeatedly connect its
 * current tail to the nearest head of a chain not yet used (its own head
 * included); reaching its own head closes the loop.  Each closed loop is
 * appended to loops; open is emptied.  Orientation is never reversed, so
 * the joined loops keep the mesh's inside-left convention.
 * Cost O(m log m) for m chains plus the scans of the nearest-head search
 * (heads sorted by x, pruned by |dx|; dead entries skipped in O(1)
 * amortised).  0 or ERR_NOMEM (loops may then hold some loops). */
int slice_chains_close(struct paths *open, struct paths *loops, struct err *e);

#endif
