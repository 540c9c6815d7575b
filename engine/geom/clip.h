/* clip.h - polygon booleans and offsets (a thin C shim over Clipper 6.4,
 * libpolyclipping; implementation in clip.cpp, the only C++ here besides
 * the TetGen shim).
 *
 * Coordinates are the integer nanometres of path.h.  Outputs are
 * normalised regions (outer CCW, holes CW, no overlaps) unless stated.
 * Every function catches C++ exceptions and returns ERR_NOMEM or
 * ERR_INTERNAL instead of letting them cross into C.  Outputs are
 * replaced (previous content freed) only on success.
 */
#ifndef INFILLD_CLIP_H
#define INFILLD_CLIP_H

#include "engine/geom/path.h"

struct err;

enum clip_op { CLIP_UNION, CLIP_INTERSECTION, CLIP_DIFFERENCE, CLIP_XOR };
enum clip_fill { CLIP_FILL_EVENODD, CLIP_FILL_NONZERO, CLIP_FILL_POSITIVE };
enum clip_join { CLIP_JOIN_SQUARE, CLIP_JOIN_ROUND, CLIP_JOIN_MITER };

/* out = subj OP clip, both closed paths read with `fill`.  clip may be NULL
 * (treated as empty). */
int clip_boolean(enum clip_op op, const struct paths *subj, const struct paths *clip,
		 enum clip_fill fill, struct paths *out, struct err *e);

/* Normalise a set of closed paths read with `fill` into a region. */
int clip_union(const struct paths *in, enum clip_fill fill, struct paths *out, struct err *e);

/* Offset a region by delta_nm (> 0 grows, < 0 shrinks).  arc_tol_nm is
 * the maximum deviation of round joins from a true arc (0 = 1/4 of
 * |delta|, Clipper's default).  miter_limit only for CLIP_JOIN_MITER. */
int clip_offset(const struct paths *in, double delta_nm, enum clip_join join,
		double miter_limit, double arc_tol_nm, struct paths *out, struct err *e);

/* Clip open polylines against a region (nonzero): out receives the parts
 * of the lines inside it, as open polylines. */
int clip_lines(const struct paths *lines, const struct paths *region, struct paths *out,
	       struct err *e);

/* Remove vertices closer than dist_nm to their neighbours and collinear
 * ones (Clipper's CleanPolygons); in place. */
int clip_clean(struct paths *ps, double dist_nm, struct err *e);

#endif
