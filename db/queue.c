/* queue.c - the job queue's backend-independent part (see queue.h):
 * state names, row ownership, the backoff rule, and the calls that check
 * their arguments and go to the backend's ops (db_ops.h; SQLite in
 * db/sqlite/queue.c, PostgreSQL in db/pg/).
 */
#include "db/queue.h"
#include "db/db_ops.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

static const char *const state_names[JOB_STATE_COUNT] = {"queued", "running", "succeeded",
							  "failed", "cancelled"};

const char *queue_state_name(int state)
{
	return state >= 0 && state < JOB_STATE_COUNT ? state_names[state] : "unknown";
}

int queue_state_parse(const char *name)
{
	for (int i = 0; name && i < JOB_STATE_COUNT; i++)
		if (!strcmp(name, state_names[i]))
			return i;
	return -1;
}

void queue_job_row_fini(struct job_row *j)
{
	if (!j)
		return;
	free(j->params);
	free(j->error);
	free(j->metrics);
	j->params = j->error = j->metrics = NULL;
}

void queue_job_rows_free(struct job_row *v, int n)
{
	for (int i = 0; v && i < n; i++)
		queue_job_row_fini(&v[i]);
	free(v);
}

void queue_events_free(struct job_event *v, int n)
{
	for (int i = 0; v && i < n; i++)
		free(v[i].data);
	free(v);
}

const double queue_duration_le[QUEUE_DURATION_BUCKETS] = {1,   5,    15,   60,   300,
							  900, 1800, 3600, 7200, 21600};

int64_t queue_backoff_ms(int attempts_done)
{
	int64_t ms = 1000;

	for (int i = 1; i < attempts_done && ms < 60000; i++)
		ms *= 2;
	return ms < 60000 ? ms : 60000;
}

int queue_submit_batch(struct db *db, const struct job_new *v, int n, struct job_submit *res,
		       struct err *e)
{
	int rc;

	for (int i = 0; i < n; i++) {
		res[i].rc = ERR_IO;
		res[i].replayed = 0;
		res[i].seq = 0;
		err_clear(&res[i].err);
	}
	if ((rc = db_begin(db, e)))
		goto fail;
	for (int i = 0; i < n; i++) {
		/* A savepoint per submission: one bad request never undoes the
		 * others of its batch. */
		if ((rc = db->ops->savepoint(db, 0, 0, e)))
			goto out;
		res[i].rc = db->ops->submit_one(db, &v[i], &res[i].seq, &res[i].replayed, &res[i].err);
		if ((rc = db->ops->savepoint(db, 1, res[i].rc != 0, e)))
			goto out;
	}
	/* One commit, one fsync for the whole batch (group commit). */
	if ((rc = db_commit(db, e)))
		goto fail;
	return 0;
out:
	db_rollback(db);
fail:
	/* The transaction failed: nothing of the batch is stored. */
	for (int i = 0; i < n; i++)
		if (!res[i].rc || res[i].rc == ERR_IO) {
			res[i].rc = rc;
			res[i].err = *e;
		}
	return rc;
}

int queue_submit(struct db *db, const struct job_new *jn, struct job_row *out, int *replayed,
		 struct err *e)
{
	struct job_submit res;
	int rc = queue_submit_batch(db, jn, 1, &res, e);

	if (!rc && res.rc) {
		*e = res.err;
		return res.rc;
	}
	if (rc)
		return rc;
	*replayed = res.replayed;
	return queue_get_seq(db, res.seq, out, e);
}

int queue_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	      struct err *e)
{
	return db->ops->get(db, tenant_id, id, out, e);
}

int queue_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e)
{
	return db->ops->get_seq(db, seq, out, e);
}

int queue_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	       struct job_row **v, int *n, int *more, struct err *e)
{
	return db->ops->list(db, tenant_id, state, before_seq, limit, v, n, more, e);
}

int queue_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		 struct err *e)
{
	return db->ops->cancel(db, tenant_id, id, out, e);
}

int queue_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
		int *got, struct err *e)
{
	return db->ops->claim(db, worker, lease_ms, out, got, e);
}

int queue_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e)
{
	return db->ops->heartbeat(db, seq, attempt, lease_ms, e);
}

int queue_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
		   int64_t lease_ms, struct err *e)
{
	return db->ops->progress(db, seq, attempt, p, lease_ms, e);
}

int queue_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		  const char *metrics_json, struct err *e)
{
	return db->ops->succeed(db, seq, attempt, a, metrics_json, e);
}

int queue_fail(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
	       struct err *e)
{
	return db->ops->fail(db, seq, attempt, f, e);
}

int queue_rescue(struct db *db, const char *worker, int *n, struct err *e)
{
	return db->ops->rescue(db, worker, n, e);
}

int queue_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		 int *n, struct err *e)
{
	return db->ops->events(db, seq, after, limit, v, n, e);
}

int queue_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e)
{
	return db->ops->counts(db, counts, e);
}

int queue_durations(struct db *db, struct queue_durations *d, struct err *e)
{
	return db->ops->durations(db, d, e);
}

int queue_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit,
			   struct expired_artifact **v, int *n, struct err *e)
{
	return db->ops->expire_artifacts(db, cutoff_ms, limit, v, n, e);
}

int queue_artifact_referenced(struct db *db, const char *job_id, const char *name)
{
	return db->ops->artifact_referenced(db, job_id, name);
}
