/* jobproc.c - the job process (see jobproc.h). */
#define _GNU_SOURCE /* prctl */
#include "service/jobproc.h"
#include "api/api_json.h"
#include "db/queue.h"
#include "db/tenants.h"
#include "engine/engine.h"
#include "service/config.h"
#include "service/rlimits.h"

#include <errno.h>
#include <fcntl.h>
#include <nettle/sha2.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

static volatile sig_atomic_t stop_requested;

static void on_usr1(int sig)
{
	(void)sig;
	stop_requested = 1;
}

struct jp {
	int fd;
	int out_fd;
	struct sha256_ctx sha;
};

/* Write everything to fd (the report pipe): 0 or -1. */
static int write_full(int fd, const void *p, size_t len)
{
	struct sink s;
	struct err e;

	sink_init_fd(&s, fd);
	return sink_write(&s, p, len, &e) ? -1 : 0;
}

static void on_report(void *ctx, const struct progress_info *info)
{
	struct jp *jp = ctx;
	struct {
		struct jobmsg_head h;
		struct jobmsg_progress p;
	} m;

	memset(&m, 0, sizeof m);
	m.h.type = JOBMSG_PROGRESS;
	m.h.len = sizeof m.p;
	m.p.fraction = info->fraction;
	m.p.layers_done = info->layers_done;
	m.p.layers_total = info->layers_total;
	snprintf(m.p.stage, sizeof m.p.stage, "%s", info->stage ? info->stage : "");
	/* Atomic (< PIPE_BUF); dropped if the worker lags (non-blocking). */
	if (write(jp->fd, &m, sizeof m) < 0) {
		/* the next report carries the same information */
	}
}

static int on_cancelled(void *ctx)
{
	(void)ctx;
	return stop_requested;
}

/* Output sink: write to the .part file, hashing on the way. */
static int out_write(void *ctx, const void *buf, size_t len, struct err *e)
{
	struct jp *jp = ctx;

	struct sink fd_sink;

	sha256_update(&jp->sha, len, buf);
	sink_init_fd(&fd_sink, jp->out_fd);
	if (sink_write(&fd_sink, buf, len, e))
		return errno == EFBIG ? ERR_SET(e, ERR_LIMIT, "output size limit reached") : e->code;
	return 0;
}

/* type: the failure's error.type, NULL = the error code's name. */
static void send_result(int fd, const struct err *e, const char *type, uint64_t bytes,
			const char *sha, const char *metrics)
{
	struct jobmsg_result r;
	struct jobmsg_head h;
	size_t ml = metrics ? strlen(metrics) : 0;
	int flags = fcntl(fd, F_GETFL);

	memset(&r, 0, sizeof r);
	r.code = e ? e->code : 0;
	if (e && e->code) {
		snprintf(r.type, sizeof r.type, "%s", type ? type : err_code_name(e->code));
		err_format(e, r.message, sizeof r.message);
		snprintf(r.field, sizeof r.field, "%s", e->field);
	}
	r.bytes = bytes;
	snprintf(r.sha256, sizeof r.sha256, "%s", sha ? sha : "");
	h.type = JOBMSG_RESULT;
	h.len = (uint32_t)(sizeof r + ml);
	fcntl(fd, F_SETFL, flags & ~O_NONBLOCK); /* the result must arrive */
	if (write_full(fd, &h, sizeof h) || write_full(fd, &r, sizeof r) ||
	    (ml && write_full(fd, metrics, ml)))
		_exit(3);
}

/* Test-only failure modes, honoured only with INFILLD_FAULT_INJECTION=1
 * (the API refuses the field otherwise).  Each imitates what a broken
 * engine or a hostile mesh could do. */
static void inject_fault(const char *fault, struct progress_hooks *hooks, int fd)
{
	struct progress p;
	struct err e;

	if (!fault[0])
		return;
	err_clear(&e);
	progress_init(&p, hooks);
	progress_stage(&p, "fault", 0.0, 0.5);
	if (!strcmp(fault, "segv")) {
		raise(SIGSEGV);
	} else if (!strcmp(fault, "alloc")) {
		/* Grow until the address-space limit refuses, as an engine
		 * that builds too big a structure would; touch every page. */
		size_t chunk = 64u << 20, total = 0;
		for (;;) {
			char *m = malloc(chunk);
			if (!m)
				break;
			memset(m, 1, chunk);
			total += chunk;
		}
		ERR_SET(&e, ERR_NOMEM, "out of memory after %zu MB", total >> 20);
		send_result(fd, &e, NULL, 0, NULL, NULL);
		_exit(0);
	} else if (!strcmp(fault, "hang")) {
		/* Cooperative: polls the cancel hook like an engine's loop. */
		struct timespec ts = {0, 50 * 1000 * 1000};
		err_clear(&e);
		for (int i = 0;; i++) {
			if (progress_update(&p, 1.0 - 1.0 / (1.0 + i * 0.01), &e)) {
				send_result(fd, &e, NULL, 0, NULL, NULL);
				_exit(0);
			}
			nanosleep(&ts, NULL);
		}
	} else if (!strcmp(fault, "cpu")) {
		volatile unsigned long x = 0; /* spins, ignoring the cancel hook */
		for (;;)
			x++;
	}
}

