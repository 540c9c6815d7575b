/* parfor.c - a parallel for loop over an index range (see parfor.h). */
#include "engine/core/parfor.h"

#include <pthread.h>
#include <stdatomic.h>

#define PARFOR_MAX_THREADS 64

struct parfor {
	size_t n, chunk;
	parfor_fn fn;
	void *ctx;
	atomic_size_t next;
};

struct parfor_arg {
	struct parfor *p;
	int tid;
};

static void *parfor_main(void *arg)
{
	struct parfor_arg *a = arg;
	struct parfor *p = a->p;
	size_t lo;

	while ((lo = atomic_fetch_add(&p->next, p->chunk)) < p->n) {
		size_t hi = lo + p->chunk < p->n ? lo + p->chunk : p->n;
		for (size_t i = lo; i < hi; i++)
			p->fn(p->ctx, i, a->tid);
	}
	return NULL;
}

void parfor_run(size_t n, int threads, size_t chunk, parfor_fn fn, void *ctx)
{
	struct parfor p;
	struct parfor_arg args[PARFOR_MAX_THREADS];
	pthread_t th[PARFOR_MAX_THREADS];
	int started[PARFOR_MAX_THREADS] = {0};

	if (n == 0)
		return;
	p.n = n;
	p.chunk = chunk ? chunk : 1;
	p.fn = fn;
	p.ctx = ctx;
	atomic_init(&p.next, 0);
	if (threads > PARFOR_MAX_THREADS)
		threads = PARFOR_MAX_THREADS;
	if (threads < 1)
		threads = 1;
	for (int t = 0; t < threads; t++) {
		args[t].p = &p;
		args[t].tid = t;
	}
	for (int t = 1; t < threads; t++)
		started[t] = pthread_create(&th[t], NULL, parfor_main, &args[t]) == 0;
	parfor_main(&args[0]);
	for (int t = 1; t < threads; t++)
		if (started[t])
			pthread_join(th[t], NULL);
}
