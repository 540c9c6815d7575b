/* solve.h - optimising the voids of one hollowing round (solve.c). */
#ifndef INFILLD_HOLLOW_SOLVE_H
#define INFILLD_HOLLOW_SOLVE_H

#include "engine/hollow/nlp.h"

struct progress;

/* status of a void whose optimum failed its check but whose support-free
 * starting point passed and was used instead */
#define HL_STATUS_FALLBACK 1
/* status of a void not optimised: the time budget (o->deadline_s) was
 * spent before its turn; it gets the support-free start like a failed one */
#define HL_STATUS_UNSOLVED (-2000)

/* Optimise v[0..n): lightweight voids each on their own, in up to
 * `threads` worker processes; stability as one problem.  Every void ends
 * with status 0 (optimum), HL_STATUS_FALLBACK, or < 0 (drop it); past
 * o->deadline_s no solve starts and the rest take their start.  prog
 * (may be NULL) moves from stage fraction f0 to f1 as voids finish and
 * may cancel.
 * Returns 0, ERR_NOMEM, ERR_IO (pipe/poll) or ERR_CANCELLED. */
int hl_solve_round(struct hl_void *v, size_t n, const struct hl_nlp_opts *o, int threads,
		   struct progress *prog, double f0, double f1, struct err *e);

#endif
