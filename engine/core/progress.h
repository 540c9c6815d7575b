/* progress.h - progress reporting and cooperative cancellation.
 *
 * A run is a sequence of stages ("read", "prepare", "tetgen", "layers",
 * ...), each owning a slice [lo, hi] of the overall 0..1 fraction.  Code
 * in long loops calls progress_update(); it maps the stage fraction to
 * the overall one (never decreasing), throttles the callback and polls
 * the cancel hook.  Only the thread that runs the job may call these;
 * engine helper threads report through their owner.
 */
#ifndef INFILLD_PROGRESS_H
#define INFILLD_PROGRESS_H

struct err;

struct progress_info {
	const char *stage;     /* static string */
	double fraction;       /* overall, 0..1, monotonic */
	double stage_fraction; /* within the stage, 0..1 */
	int layers_done;       /* layers written so far */
	int layers_total;      /* 0 until known */
};

struct progress_hooks {
	/* Called at most every ~0.5% / 200 ms and on every stage change.
	 * May be NULL. */
	void (*report)(void *ctx, const struct progress_info *info);
	/* Nonzero when the job should stop.  May be NULL. */
	int (*cancelled)(void *ctx);
	void *ctx;
};

struct progress {
	struct progress_hooks hooks;
	struct progress_info info;
	double lo, hi;          /* current stage's slice of the overall fraction */
	double last_fraction;   /* last reported overall fraction */
	double last_report_s;   /* monotonic clock of the last report */
};

/* hooks may be NULL (silent, never cancelled). */
void progress_init(struct progress *p, const struct progress_hooks *hooks);

/* Enter a stage covering [lo, hi] of the overall fraction (clamped so the
 * overall fraction never goes back).  Always reports. */
void progress_stage(struct progress *p, const char *stage, double lo, double hi);

/* Advance within the current stage (0..1).  Returns 0, or ERR_CANCELLED
 * (with e filled) when the cancel hook says stop. */
int progress_update(struct progress *p, double stage_fraction, struct err *e);

/* Record layer counts (reported with the next update). */
void progress_layers(struct progress *p, int done, int total);

/* Monotonic clock in seconds (for stage timings in metrics). */
double progress_now_s(void);

#endif
