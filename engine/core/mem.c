/* mem.c - allocation wrappers (see mem.h). */
#include "engine/core/mem.h"
#include "engine/core/err.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Thread-local test instrumentation, not configuration: production code
 * never sets it, so workers stay reentrant. */
static _Thread_local long fail_countdown = -1;
static _Thread_local long injected;

static int should_fail(void)
{
	if (fail_countdown < 0)
		return 0;
	if (fail_countdown > 1) {
		fail_countdown--;
		return 0;
	}
	injected++;
	return 1; /* stays at 1: every later allocation fails too */
}

long mem_fail_after(long n)
{
	long prev = fail_countdown;

	fail_countdown = n < 0 ? -1 : n;
	injected = 0;
	return prev;
}

long mem_injected_failures(void)
{
	return injected;
}

void *mem_alloc(size_t n)
{
	if (should_fail())
		return NULL;
	return malloc(n ? n : 1);
}

void *mem_calloc(size_t count, size_t size)
{
	if (should_fail())
		return NULL;
	if (count == 0 || size == 0)
		return calloc(1, 1);
	return calloc(count, size);
}

void *mem_realloc(void *p, size_t n)
{
	if (should_fail())
		return NULL;
	return realloc(p, n ? n : 1);
}

void *mem_realloc_array(void *p, size_t count, size_t size)
{
	if (size && count > SIZE_MAX / size)
		return NULL;
	return mem_realloc(p, count * size);
}

void mem_free(void *p)
{
	free(p);
}

char *mem_strdup(const char *s)
{
	size_t n = strlen(s) + 1;
	char *d = mem_alloc(n);

	if (d)
		memcpy(d, s, n);
	return d;
}

int mem_grow(void **arr, size_t *cap, size_t need, size_t elem)
{
	size_t ncap;
	void *p;

	if (need <= *cap)
		return 0;
	ncap = *cap ? *cap : 16;
	while (ncap < need) {
		if (ncap > SIZE_MAX / 2)
			return ERR_NOMEM;
		ncap *= 2;
	}
	p = mem_realloc_array(*arr, ncap, elem);
	if (!p)
		return ERR_NOMEM;
	*arr = p;
	*cap = ncap;
	return 0;
}
