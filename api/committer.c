/* committer.c - group commit of job submissions.
 *
 * synchronous=FULL makes every commit wait for the disk (~4 ms here), so
 * one transaction per request caps submissions near 250/s.  Handlers
 * instead validate, hand the job to this thread and park their
 * connection; the thread commits everything waiting in one transaction
 * (queue_submit_batch: one fsync, a savepoint each), then answers and
 * resumes every request of the batch.  Nothing is acknowledged before it
 * is on disk.
 */
#include "api/api_internal.h"
#include "api/log.h"
#include "db/queue.h"

#include <stdlib.h>
#include <string.h>

#define BATCH_MAX 512

struct submit_task {
	struct api_req *req;
	struct job_new jn;
	struct submit_task *next;
	char strings[]; /* the job_new's strings, copied */
};

static char *put(char **p, const char *s)
{
	char *at = *p;

	if (!s)
		return NULL;
	strcpy(at, s);
	*p += strlen(s) + 1;
	return at;
}

int api_submit_enqueue(struct api_req *r, const struct job_new *jn)
{
	struct api_server *s = r->srv;
	const char *strs[] = {jn->mesh_id, jn->engine, jn->format, jn->printer, jn->params,
			      jn->idem_key, jn->request_hash, jn->fault};
	size_t len = 0;
	struct submit_task *t;
	char *p;

	for (size_t i = 0; i < sizeof strs / sizeof strs[0]; i++)
		len += strs[i] ? strlen(strs[i]) + 1 : 0;
	if (!(t = calloc(1, sizeof *t + len)))
		return -1;
	t->req = r;
	t->jn = *jn;
	p = t->strings;
	t->jn.mesh_id = put(&p, jn->mesh_id);
	t->jn.engine = put(&p, jn->engine);
	t->jn.format = put(&p, jn->format);
	t->jn.printer = put(&p, jn->printer);
	t->jn.params = put(&p, jn->params);
	t->jn.idem_key = put(&p, jn->idem_key);
	t->jn.request_hash = put(&p, jn->request_hash);
	t->jn.fault = put(&p, jn->fault);
	api_park(r);
	pthread_mutex_lock(&s->cm_mu);
	if (s->cm_tail)
		s->cm_tail->next = t;
	else
		s->cm_head = t;
	s->cm_tail = t;
	pthread_cond_signal(&s->cm_cv);
	pthread_mutex_unlock(&s->cm_mu);
	return 0;
}

static void answer(struct api_server *s, struct db *db, struct submit_task *t,
		   const struct job_submit *res)
{
	struct api_req *r = t->req;
	struct job_row j;
	struct err e;

	if (res->rc == 0 && queue_get_seq(db, res->seq, &j, &e) == 0) {
		r->pending = api_submit_response(&j, res->replayed);
		r->pending_status = MHD_HTTP_ACCEPTED;
		queue_job_row_fini(&j);
	} else if (res->rc == ERR_PARAM) {
		r->pending = api_problem_response(PROB_IDEMPOTENCY, r->url, "Idempotency-Key",
						  res->err.msg, &r->pending_status);
	} else if (res->rc == ERR_NOTFOUND) {
		r->pending = api_problem_response(PROB_INVALID_PARAM, r->url, "mesh_id",
						  res->err.msg, &r->pending_status);
	} else {
		log_msg(LOG_ERROR, "api", "queueing a job: %s", res->rc ? res->err.msg : e.msg);
		r->pending = api_problem_response(PROB_UNAVAILABLE, r->url, NULL,
						  "cannot queue the job now", &r->pending_status);
	}
	MHD_resume_connection(r->conn);
	(void)s;
}

static void *committer_main(void *arg)
{
	struct api_server *s = arg;
	static __thread struct job_new v[BATCH_MAX];
	static __thread struct job_submit res[BATCH_MAX];
	struct submit_task *batch[BATCH_MAX];

	for (;;) {
		struct db *db;
		struct err e;
		int n = 0;

		pthread_mutex_lock(&s->cm_mu);
		while (!s->cm_head && !s->cm_stop)
			pthread_cond_wait(&s->cm_cv, &s->cm_mu);
		while (s->cm_head && n < BATCH_MAX) {
			batch[n++] = s->cm_head;
			s->cm_head = s->cm_head->next;
		}
		if (!s->cm_head)
			s->cm_tail = NULL;
		pthread_mutex_unlock(&s->cm_mu);
		if (n == 0)
			return NULL; /* stopping and drained */
		for (int i = 0; i < n; i++)
			v[i] = batch[i]->jn;
		db = db_pool_get(s->pool);
		err_clear(&e);
		queue_submit_batch(db, v, n, res, &e);
		for (int i = 0; i < n; i++) {
			answer(s, db, batch[i], &res[i]);
			free(batch[i]);
		}
		db_pool_put(s->pool, db);
	}
}

int api_committer_start(struct api_server *s, struct err *e)
{
	if (pthread_create(&s->cm_thread, NULL, committer_main, s) != 0)
		return ERR_SET(e, ERR_IO, "cannot start the committer thread");
	s->cm_started = 1;
	return 0;
}

void api_committer_stop(struct api_server *s)
{
	if (!s->cm_started)
		return;
	pthread_mutex_lock(&s->cm_mu);
	s->cm_stop = 1;
	pthread_cond_broadcast(&s->cm_cv);
	pthread_mutex_unlock(&s->cm_mu);
	pthread_join(s->cm_thread, NULL);
	s->cm_started = 0;
}
