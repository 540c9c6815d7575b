/* worker.c - `infilld worker`.  With --worker-name (a child of serve's or
 * of a cluster worker's supervisor) it claims jobs from the queue and
 * runs each attempt in a forked job process
 * (jobproc.c), relaying its progress to the database, renewing the lease,
 * enforcing the wall-clock limit, stopping it on cancellation, and
 * recording how it ended.  Every write is fenced by (job, attempt).
 */
#define _GNU_SOURCE /* prctl */
#include "api/log.h"
#include "db/db.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "db/store.h"
#include "db/tenants.h"
#include "engine/engine.h"
#include "engine/core/progress.h"
#include "service/commands.h"
#include "service/config.h"
#include "service/jobproc.h"
#include "service/supervisor.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static volatile sig_atomic_t worker_stopping;

static void on_term(int sig)
{
	(void)sig;
	worker_stopping = 1;
}

struct attempt {
	const struct service_config *cfg;
	struct db *db;
	struct job_row *job;
	pid_t pid;
	int fd;
	struct buf in;            /* bytes read from the pipe */
	struct jobmsg_progress last;
	int have_progress, progress_dirty;
	int have_result;
	struct jobmsg_result result;
	char *metrics;
	int lost;                 /* fenced write refused: not ours any more */
	int timed_out, shutdown;
	double stop_sent_s;       /* when SIGUSR1 went out */
	double stop_seen_s;       /* when the worker was told to stop */
	const char *mesh_path;    /* the job's input, named ... */
	char mesh_name[128];      /* ... by the client's name in messages */
};

/* Parse complete records from a->in. */
static void take_messages(struct attempt *a)
{
	size_t off = 0;

	while (a->in.len - off >= sizeof(struct jobmsg_head)) {
		struct jobmsg_head h;
		memcpy(&h, a->in.data + off, sizeof h);
		if (h.len > (64u << 20)) {
			off = a->in.len; /* garbage: ignore the rest */
			break;
		}
		if (a->in.len - off - sizeof h < h.len)
			break;
		if (h.type == JOBMSG_PROGRESS && h.len == sizeof a->last) {
			memcpy(&a->last, a->in.data + off + sizeof h, sizeof a->last);
			a->last.stage[sizeof a->last.stage - 1] = '\0';
			a->have_progress = a->progress_dirty = 1;
		} else if (h.type == JOBMSG_RESULT && h.len >= sizeof a->result) {
			size_t ml = h.len - sizeof a->result;
			memcpy(&a->result, a->in.data + off + sizeof h, sizeof a->result);
			a->result.message[sizeof a->result.message - 1] = '\0';
			a->result.field[sizeof a->result.field - 1] = '\0';
			a->result.type[sizeof a->result.type - 1] = '\0';
			a->result.sha256[sizeof a->result.sha256 - 1] = '\0';
			free(a->metrics);
			a->metrics = malloc(ml + 1);
			if (a->metrics) {
				memcpy(a->metrics, a->in.data + off + sizeof h + sizeof a->result, ml);
				a->metrics[ml] = '\0';
			}
			a->have_result = 1;
		}
		off += sizeof h + h.len;
	}
	if (off) {
		memmove(a->in.data, a->in.data + off, a->in.len - off);
		a->in.len -= off;
	}
}

static void read_pipe(struct attempt *a)
{
	char chunk[8192];
	ssize_t n;

	while ((n = read(a->fd, chunk, sizeof chunk)) > 0)
		buf_append(&a->in, chunk, (size_t)n);
	take_messages(a);
}

static const char *signal_name(int sig)
{
	switch (sig) {
	case SIGSEGV: return "SIGSEGV";
	case SIGBUS: return "SIGBUS";
	case SIGABRT: return "SIGABRT";
	case SIGFPE: return "SIGFPE";
	case SIGILL: return "SIGILL";
	case SIGKILL: return "SIGKILL";
	case SIGXCPU: return "SIGXCPU";
	case SIGXFSZ: return "SIGXFSZ";
	default: return "a signal";
	}
}

