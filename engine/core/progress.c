/* progress.c - progress reporting and cancellation (see progress.h). */
#include "engine/core/progress.h"
#include "engine/core/err.h"

#include <string.h>
#include <time.h>

double progress_now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static void report(struct progress *p)
{
	p->last_fraction = p->info.fraction;
	p->last_report_s = progress_now_s();
	if (p->hooks.report)
		p->hooks.report(p->hooks.ctx, &p->info);
}

void progress_init(struct progress *p, const struct progress_hooks *hooks)
{
	memset(p, 0, sizeof *p);
	if (hooks)
		p->hooks = *hooks;
	p->info.stage = "start";
	p->hi = 1.0;
}

void progress_stage(struct progress *p, const char *stage, double lo, double hi)
{
	if (lo < p->info.fraction)
		lo = p->info.fraction;
	if (hi < lo)
		hi = lo;
	if (hi > 1.0)
		hi = 1.0;
	p->lo = lo;
	p->hi = hi;
	p->info.stage = stage;
	p->info.stage_fraction = 0.0;
	p->info.fraction = lo;
	report(p);
}

int progress_update(struct progress *p, double f, struct err *e)
{
	double overall;

	if (p->hooks.cancelled && p->hooks.cancelled(p->hooks.ctx))
		return ERR_SET(e, ERR_CANCELLED, "cancelled during stage '%s'", p->info.stage);
	if (!(f >= 0.0)) /* also catches NaN */
		f = 0.0;
	if (f > 1.0)
		f = 1.0;
	p->info.stage_fraction = f;
	overall = p->lo + (p->hi - p->lo) * f;
	if (overall > p->info.fraction)
		p->info.fraction = overall;
	if (p->info.fraction - p->last_fraction >= 0.005 ||
	    progress_now_s() - p->last_report_s >= 0.2 || f >= 1.0)
		report(p);
	return 0;
}

void progress_layers(struct progress *p, int done, int total)
{
	p->info.layers_done = done;
	p->info.layers_total = total;
}
