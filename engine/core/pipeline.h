/* pipeline.h - an ordered parallel map with bounded memory.
 *
 * Items are submitted in sequence; `work` runs on pool threads in any
 * order; `emit` runs on the submitting thread strictly in submission
 * order.  At most max_in_flight items exist at once, so memory is bounded
 * by that many layers whatever the layer count.  Used by the output
 * writers (rasterise + PNG-encode, toolpath planning) so a sink is only
 * ever written from one thread.
 */
#ifndef INFILLD_PIPELINE_H
#define INFILLD_PIPELINE_H

struct err;

struct pipeline_ops {
	/* Pool thread, any order.  0 or a negative err_code (fills e). */
	int (*work)(void *ctx, void *item, struct err *e);
	/* Submitting thread, in order, only for items whose work succeeded
	 * while the pipeline has not failed.  Owns the item afterwards. */
	int (*emit)(void *ctx, void *item, struct err *e);
	/* Release an item that will not be emitted (after a failure). */
	void (*drop)(void *ctx, void *item);
};

struct pipeline;

/* threads = 0 runs work inline in pipeline_submit().  max_in_flight >= 1.
 * Caller frees with pipeline_free(). */
int pipeline_new(const struct pipeline_ops *ops, void *ctx, int threads, int max_in_flight,
		 struct pipeline **out, struct err *e);

/* Queue item (ownership passes to the pipeline).  Blocks while
 * max_in_flight items are pending, emitting finished ones meanwhile.
 * After any failure every later call returns that failure (first error
 * wins, copied into e) and drops its item. */
int pipeline_submit(struct pipeline *p, void *item, struct err *e);

/* Wait for all queued work and emit it.  0 or the first failure. */
int pipeline_finish(struct pipeline *p, struct err *e);

/* Stop the threads, dropping anything not emitted.  NULL-safe. */
void pipeline_free(struct pipeline *p);

/* Online CPU count (>= 1). */
int pipeline_cpu_count(void);

#endif