/* Record how the attempt ended. */
static void finish(struct attempt *a, int status)
{
	const struct service_config *c = a->cfg;
	struct job_row *j = a->job;
	struct job_failure f = {NULL, NULL, "", 0};
	char msg[ERR_MSG_MAX + 256], redacted[ERR_MSG_MAX + 256];
	char tmp[STORE_PATH_MAX], final_path[STORE_PATH_MAX], name[128];
	struct err e;
	int rc;

	err_clear(&e);
	store_tmp_path(c->store_dir, "", tmp, sizeof tmp);
	snprintf(tmp + strlen(tmp), sizeof tmp - strlen(tmp), "%s-a%d.part", j->id, j->attempt);
	if (a->lost) {
		unlink(tmp);
		log_msg(LOG_INFO, "worker", "job %s attempt %d stopped (cancelled or taken over)",
			j->id, j->attempt);
		return;
	}
	if (a->have_result && a->result.code == 0 && WIFEXITED(status)) {
		enum out_format fmt;
		struct job_artifact art;
		if (out_format_parse(j->format, &fmt, &e) != 0)
			fmt = OUT_ZIP;
		snprintf(name, sizeof name, "%s-a%d%s", j->id, j->attempt, out_format_extension(fmt));
		store_artifact_path(c->store_dir, j->tenant_id, name, final_path, sizeof final_path);
		rc = store_publish(tmp, final_path, &e);
		if (rc) {
			f.type = "io";
			f.message = e.msg;
			f.retryable = 1;
			unlink(tmp);
			goto fail;
		}
		art.name = name;
		art.bytes = (int64_t)a->result.bytes;
		art.sha256 = a->result.sha256;
		art.mesh_name = a->mesh_name;
		rc = queue_succeed(a->db, j->seq, j->attempt, &art, a->metrics, &e);
		if (rc == ERR_LIMIT) {
			/* Another output of the tenant took the room meanwhile. */
			unlink(final_path);
			snprintf(msg, sizeof msg, "%s", e.msg);
			f.type = "quota";
			f.message = msg;
			goto fail;
		}
		if (rc != 1) {
			unlink(final_path); /* fenced out (or the db failed): not ours */
			log_msg(rc < 0 ? LOG_ERROR : LOG_INFO, "worker",
				"job %s attempt %d finished but was not recorded%s%s", j->id, j->attempt,
				rc < 0 ? ": " : " (cancelled meanwhile)", rc < 0 ? e.msg : "");
		} else {
			log_msg(LOG_INFO, "worker", "job %s attempt %d succeeded (%llu bytes)", j->id,
				j->attempt, (unsigned long long)a->result.bytes);
		}
		return;
	}
	unlink(tmp);
	if (a->shutdown) {
		f.type = "shutdown";
		f.message = "the service stopped while the job ran; it will run again";
		f.retryable = 1;
	} else if (a->timed_out) {
		snprintf(msg, sizeof msg, "the job ran longer than the %d s wall-clock limit",
			 c->job_timeout_s);
		f.type = "limit";
		f.message = msg;
	} else if (a->have_result) {
		f.type = a->result.type;
		f.field = a->result.field;
		f.message = a->result.message;
		if (a->result.code == ERR_NOMEM) {
			snprintf(msg, sizeof msg, "memory limit of %d MB exceeded (%s)", c->job_mem_mb,
				 a->result.message);
			f.type = "limit";
			f.message = msg;
		}
		f.retryable = a->result.code == ERR_IO;
	} else if (WIFSIGNALED(status)) {
		int sig = WTERMSIG(status);
		f.type = sig == SIGXCPU || sig == SIGXFSZ ? "limit" : "signal";
		if (sig == SIGXCPU)
			snprintf(msg, sizeof msg, "CPU time limit of %d s exceeded (SIGXCPU)", c->job_cpu_s);
		else if (sig == SIGXFSZ)
			snprintf(msg, sizeof msg, "output size limit of %d MB exceeded (SIGXFSZ)",
				 c->output_limit_mb);
		else
			snprintf(msg, sizeof msg, "the job process was killed by %s (signal %d)%s",
				 signal_name(sig), sig,
				 sig == SIGKILL ? ", probably by the kernel's out-of-memory killer" : "");
		f.message = msg;
		/* A crash on the same input repeats; an outside SIGKILL may not. */
		f.retryable = sig == SIGKILL;
	} else {
		snprintf(msg, sizeof msg, "the job process exited with status %d without a result",
			 WEXITSTATUS(status));
		f.type = "internal";
		f.message = msg;
	}
fail:
	/* Messages name our files (the mesh by its id, the .part file, the
	 * data directory); the client knows the mesh by its own name. */
	if (f.message != redacted) {
		snprintf(redacted, sizeof redacted, "%s", f.message);
		store_redact(redacted, sizeof redacted, NULL, tmp, "the output");
		store_redact(redacted, sizeof redacted, c->store_dir, a->mesh_path, a->mesh_name);
		f.message = redacted;
	}
	rc = queue_fail(a->db, j->seq, j->attempt, &f, &e);
	log_msg(LOG_INFO, "worker", "job %s attempt %d failed (%s: %s)%s", j->id, j->attempt, f.type,
		f.message, rc == 1 ? "" : " - not recorded, job no longer ours");
}

