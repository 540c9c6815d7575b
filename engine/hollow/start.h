/* start.h - support-free starting point of a void's offsets (start.c). */
#ifndef INFILLD_HOLLOW_START_H
#define INFILLD_HOLLOW_START_H

#include "engine/hollow/hollow_int.h"

/* Fill l (v->nv offsets) top-down: top loop on its poles, every other
 * vertex the smallest offset within reach_mm of its upper cross-edge
 * neighbours (see start.c).  0 or ERR_NOMEM. */
int hl_void_support_start(const struct hl_void *v, double reach_mm, double *l, struct err *e);

#endif
