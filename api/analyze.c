/* analyze.c - mesh analysis for uploads, off the HTTP threads and out of
 * the server's address space.
 *
 * Reading a hostile mesh is engine work, so it runs in a child process
 * (`infilld sandbox --as-mb N --cpu-s N -- analyze FILE`, which applies
 * rlimits and then runs the CLI's analyze) spawned by one of two pool
 * threads; the upload's connection stays parked meanwhile.  A crash, a
 * hang (wall timeout) or a limit in the child fails only that upload.
 * The same threads run other file work that must not block an HTTP
 * thread (api_offload(): output.c's whole-file digest before a Range).
 */
#define _GNU_SOURCE /* pipe2, strcasestr */
#include "api/api_internal.h"
#include "api/log.h"
#include "api/upload.h"
#include "engine/core/err.h"
#include "engine/core/progress.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>


struct analyze_task {
	struct api_req *req;
	void (*fn)(struct api_req *);
	struct analyze_task *next;
};

#define ANALYZE_OUT_MAX (4u << 20)
#define ANALYZE_ERR_MAX 4096u

int api_analyze_run(const struct api_config *c, const char *path, struct analyze_result *res)
{
	char as[32], cpu[32];
	char *argv[12];
	int out_p[2] = {-1, -1}, err_p[2] = {-1, -1}, argc = 0, status = 0, rc = -1;
	posix_spawn_file_actions_t fa;
	pid_t pid;
	double deadline;
	struct buf *bufs[2] = {&res->out, &res->err};

	memset(res, 0, sizeof *res);
	buf_init(&res->out);
	buf_init(&res->err);
	snprintf(as, sizeof as, "--as-mb=%d", c->analyze_mem_mb);
	snprintf(cpu, sizeof cpu, "--cpu-s=%d", c->analyze_timeout_s);
	argv[argc++] = (char *)c->self_exe;
	argv[argc++] = (char *)"sandbox";
	argv[argc++] = as;
	argv[argc++] = cpu;
	argv[argc++] = (char *)"--";
	argv[argc++] = (char *)"analyze";
	argv[argc++] = (char *)path;
	argv[argc] = NULL;
	if (pipe2(out_p, O_CLOEXEC) || pipe2(err_p, O_CLOEXEC))
		goto out;
	posix_spawn_file_actions_init(&fa);
	posix_spawn_file_actions_adddup2(&fa, out_p[1], STDOUT_FILENO);
	posix_spawn_file_actions_adddup2(&fa, err_p[1], STDERR_FILENO);
	posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
	rc = posix_spawn(&pid, c->self_exe, &fa, NULL, argv, environ);
	posix_spawn_file_actions_destroy(&fa);
	close(out_p[1]);
	close(err_p[1]);
	out_p[1] = err_p[1] = -1;
	if (rc != 0) {
		log_msg(LOG_ERROR, "analyze", "cannot start %s: %s", c->self_exe, strerror(rc));
		rc = -1;
		goto out;
	}
	deadline = progress_now_s() + c->analyze_timeout_s + 5;
	{
		struct pollfd pf[2] = {{out_p[0], POLLIN, 0}, {err_p[0], POLLIN, 0}};
		int open_n = 2;
		while (open_n > 0) {
			double left = deadline - progress_now_s();
			int n;
			if (left <= 0) {
				kill(pid, SIGKILL);
				res->timed_out = 1;
				break;
			}
			n = poll(pf, 2, (int)(left * 1000) + 1);
			if (n < 0 && errno != EINTR)
				break;
			for (int i = 0; i < 2; i++) {
				char chunk[16384];
				ssize_t got;
				if (pf[i].fd < 0 || !(pf[i].revents & (POLLIN | POLLHUP | POLLERR)))
					continue;
				got = read(pf[i].fd, chunk, sizeof chunk);
				if (got <= 0) {
					pf[i].fd = -1;
					open_n--;
					continue;
				}
				if (bufs[i]->len + (size_t)got <= (i ? ANALYZE_ERR_MAX : ANALYZE_OUT_MAX))
					buf_append(bufs[i], chunk, (size_t)got);
			}
		}
	}
	while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
		;
	res->exited = WIFEXITED(status);
	res->exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
	res->signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
	buf_append(&res->out, "", 1);
	buf_append(&res->err, "", 1);
	rc = 0;
out:
	for (int i = 0; i < 2; i++) {
		if (out_p[i] >= 0)
			close(out_p[i]);
		if (err_p[i] >= 0)
			close(err_p[i]);
	}
	return rc;
}

void api_analyze_result_fini(struct analyze_result *res)
{
	buf_fini(&res->out);
	buf_fini(&res->err);
}

static void *analyze_main(void *arg)
{
	struct api_server *s = arg;

	for (;;) {
		struct analyze_task *t;

		pthread_mutex_lock(&s->an_mu);
		while (!s->an_head && !atomic_load(&s->stopping))
			pthread_cond_wait(&s->an_cv, &s->an_mu);
		t = s->an_head;
		if (t) {
			s->an_head = t->next;
			if (!s->an_head)
				s->an_tail = NULL;
		}
		pthread_mutex_unlock(&s->an_mu);
		if (!t)
			return NULL; /* stopping and nothing left */
		/* Prepares r->pending; then the connection is resumed and MHD
		 * calls on_request again, which queues it. */
		t->fn(t->req);
		MHD_resume_connection(t->req->conn);
		free(t);
	}
}

int api_analyze_submit(struct api_req *r)
{
	return api_offload(r, api_upload_complete);
}

int api_offload(struct api_req *r, void (*fn)(struct api_req *))
{
	struct api_server *s = r->srv;
	struct analyze_task *t = calloc(1, sizeof *t);

	if (!t)
		return -1;
	t->req = r;
	t->fn = fn;
	api_park(r);
	pthread_mutex_lock(&s->an_mu);
	if (s->an_tail)
		s->an_tail->next = t;
	else
		s->an_head = t;
	s->an_tail = t;
	pthread_cond_signal(&s->an_cv);
	pthread_mutex_unlock(&s->an_mu);
	return 0;
}

int api_analyze_start(struct api_server *s, struct err *e)
{
	for (int i = 0; i < 2; i++) {
		if (pthread_create(&s->an_threads[i], NULL, analyze_main, s) != 0) {
			api_analyze_stop(s);
			return ERR_SET(e, ERR_IO, "cannot start analysis threads");
		}
		s->an_started++;
	}
	return 0;
}

void api_analyze_stop(struct api_server *s)
{
	/* Threads drain the queue (each upload gets its answer), then exit. */
	pthread_mutex_lock(&s->an_mu);
	atomic_store(&s->stopping, 1);
	pthread_cond_broadcast(&s->an_cv);
	pthread_mutex_unlock(&s->an_mu);
	for (int i = 0; i < s->an_started; i++)
		pthread_join(s->an_threads[i], NULL);
	s->an_started = 0;
}