/* Relay progress, heartbeat, watch limits until the child exits. */
static void supervise(struct attempt *a)
{
	const struct service_config *c = a->cfg;
	double start = progress_now_s(), last_write = start - 1.0, now; /* first report at once */
	double beat_s = c->lease_s / 3.0 > 0.5 ? c->lease_s / 3.0 : 0.5;
	int64_t lease_ms = (int64_t)c->lease_s * 1000;
	struct err e;
	int status = 0;

	for (;;) {
		struct pollfd pf = {a->fd, POLLIN, 0};
		pid_t w;

		poll(&pf, 1, 200);
		read_pipe(a);
		w = waitpid(a->pid, &status, WNOHANG);
		if (w == a->pid) {
			read_pipe(a);
			break;
		}
		now = progress_now_s();
		if (!a->lost && !a->timed_out && !a->shutdown &&
		    ((a->progress_dirty && now - last_write >= 0.25) || now - last_write >= beat_s)) {
			int rc;
			if (a->progress_dirty) {
				struct job_progress p = {a->last.stage, a->last.fraction,
							 a->last.layers_done, a->last.layers_total};
				rc = queue_progress(a->db, a->job->seq, a->job->attempt, &p, lease_ms, &e);
				a->progress_dirty = 0;
			} else {
				rc = queue_heartbeat(a->db, a->job->seq, a->job->attempt, lease_ms, &e);
			}
			last_write = now;
			if (rc == 0) {
				a->lost = 1;
			} else if (rc < 0) {
				log_msg(LOG_WARN, "worker", "job %s: %s", a->job->id, e.msg);
			}
		}
		if (!a->timed_out && now - start > c->job_timeout_s)
			a->timed_out = 1;
		if (worker_stopping && !a->shutdown) {
			/* SIGTERM: let the job finish within the drain time. */
			if (a->stop_seen_s == 0)
				a->stop_seen_s = now;
			if (now - a->stop_seen_s >= c->drain_s)
				a->shutdown = 1;
		}
		if ((a->lost || a->timed_out || a->shutdown) && a->stop_sent_s == 0) {
			kill(a->pid, SIGUSR1); /* cooperative stop */
			a->stop_sent_s = now;
		}
		if (a->stop_sent_s > 0 && now - a->stop_sent_s > 3.0)
			kill(a->pid, SIGKILL);
	}
	finish(a, status);
}

