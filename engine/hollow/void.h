/* void.h - building one void from a chain of loops (void.c). */
#ifndef INFILLD_HOLLOW_VOID_H
#define INFILLD_HOLLOW_VOID_H

#include "engine/hollow/hollow_int.h"

/* Build a void from loops[0..n) (bottom to top, consecutive slices;
 * borrowed, copied): shifting directions and bounds per loop (hl_poles),
 * strips between neighbours (hl_strip).  Strips are built upward until a
 * pair has no admissible strip; *used = loops taken (>= 1).  Returns 0
 * with *out replaced, 1 when fewer than two loops could be joined (the
 * caller continues from loops[*used]), or a negative err_code. */
int hl_void_build(const struct hl_loop *const *loops, size_t n, const struct hl_block *block,
		  struct hl_void *out, size_t *used, struct err *e);

#endif