void jobproc_main(const struct jobproc_args *a)
{
	const struct service_config *c = a->cfg;
	const struct job_row *j = a->job;
	struct progress_hooks hooks;
	struct job_spec js;
	char scratch[4096];
	const char *slash;
	struct metrics m;
	struct sink sink;
	struct jp jp;
	struct err e;
	json_t *params = NULL;
	char *metrics_text = NULL;
	unsigned char digest[32];
	char sha[65];
	int rc, quota_hit = 0;

	/* Die with the worker; stop on SIGUSR1; EFBIG instead of SIGXFSZ. */
	prctl(PR_SET_PDEATHSIG, SIGKILL);
	signal(SIGUSR1, on_usr1);
	signal(SIGTERM, SIG_DFL);
	signal(SIGINT, SIG_IGN);
	signal(SIGXFSZ, SIG_IGN);
	signal(SIGPIPE, SIG_IGN);
	rlimit_set(RLIMIT_AS, (uint64_t)c->job_mem_mb << 20, 0);
	rlimit_set(RLIMIT_CPU, (uint64_t)c->job_cpu_s, 5);
	rlimit_set(RLIMIT_FSIZE, ((uint64_t)c->output_limit_mb << 20) + (1u << 20), 0);
	rlimit_set(RLIMIT_CORE, 0, 0);
	memset(&jp, 0, sizeof jp);
	jp.fd = a->fd;
	fcntl(jp.fd, F_SETFL, fcntl(jp.fd, F_GETFL) | O_NONBLOCK);
	hooks.report = on_report;
	hooks.cancelled = on_cancelled;
	hooks.ctx = &jp;
	if (c->fault_injection)
		inject_fault(j->fault, &hooks, a->fd);

	err_clear(&e);
	metrics_init(&m);
	rc = job_spec_init(&js, j->engine, j->format, j->printer, &e);
	if (!rc && j->params) {
		json_error_t jerr;
		params = json_loads(j->params, 0, &jerr);
		rc = params ? api_params_apply(&js, params, 0, &e)
			    : ERR_SET(&e, ERR_INTERNAL, "stored parameters unreadable: %s", jerr.text);
	}
	if (!rc) {
		js.input_path = a->mesh_path;
		js.threads = c->job_threads;
		js.output_limit_bytes = (uint64_t)c->output_limit_mb << 20;
		js.job_name = a->output_name;
		js.created_unix = j->created_ms / 1000;
		/* Temporary files beside the artifact, inside the data directory. */
		slash = strrchr(a->out_tmp, '/');
		snprintf(scratch, sizeof scratch, "%.*s", slash ? (int)(slash - a->out_tmp) : 1,
			 slash ? a->out_tmp : ".");
		js.scratch_dir = scratch;
		rc = job_spec_validate(&js, &e);
	}
	if (!rc) {
		jp.out_fd = open(a->out_tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
		if (jp.out_fd < 0)
			rc = ERR_SET(&e, ERR_IO, "cannot create %s: %s", a->out_tmp, strerror(errno));
	}
	if (!rc) {
		sha256_init(&jp.sha);
		sink.write = out_write;
		sink.ctx = &jp;
		sink.bytes = 0;
		sink.limit = js.output_limit_bytes;
		/* The tenant's quota bounds the output too: the job stops once
		 * its output would pass it (error type "quota"). */
		if (a->quota_bytes > 0 && (uint64_t)a->quota_left_bytes < sink.limit)
			sink.limit = (uint64_t)a->quota_left_bytes;
		rc = engine_run(&js, &sink, &hooks, &m, &e);
		if (rc == ERR_LIMIT && sink.limit < js.output_limit_bytes) {
			err_clear(&e);
			rc = ERR_SET(&e, ERR_LIMIT,
				     "the output would take the tenant past its storage quota of %lld "
				     "bytes (%lld bytes were left)",
				     (long long)a->quota_bytes, (long long)a->quota_left_bytes);
			quota_hit = 1;
		}
		if (!rc && fsync(jp.out_fd) != 0)
			rc = ERR_SET(&e, ERR_IO, "fsync output: %s", strerror(errno));
		close(jp.out_fd);
	}
	if (!rc) {
		json_t *mj = api_metrics_json(&m);
		metrics_text = mj ? json_dumps(mj, JSON_COMPACT) : NULL;
		json_decref(mj);
		sha256_digest(&jp.sha, sizeof digest, digest);
		db_sha256_hex(digest, sha);
		send_result(a->fd, NULL, NULL, sink.bytes, sha, metrics_text ? metrics_text : "{}");
	} else {
		send_result(a->fd, &e, quota_hit ? "quota" : NULL, 0, NULL, NULL);
	}
	/* No cleanup needed: the process ends here. */
	_exit(0);
}