static void run_attempt(const struct service_config *c, struct db *db, struct job_row *j)
{
	struct attempt a;
	struct mesh_rec m;
	struct jobproc_args args;
	struct tenant t;
	char mesh_path[STORE_PATH_MAX], tmp[STORE_PATH_MAX];
	int p[2];
	struct err e;

	memset(&a, 0, sizeof a);
	a.cfg = c;
	a.db = db;
	a.job = j;
	buf_init(&a.in);
	if (db_mesh_get(db, j->tenant_id, j->mesh_id, &m, &e) != 0) {
		struct job_failure f = {"not_found", "the job's mesh was deleted", "mesh_id", 0};
		queue_fail(db, j->seq, j->attempt, &f, &e);
		return;
	}
	store_mesh_path(c->store_dir, j->tenant_id, m.id, m.format, mesh_path, sizeof mesh_path);
	a.mesh_path = mesh_path;
	snprintf(a.mesh_name, sizeof a.mesh_name, "%s", m.name);
	db_mesh_rec_fini(&m);
	store_tmp_path(c->store_dir, "", tmp, sizeof tmp);
	snprintf(tmp + strlen(tmp), sizeof tmp - strlen(tmp), "%s-a%d.part", j->id, j->attempt);
	if (pipe2(p, O_CLOEXEC) != 0) {
		struct job_failure f = {"io", "cannot create a pipe", "", 1};
		queue_fail(db, j->seq, j->attempt, &f, &e);
		return;
	}
	memset(&args, 0, sizeof args);
	if (db_tenant_get_id(db, j->tenant_id, &t, &e) == 0 && t.quota_bytes > 0) {
		args.quota_bytes = t.quota_bytes;
		args.quota_left_bytes = t.quota_bytes > t.used_bytes ? t.quota_bytes - t.used_bytes : 0;
		if (args.quota_left_bytes == 0) {
			char msg[160];
			struct job_failure f = {"quota", msg, "", 0};
			snprintf(msg, sizeof msg,
				 "the tenant's storage quota of %lld bytes is used up (%lld in use)",
				 (long long)t.quota_bytes, (long long)t.used_bytes);
			close(p[0]);
			close(p[1]);
			queue_fail(db, j->seq, j->attempt, &f, &e);
			return;
		}
	}
	store_output_name(a.mesh_name, j->id, args.output_name, sizeof args.output_name);
	args.cfg = c;
	args.job = j;
	args.mesh_path = mesh_path;
	args.out_tmp = tmp;
	args.fd = p[1];
	log_msg(LOG_INFO, "worker", "job %s attempt %d: %s -> %s (%s)", j->id, j->attempt,
		j->engine, j->format, j->printer);
	a.pid = fork();
	if (a.pid == 0) {
		close(p[0]);
		jobproc_main(&args);
	}
	close(p[1]);
	if (a.pid < 0) {
		struct job_failure f = {"io", "cannot fork the job process", "", 1};
		close(p[0]);
		queue_fail(db, j->seq, j->attempt, &f, &e);
		return;
	}
	a.fd = p[0];
	fcntl(a.fd, F_SETFL, fcntl(a.fd, F_GETFL) | O_NONBLOCK);
	supervise(&a);
	close(a.fd);
	buf_fini(&a.in);
	free(a.metrics);
}

/* Is the store there to write to?  Probed when idle at most every 2 s (a
 * file create + fsync on a network file system is not free) and after
 * every attempt (recheck), since a store that vanished shows first as an
 * attempt failing; a worker whose store is gone claims nothing until it
 * is back. */
static int store_usable(const struct service_config *c, int recheck)
{
	static double last_s = -1e9;
	static int ok = 1;
	double now = progress_now_s();

	if (recheck || now - last_s >= 2.0) {
		struct err e;
		int was = ok;
		err_clear(&e);
		ok = store_check(c->store_dir, &e) == 0;
		if (!ok && was)
			log_msg(LOG_ERROR, "worker", "%s; not claiming jobs until it is back", e.msg);
		else if (ok && !was)
			log_msg(LOG_INFO, "worker", "store %s is back", c->store_dir);
		last_s = now;
	}
	return ok;
}

