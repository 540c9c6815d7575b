/* pipeline.c - ordered parallel map (see pipeline.h).
 *
 * Slots form a ring indexed by sequence number modulo max_in_flight:
 * [tail, head) are in flight.  Workers pick the oldest queued slot so
 * early layers finish first and the in-order emitter rarely waits.
 */
#include "engine/core/pipeline.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <pthread.h>
#include <string.h>
#include <unistd.h>

enum slot_state { SLOT_EMPTY, SLOT_QUEUED, SLOT_RUNNING, SLOT_DONE };

struct slot {
	void *item;
	enum slot_state state;
	int rc;
	struct err err;
};

struct pipeline {
	struct pipeline_ops ops;
	void *ctx;
	int nthreads, cap;
	struct slot *slots;
	unsigned long head, tail; /* next to submit, next to emit */
	int failed;               /* first failure code, 0 if none */
	struct err fail_err;
	int stopping;
	pthread_mutex_t mu;
	pthread_cond_t work_cv; /* a slot became QUEUED, or stopping */
	pthread_cond_t done_cv; /* a slot became DONE */
	pthread_t *threads;
	int started;
};

int pipeline_cpu_count(void)
{
	long n = sysconf(_SC_NPROCESSORS_ONLN);
	return n < 1 ? 1 : n > 256 ? 256 : (int)n;
}

static void *worker_main(void *arg)
{
	struct pipeline *p = arg;

	pthread_mutex_lock(&p->mu);
	for (;;) {
		struct slot *s = NULL;
		for (unsigned long q = p->tail; q != p->head; q++) {
			struct slot *c = &p->slots[q % (unsigned long)p->cap];
			if (c->state == SLOT_QUEUED) {
				s = c;
				break;
			}
		}
		if (!s) {
			if (p->stopping)
				break;
			pthread_cond_wait(&p->work_cv, &p->mu);
			continue;
		}
		s->state = SLOT_RUNNING;
		pthread_mutex_unlock(&p->mu);
		err_clear(&s->err);
		s->rc = p->ops.work(p->ctx, s->item, &s->err);
		pthread_mutex_lock(&p->mu);
		s->state = SLOT_DONE;
		pthread_cond_broadcast(&p->done_cv);
	}
	pthread_mutex_unlock(&p->mu);
	return NULL;
}

int pipeline_new(const struct pipeline_ops *ops, void *ctx, int threads, int max_in_flight,
		 struct pipeline **out, struct err *e)
{
	struct pipeline *p;

	if (max_in_flight < 1)
		max_in_flight = 1;
	if (threads < 0)
		threads = 0;
	p = mem_calloc(1, sizeof *p);
	if (!p)
		return ERR_SET(e, ERR_NOMEM, "out of memory creating a pipeline");
	p->ops = *ops;
	p->ctx = ctx;
	p->cap = max_in_flight;
	p->nthreads = threads;
	p->slots = mem_calloc((size_t)max_in_flight, sizeof *p->slots);
	p->threads = mem_calloc((size_t)(threads ? threads : 1), sizeof *p->threads);
	if (!p->slots || !p->threads) {
		mem_free(p->slots);
		mem_free(p->threads);
		mem_free(p);
		return ERR_SET(e, ERR_NOMEM, "out of memory creating a pipeline");
	}
	pthread_mutex_init(&p->mu, NULL);
	pthread_cond_init(&p->work_cv, NULL);
	pthread_cond_init(&p->done_cv, NULL);
	for (int i = 0; i < threads; i++) {
		if (pthread_create(&p->threads[i], NULL, worker_main, p) != 0) {
			pipeline_free(p);
			return ERR_SET(e, ERR_LIMIT, "cannot start pipeline thread %d", i);
		}
		p->started++;
	}
	*out = p;
	return 0;
}

/* Record the first failure.  Called with mu held. */
static void fail(struct pipeline *p, int rc, const struct err *src)
{
	if (p->failed)
		return;
	p->failed = rc;
	if (src)
		p->fail_err = *src;
}

