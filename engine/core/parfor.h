/* parfor.h - run a loop body over [0, n) on a few threads.
 *
 * Dynamic scheduling in chunks through an atomic counter; the calling
 * thread takes part.  The body must be safe to run concurrently for
 * different indices; `tid` (0..threads-1) indexes per-thread scratch.
 * With threads <= 1, or when threads cannot be started, the loop runs on
 * the caller alone (same results: bodies must not depend on the order).
 */
#ifndef INFILLD_PARFOR_H
#define INFILLD_PARFOR_H

#include <stddef.h>

typedef void (*parfor_fn)(void *ctx, size_t i, int tid);

/* chunk: indices taken at once (>= 1). */
void parfor_run(size_t n, int threads, size_t chunk, parfor_fn fn, void *ctx);

#endif
