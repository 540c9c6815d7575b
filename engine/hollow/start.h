/* start.h - support-free starting point of a void's offsets (start.c). */
#ifndef INFILLD_HOLLOW_START_H
#define INFILLD_HOLLOW_START_H

#include "engine/hollow/hollow_int.h"

/* Fill l (v->nv offsets): v->start when restrip.c made one, else a sweep
 * top-down: top loop on its poles, every other vertex the smallest offset
 * within reach_mm of its upper cross-edge neighbours (see start.c).  0 or
 * ERR_NOMEM. */
int hl_void_support_start(const struct hl_void *v, double reach_mm, double *l, struct err *e);

/* Rebuild v's strips top-down where its start puts the vertices, and set
 * v->start (restrip.c; reach_mm as above, block: clearance at offset 0).
 * A pair of loops with no strip whose cross edges stay within reach ends
 * the void: it keeps the loops above and *first is the index (in v's
 * loops before the call) of the lowest kept, else 0.  Returns 0, 1 when
 * fewer than two loops are left (v unusable), or a negative err_code. */
int hl_void_restrip(struct hl_void *v, double reach_mm, const struct hl_block *block,
		    size_t *first, struct err *e);

#endif