/* One worker process: claim, run, repeat (started by a supervisor). */
static int worker_child(struct service_config *c)
{
	struct sigaction sa;
	struct db *db;
	struct err e;
	pid_t parent = getppid();
	int ran = 0;

	/* Die with the supervisor: a worker without it would run jobs nobody
	 * watches. */
	prctl(PR_SET_PDEATHSIG, SIGTERM);
	if (getppid() != parent)
		return 1;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_term;
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
	err_clear(&e);
	if (db_open(c->db_url, &db, &e)) {
		log_msg(LOG_ERROR, "worker", "%s", e.msg);
		return 1;
	}
	log_msg(LOG_DEBUG, "worker", "%s ready", c->worker_name);
	while (!worker_stopping) {
		struct job_row j;
		int got = 0;

		if (store_usable(c, ran) &&
		    queue_claim(db, c->worker_name, (int64_t)c->lease_s * 1000, &j, &got, &e)) {
			log_msg(LOG_WARN, "worker", "claim: %s", e.msg);
			got = 0;
		}
		ran = got;
		if (got) {
			run_attempt(c, db, &j);
			queue_job_row_fini(&j);
			continue;
		}
		{
			/* Idle: poll the queue every 100-200 ms (jittered so workers
			 * do not claim in lock-step). */
			struct timespec ts = {0, (100 + rand() % 100) * 1000 * 1000};
			nanosleep(&ts, NULL);
		}
	}
	db_close(db);
	return 0;
}

/* `infilld worker` as people start it on a cluster's machines: --slots
 * worker processes (supervisor.c), the rescuer for expired leases, no
 * HTTP; SIGTERM drains like serve's. */
static int worker_main(struct service_config *c, int argc, char **argv)
{
	struct supervisor sup;
	char shown[256];
	sigset_t set;
	struct db *db;
	struct err e;
	int n;

	err_clear(&e);
	if (store_init(c->data_dir, &e) || store_init(c->store_dir, &e)) {
		fprintf(stderr, "infilld worker: %s\n", e.msg);
		return 1;
	}
	db_url_redact(c->db_url, shown, sizeof shown);
	if (db_open(c->db_url, &db, &e)) {
		fprintf(stderr, "infilld worker: %s: %s\n", shown, e.msg);
		return 1;
	}
	supervisor_block_signals(&set);
	supervisor_init(&sup, c, c->slots, argc, argv);
	supervisor_start_due(&sup);
	printf("infilld %s: worker with %d slot(s) (db %s, store %s)\n", INFILLD_VERSION, c->slots,
	       shown, c->store_dir);
	fflush(stdout);
	for (;;) {
		struct timespec ts = {1, 0};
		int sig = sigtimedwait(&set, NULL, &ts);
		if (sig == SIGTERM || sig == SIGINT)
			break;
		supervisor_reap(&sup, supervisor_requeue, db);
		supervisor_start_due(&sup);
		if (queue_rescue(db, NULL, &n, &e) == 0 && n)
			log_msg(LOG_WARN, "worker", "%d job lease(s) expired; re-queued or failed", n);
	}
	log_msg(LOG_INFO, "worker", "stopping: draining jobs for up to %d s", c->drain_s);
	supervisor_stop(&sup, c->drain_s + 10.0);
	db_close(db);
	return 0;
}

int cmd_worker(int argc, char **argv)
{
	struct service_config c;
	int rc = config_parse(&c, argc, argv, 1);

	if (rc)
		return rc == CONFIG_HELP ? 0 : rc;
	return c.worker_name[0] ? worker_child(&c) : worker_main(&c, argc, argv);
}
