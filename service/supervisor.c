/* supervisor.c - worker processes of serve and of a cluster's `infilld
 * worker` (see supervisor.h).  Workers are this binary re-executed as
 * `infilld worker ... --worker-name HOST-wN-PID`
 * (posix_spawn, so nothing of the multi-threaded server leaks into them).
 */
#define _GNU_SOURCE /* environ */
#include "service/supervisor.h"
#include "api/log.h"
#include "db/queue.h"
#include "engine/core/progress.h"
#include "service/config.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

void supervisor_init(struct supervisor *s, const struct service_config *cfg, int n, int argc,
		     char **argv)
{
	char host[64] = "host";

	/* Names are unique across the machines of a cluster: the rescuer
	 * re-queues a dead worker's jobs by name. */
	gethostname(host, sizeof host - 1);
	host[sizeof host - 1] = '\0';
	memset(s, 0, sizeof *s);
	s->cfg = cfg;
	s->argc = argc;
	s->argv = argv;
	s->n = n < SUPERVISOR_MAX_WORKERS ? n : SUPERVISOR_MAX_WORKERS;
	for (int i = 0; i < s->n; i++)
		snprintf(s->w[i].name, sizeof s->w[i].name, "%.12s-w%d-%d", host, i, (int)getpid());
}

static void spawn_one(struct supervisor *s, int i)
{
	char **argv = calloc((size_t)s->argc + 4, sizeof *argv);
	sigset_t none;
	posix_spawnattr_t at;
	int k = 0, rc;

	if (!argv)
		return;
	argv[k++] = (char *)s->cfg->self_exe;
	argv[k++] = (char *)"worker";
	for (int a = 1; a < s->argc; a++)
		argv[k++] = s->argv[a];
	argv[k++] = (char *)"--worker-name";
	argv[k++] = s->w[i].name;
	argv[k] = NULL;
	/* Workers start with no signals blocked (serve blocks them). */
	sigemptyset(&none);
	posix_spawnattr_init(&at);
	posix_spawnattr_setsigmask(&at, &none);
	posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK);
	rc = posix_spawn(&s->w[i].pid, s->cfg->self_exe, NULL, &at, argv, environ);
	posix_spawnattr_destroy(&at);
	free(argv);
	if (rc != 0) {
		log_msg(LOG_ERROR, "supervisor", "cannot start worker %s: %s", s->w[i].name,
			strerror(rc));
		s->w[i].pid = 0;
		s->w[i].restart_at_s = progress_now_s() + 5;
		return;
	}
	s->w[i].started_s = progress_now_s();
	log_msg(LOG_DEBUG, "supervisor", "worker %s started (pid %d)", s->w[i].name,
		(int)s->w[i].pid);
}

void supervisor_start_due(struct supervisor *s)
{
	double now = progress_now_s();

	for (int i = 0; i < s->n; i++)
		if (!s->w[i].pid && now >= s->w[i].restart_at_s)
			spawn_one(s, i);
}

int supervisor_reap(struct supervisor *s, void (*dead)(void *ctx, const char *name), void *ctx)
{
	int status, n = 0;

	/* Only our workers: waitpid(-1) would also reap the analysis
	 * children that api/analyze.c threads wait for. */
	for (int i = 0; i < s->n; i++) {
		double now = progress_now_s(), backoff;
		pid_t pid = s->w[i].pid;
		if (!pid || waitpid(pid, &status, WNOHANG) != pid)
			continue;
		s->w[i].pid = 0;
		n++;
		if (WIFSIGNALED(status))
			log_msg(LOG_WARN, "supervisor", "worker %s (pid %d) killed by signal %d",
				s->w[i].name, (int)pid, WTERMSIG(status));
		else
			log_msg(LOG_WARN, "supervisor", "worker %s (pid %d) exited with %d", s->w[i].name,
				(int)pid, WEXITSTATUS(status));
		dead(ctx, s->w[i].name);
		/* Fresh name: a late write of the dead one stays fenced by the
		 * attempt number anyway; the name keeps logs clear. */
		snprintf(s->w[i].name, sizeof s->w[i].name, "w%d-%d-%ld", i, (int)getpid(),
			 (long)(now * 1000) % 100000);
		s->w[i].quick_deaths = now - s->w[i].started_s < 5 ? s->w[i].quick_deaths + 1 : 0;
		backoff = s->w[i].quick_deaths
				  ? 0.5 * (1 << (s->w[i].quick_deaths < 6 ? s->w[i].quick_deaths : 6))
				  : 0;
		s->w[i].restart_at_s = now + backoff;
	}
	return n;
}

int supervisor_alive(const struct supervisor *s)
{
	int n = 0;

	for (int i = 0; i < s->n; i++)
		n += s->w[i].pid != 0;
	return n;
}

void supervisor_stop(struct supervisor *s, double wait_s)
{
	double deadline = progress_now_s() + wait_s;
	struct timespec ts = {0, 50 * 1000 * 1000};

	for (int i = 0; i < s->n; i++)
		if (s->w[i].pid)
			kill(s->w[i].pid, SIGTERM);
	while (supervisor_alive(s) && progress_now_s() < deadline) {
		for (int i = 0; i < s->n; i++)
			if (s->w[i].pid && waitpid(s->w[i].pid, NULL, WNOHANG) == s->w[i].pid)
				s->w[i].pid = 0;
		nanosleep(&ts, NULL);
	}
	for (int i = 0; i < s->n; i++)
		if (s->w[i].pid) {
			log_msg(LOG_WARN, "supervisor", "worker %s did not stop; killing it",
				s->w[i].name);
			kill(s->w[i].pid, SIGKILL);
			waitpid(s->w[i].pid, NULL, 0);
			s->w[i].pid = 0;
		}
}

void supervisor_requeue(void *ctx, const char *name)
{
	struct db *db = ctx;
	struct err e;
	int n = 0;

	err_clear(&e);
	if (queue_rescue(db, name, &n, &e))
		log_msg(LOG_ERROR, "supervisor", "re-queueing jobs of %s: %s", name, e.msg);
	else if (n)
		log_msg(LOG_WARN, "supervisor", "worker %s died holding %d job(s); re-queued", name,
			n);
}

void supervisor_block_signals(sigset_t *set)
{
	sigemptyset(set);
	sigaddset(set, SIGTERM);
	sigaddset(set, SIGINT);
	sigaddset(set, SIGCHLD);
	sigaddset(set, SIGHUP);
	pthread_sigmask(SIG_BLOCK, set, NULL);
	signal(SIGPIPE, SIG_IGN);
}
