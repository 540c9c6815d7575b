/* supervisor.h - the worker processes of `serve` and of a cluster's
 * `infilld worker`: start N, restart the
 * ones that die (with a back-off against crash loops), stop them all.
 */
#ifndef INFILLD_SERVICE_SUPERVISOR_H
#define INFILLD_SERVICE_SUPERVISOR_H

#include <signal.h>
#include <sys/types.h>

struct service_config;

#define SUPERVISOR_MAX_WORKERS 256

struct supervisor {
	const struct service_config *cfg;
	int argc;
	char **argv;                 /* serve's options, passed on to workers */
	int n;
	struct {
		pid_t pid;           /* 0 = not running */
		char name[32];
		double started_s, restart_at_s;
		int quick_deaths;    /* deaths soon after start, for back-off */
	} w[SUPERVISOR_MAX_WORKERS];
};

/* n workers (at most SUPERVISOR_MAX_WORKERS), each started with argv's
 * options. */
void supervisor_init(struct supervisor *s, const struct service_config *cfg, int n, int argc,
		     char **argv);
/* Start every worker that is due (not running, back-off over). */
void supervisor_start_due(struct supervisor *s);
/* Reap exited workers; for each, dead(name) is called (to re-queue its
 * jobs at once).  Returns the number reaped. */
int supervisor_reap(struct supervisor *s, void (*dead)(void *ctx, const char *name), void *ctx);
int supervisor_alive(const struct supervisor *s);
/* The dead() of supervisor_reap() for ctx = a struct db *: re-queue (or
 * fail) what the dead worker held, at once rather than at lease expiry. */
void supervisor_requeue(void *ctx, const char *name);
/* Block SIGTERM, SIGINT, SIGCHLD and SIGHUP (in *set, for sigtimedwait()
 * by the supervising thread; threads started later inherit the mask) and
 * ignore SIGPIPE. */
void supervisor_block_signals(sigset_t *set);
/* SIGTERM all, wait up to wait_s, then SIGKILL what is left. */
void supervisor_stop(struct supervisor *s, double wait_s);

#endif
