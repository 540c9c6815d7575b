/* mem.h - allocation wrappers with an allocation-failure injection mode.
 *
 * Engine code allocates through mem_alloc()/mem_calloc()/mem_realloc()
 * so tests can make the N-th allocation of the current thread fail and
 * check that every path reports ERR_NOMEM and leaks nothing
 * (tests/unit/... use mem_fail_after()).  mem_free(NULL) is a no-op.
 * The multiplication helpers refuse size_t overflow instead of wrapping.
 */
#ifndef INFILLD_MEM_H
#define INFILLD_MEM_H

#include <stddef.h>

void *mem_alloc(size_t n);
void *mem_calloc(size_t count, size_t size);
void *mem_realloc(void *p, size_t n);
/* realloc to count*size bytes; NULL (and p untouched) on overflow or OOM. */
void *mem_realloc_array(void *p, size_t count, size_t size);
void mem_free(void *p);
char *mem_strdup(const char *s);

/* Test hook: the n-th following allocation on this thread fails (n >= 1);
 * n < 0 switches injection off.  Returns the previous setting. */
long mem_fail_after(long n);
/* Allocations that failed by injection since the last mem_fail_after(). */
long mem_injected_failures(void);

/* Grow a dynamic array: ensure *cap >= need, doubling; elements of size
 * `elem`.  Returns 0 or ERR_NOMEM (array untouched on failure). */
int mem_grow(void **arr, size_t *cap, size_t need, size_t elem);

#endif