static int failure(struct pipeline *p, struct err *e)
{
	if (e)
		*e = p->fail_err;
	return p->failed;
}

/* Emit finished items at the tail.  block: wait for the tail item.
 * Called with mu held; drops it around callbacks. */
static void emit_ready(struct pipeline *p, int block)
{
	while (p->tail != p->head) {
		struct slot *s = &p->slots[p->tail % (unsigned long)p->cap];
		void *item;
		int rc;
		struct err ee;

		if (s->state != SLOT_DONE) {
			if (!block)
				return;
			pthread_cond_wait(&p->done_cv, &p->mu);
			continue;
		}
		item = s->item;
		rc = s->rc;
		if (rc)
			fail(p, rc, &s->err);
		s->item = NULL;
		s->state = SLOT_EMPTY;
		p->tail++;
		pthread_mutex_unlock(&p->mu);
		err_clear(&ee);
		if (!p->failed) {
			rc = p->ops.emit(p->ctx, item, &ee);
		} else {
			if (p->ops.drop)
				p->ops.drop(p->ctx, item);
			rc = 0;
		}
		pthread_mutex_lock(&p->mu);
		if (rc)
			fail(p, rc, &ee);
	}
}

int pipeline_submit(struct pipeline *p, void *item, struct err *e)
{
	struct slot *s;

	if (p->nthreads == 0) {
		struct err ee;
		int rc;
		if (p->failed) {
			if (p->ops.drop)
				p->ops.drop(p->ctx, item);
			return failure(p, e);
		}
		err_clear(&ee);
		rc = p->ops.work(p->ctx, item, &ee);
		if (!rc)
			rc = p->ops.emit(p->ctx, item, &ee);
		else if (p->ops.drop)
			p->ops.drop(p->ctx, item);
		if (rc)
			fail(p, rc, &ee);
		return rc ? failure(p, e) : 0;
	}
	pthread_mutex_lock(&p->mu);
	while (!p->failed && p->head - p->tail >= (unsigned long)p->cap) {
		emit_ready(p, 0);
		if (p->head - p->tail >= (unsigned long)p->cap)
			pthread_cond_wait(&p->done_cv, &p->mu);
	}
	if (p->failed) {
		pthread_mutex_unlock(&p->mu);
		if (p->ops.drop)
			p->ops.drop(p->ctx, item);
		return failure(p, e);
	}
	s = &p->slots[p->head % (unsigned long)p->cap];
	s->item = item;
	s->state = SLOT_QUEUED;
	p->head++;
	pthread_cond_signal(&p->work_cv);
	emit_ready(p, 0);
	pthread_mutex_unlock(&p->mu);
	return p->failed ? failure(p, e) : 0;
}

int pipeline_finish(struct pipeline *p, struct err *e)
{
	if (p->nthreads == 0)
		return p->failed ? failure(p, e) : 0;
	pthread_mutex_lock(&p->mu);
	emit_ready(p, 1);
	pthread_mutex_unlock(&p->mu);
	return p->failed ? failure(p, e) : 0;
}

void pipeline_free(struct pipeline *p)
{
	if (!p)
		return;
	pthread_mutex_lock(&p->mu);
	p->stopping = 1;
	pthread_cond_broadcast(&p->work_cv);
	pthread_mutex_unlock(&p->mu);
	for (int i = 0; i < p->started; i++)
		pthread_join(p->threads[i], NULL);
	/* Anything still in flight was never emitted. */
	for (unsigned long q = p->tail; q != p->head; q++) {
		struct slot *s = &p->slots[q % (unsigned long)p->cap];
		if (s->item && p->ops.drop)
			p->ops.drop(p->ctx, s->item);
	}
	pthread_mutex_destroy(&p->mu);
	pthread_cond_destroy(&p->work_cv);
	pthread_cond_destroy(&p->done_cv);
	mem_free(p->slots);
	mem_free(p->threads);
	mem_free(p);
}
