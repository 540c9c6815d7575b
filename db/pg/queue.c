/* queue.c - the PostgreSQL job queue, client side: submit (group commit,
 * idempotency keys), reads, cancel, events, counts, retention (see
 * queue.h; the worker side is queue_worker.c).
 *
 * Each visible change bumps jobs.event_seq and appends a job_events row
 * whose data is a JSON snapshot built in SQL (db/ knows no jansson), and
 * notifies channel infilld_job with the job's seq in the same transaction
 * (LISTENers get it on commit: db_wait()).
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define JOB_COLS                                                                         \
	"seq, id, tenant_id, mesh_id, engine, format, printer, params, fault, state, stage," \
	" progress, layers_done, layers_total, attempt, max_attempts, created_at,"          \
	" started_at, finished_at, run_after, lease_expires, error_type, error,"            \
	" error_field, metrics, artifact, artifact_bytes, artifact_sha256, event_seq,"       \
	" artifact_damaged_at, mesh_name"

static void read_job(const PGresult *r, int i, struct job_row *j)
{
	memset(j, 0, sizeof *j);
	j->seq = pgdb_i64(r, i, 0);
	pgdb_copy(r, i, 1, j->id, sizeof j->id);
	j->tenant_id = pgdb_i64(r, i, 2);
	pgdb_copy(r, i, 3, j->mesh_id, sizeof j->mesh_id);
	pgdb_copy(r, i, 4, j->engine, sizeof j->engine);
	pgdb_copy(r, i, 5, j->format, sizeof j->format);
	pgdb_copy(r, i, 6, j->printer, sizeof j->printer);
	j->params = pgdb_dup(r, i, 7);
	pgdb_copy(r, i, 8, j->fault, sizeof j->fault);
	j->state = queue_state_parse(pgdb_text(r, i, 9));
	pgdb_copy(r, i, 10, j->stage, sizeof j->stage);
	j->progress = pgdb_f64(r, i, 11);
	j->layers_done = pgdb_int(r, i, 12);
	j->layers_total = pgdb_int(r, i, 13);
	j->attempt = pgdb_int(r, i, 14);
	j->max_attempts = pgdb_int(r, i, 15);
	j->created_ms = pgdb_i64(r, i, 16);
	j->started_ms = pgdb_i64(r, i, 17);
	j->finished_ms = pgdb_i64(r, i, 18);
	j->run_after_ms = pgdb_i64(r, i, 19);
	j->lease_expires_ms = pgdb_i64(r, i, 20);
	pgdb_copy(r, i, 21, j->error_type, sizeof j->error_type);
	j->error = pgdb_dup(r, i, 22);
	pgdb_copy(r, i, 23, j->error_field, sizeof j->error_field);
	j->metrics = pgdb_dup(r, i, 24);
	pgdb_copy(r, i, 25, j->artifact, sizeof j->artifact);
	j->artifact_bytes = pgdb_i64(r, i, 26);
	pgdb_copy(r, i, 27, j->artifact_sha256, sizeof j->artifact_sha256);
	j->event_seq = pgdb_i64(r, i, 28);
	j->artifact_damaged_ms = pgdb_i64(r, i, 29);
	pgdb_copy(r, i, 30, j->mesh_name, sizeof j->mesh_name);
}

int pgdb_add_event(struct db *db, int64_t seq, const char *type, struct err *e)
{
	/* The snapshot is written byte for byte as SQLite's json_object()
	 * writes it (no blanks; json_build_object() would put " : " between
	 * key and value), with to_json() quoting the strings. */
	static const char sql[] =
		"WITH ins AS (INSERT INTO job_events(job_seq, n, type, data)"
		" SELECT seq, event_seq, $2::text,"
		"  '{\"id\":' || to_json(id)::text || ',\"state\":' || to_json(state)::text"
		"  || ',\"stage\":' || to_json(stage)::text || ',\"progress\":' || to_json(progress)::text"
		"  || ',\"layers_done\":' || layers_done || ',\"layers_total\":' || layers_total"
		"  || ',\"attempt\":' || attempt || ',\"error\":' || CASE WHEN error IS NULL THEN 'null'"
		"  ELSE '{\"type\":' || coalesce(to_json(error_type)::text, 'null')"
		"   || ',\"detail\":' || to_json(error)::text"
		"   || ',\"field\":' || coalesce(to_json(error_field)::text, 'null') || '}' END || '}'"
		" FROM jobs WHERE seq = $1::bigint RETURNING job_seq)"
		" SELECT pg_notify('infilld_job', job_seq::text) FROM ins";
	struct pgdb_params p;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_text(&p, type);
	return pgdb_run(db, sql, &p, "appending job event", e);
}

int pgdb_record_duration(struct db *db, int64_t seq, struct err *e)
{
	static const char get_sql[] =
		"SELECT state, ((finished_at - coalesce(started_at, created_at)) / 1000.0)::float8"
		" FROM jobs WHERE seq = $1::bigint";
	/* Non-cumulative buckets; le -1 encodes +Inf. */
	static const char bucket_sql[] =
		"INSERT INTO job_durations(state, le, count) VALUES ($1::text, $2::float8, 1)"
		" ON CONFLICT (state, le) DO UPDATE SET count = job_durations.count + 1";
	static const char sum_sql[] =
		"INSERT INTO job_duration_sums(state, count, sum_s) VALUES ($1::text, 1, $2::float8)"
		" ON CONFLICT (state) DO UPDATE SET count = job_duration_sums.count + 1,"
		"  sum_s = job_duration_sums.sum_s + excluded.sum_s";
	struct pgdb_params p;
	char state[16];
	double d, le = -1;
	PGresult *r;
	int rc;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	if (!(r = pgdb_q(db, get_sql, &p, "reading job duration", e)))
		return ERR_IO;
	if (PQntuples(r) != 1) {
		PQclear(r);
		return ERR_SET(e, ERR_IO, "reading job duration: no job %lld", (long long)seq);
	}
	pgdb_copy(r, 0, 0, state, sizeof state);
	d = pgdb_f64(r, 0, 1);
	PQclear(r);
	for (int i = 0; i < QUEUE_DURATION_BUCKETS; i++)
		if (d <= queue_duration_le[i]) {
			le = queue_duration_le[i];
			break;
		}
	pgdb_p_init(&p);
	pgdb_p_text(&p, state);
	pgdb_p_f64(&p, le);
	if ((rc = pgdb_run(db, bucket_sql, &p, "recording duration", e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, state);
	pgdb_p_f64(&p, d);
	return pgdb_run(db, sum_sql, &p, "recording duration", e);
}

/* The job of jn's idempotency key: 1 found (*seq; *replayed = 1, or
 * ERR_PARAM for another request under the same key), 0 none, or ERR_IO. */
static int idem_lookup(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
		       struct err *e)
{
	static const char sql[] = "SELECT seq, request_hash FROM jobs"
				  " WHERE tenant_id = $1::bigint AND idem_key = $2::text";
	struct pgdb_params p;
	PGresult *r;
	int same;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, jn->tenant_id);
	pgdb_p_text(&p, jn->idem_key);
	if (!(r = pgdb_q(db, sql, &p, "checking the idempotency key", e)))
		return ERR_IO;
	if (PQntuples(r) != 1) {
		PQclear(r);
		return 0;
	}
	same = !strcmp(pgdb_text(r, 0, 1), jn->request_hash ? jn->request_hash : "");
	*seq = pgdb_i64(r, 0, 0);
	PQclear(r);
	if (!same)
		return ERR_FIELD(e, "Idempotency-Key",
				 "this Idempotency-Key was used with a different request");
	*replayed = 1;
	return 1;
}

int pgdb_submit_one(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
		    struct err *e)
{
	/* FOR SHARE: the mesh cannot be deleted before this commits
	 * (meshes.c). */
	static const char mesh_sql[] = "SELECT 1 FROM meshes"
				       " WHERE tenant_id = $1::bigint AND id = $2::text FOR SHARE";
	/* A concurrent submit of the same key makes this wait for it; once it
	 * committed, DO NOTHING returns no row and the key's job is read. */
	static const char ins_sql[] =
		"INSERT INTO jobs(id, tenant_id, mesh_id, engine, format, printer, params,"
		" idem_key, request_hash, fault, max_attempts, created_at, event_seq)"
		" VALUES ($1::text, $2::bigint, $3::text, $4::text, $5::text, $6::text, $7::text,"
		"  $8::text, $9::text, $10::text, $11::int, $12::bigint, 1)"
		" ON CONFLICT (tenant_id, idem_key) WHERE idem_key IS NOT NULL DO NOTHING"
		" RETURNING seq";
	char id[DB_ID_MAX];
	struct pgdb_params p;
	PGresult *r;
	int rc, found;

	*replayed = 0;
	if ((rc = db_make_id("j_", id, e)))
		return rc;
	if (jn->idem_key && (rc = idem_lookup(db, jn, seq, replayed, e)))
		return rc < 0 ? rc : 0;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, jn->tenant_id);
	pgdb_p_text(&p, jn->mesh_id);
	if (!(r = pgdb_q(db, mesh_sql, &p, "checking mesh", e)))
		return ERR_IO;
	found = PQntuples(r) > 0;
	PQclear(r);
	if (!found) {
		ERR_SET(e, ERR_NOTFOUND, "no mesh '%s'", jn->mesh_id);
		snprintf(e->field, sizeof e->field, "mesh_id");
		return ERR_NOTFOUND;
	}
	pgdb_p_init(&p);
	pgdb_p_text(&p, id);
	pgdb_p_i64(&p, jn->tenant_id);
	pgdb_p_text(&p, jn->mesh_id);
	pgdb_p_text(&p, jn->engine);
	pgdb_p_text(&p, jn->format);
	pgdb_p_text(&p, jn->printer);
	pgdb_p_text(&p, jn->params ? jn->params : "{}");
	pgdb_p_text(&p, jn->idem_key);
	pgdb_p_text(&p, jn->request_hash);
	pgdb_p_text(&p, jn->fault && jn->fault[0] ? jn->fault : NULL);
	pgdb_p_i64(&p, jn->max_attempts > 0 ? jn->max_attempts : 3);
	pgdb_p_i64(&p, db_now_ms());
	if (!(r = pgdb_q(db, ins_sql, &p, "queueing job", e)))
		return ERR_IO;
	found = PQntuples(r) == 1;
	if (found)
		*seq = pgdb_i64(r, 0, 0);
	PQclear(r);
	if (!found) {
		/* Lost the race for the key: the winner's job is committed. */
		rc = idem_lookup(db, jn, seq, replayed, e);
		if (rc == 0)
			rc = ERR_SET(e, ERR_IO, "queueing job: idempotency key conflict");
		return rc < 0 ? rc : 0;
	}
	return pgdb_add_event(db, *seq, "state", e);
}

static int get_by(struct db *db, const char *sql, const struct pgdb_params *p,
		  struct job_row *out, struct err *e)
{
	PGresult *r = pgdb_q(db, sql, p, "reading job", e);
	int rc = 0;

	if (!r)
		return ERR_IO;
	if (PQntuples(r) == 1)
		read_job(r, 0, out);
	else
		rc = ERR_SET(e, ERR_NOTFOUND, "no such job");
	PQclear(r);
	return rc;
}

int pgdb_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	     struct err *e)
{
	static const char sql[] =
		"SELECT " JOB_COLS " FROM jobs WHERE tenant_id = $1::bigint AND id = $2::text";
	struct pgdb_params p;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_text(&p, id);
	return get_by(db, sql, &p, out, e);
}

int pgdb_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e)
{
	static const char sql[] = "SELECT " JOB_COLS " FROM jobs WHERE seq = $1::bigint";
	struct pgdb_params p;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	return get_by(db, sql, &p, out, e);
}

int pgdb_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	      struct job_row **v, int *n, int *more, struct err *e)
{
	static const char all_sql[] = "SELECT " JOB_COLS " FROM jobs WHERE tenant_id = $1::bigint"
				      " AND seq < $2::bigint ORDER BY seq DESC LIMIT $3::int";
	static const char state_sql[] =
		"SELECT " JOB_COLS " FROM jobs WHERE tenant_id = $1::bigint"
		" AND seq < $2::bigint AND state = $4::text ORDER BY seq DESC LIMIT $3::int";
	struct pgdb_params p;
	struct job_row *a;
	PGresult *r;
	int cnt;

	if (limit < 1 || limit > 1000)
		limit = 50;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_i64(&p, before_seq > 0 ? before_seq : INT64_MAX);
	pgdb_p_i64(&p, limit + 1);
	if (state >= 0)
		pgdb_p_text(&p, queue_state_name(state));
	if (!(r = pgdb_q(db, state >= 0 ? state_sql : all_sql, &p, "listing jobs", e)))
		return ERR_IO;
	cnt = PQntuples(r);
	if (!(a = calloc((size_t)cnt + 1, sizeof *a))) {
		PQclear(r);
		return ERR_SET(e, ERR_NOMEM, "out of memory listing jobs");
	}
	for (int i = 0; i < cnt; i++)
		read_job(r, i, &a[i]);
	PQclear(r);
	*more = cnt > limit;
	if (*more)
		queue_job_row_fini(&a[--cnt]);
	*v = a;
	*n = cnt;
	return 0;
}

int pgdb_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		struct err *e)
{
	/* A claim holding the row makes this wait, then re-check the state on
	 * the claimed row: the running job is cancelled (its worker's fenced
	 * writes then fail). */
	static const char sql[] =
		"UPDATE jobs SET state = 'cancelled', stage = 'cancelled', finished_at = $3::bigint,"
		" lease_expires = NULL, event_seq = event_seq + 1"
		" WHERE tenant_id = $1::bigint AND id = $2::text AND state IN ('queued', 'running')"
		" RETURNING seq";
	struct pgdb_params p;
	PGresult *r;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_text(&p, id);
	pgdb_p_i64(&p, db_now_ms());
	if (!(r = pgdb_q(db, sql, &p, "cancelling job", e))) {
		rc = ERR_IO;
		goto out;
	}
	if (PQntuples(r) == 1) {
		int64_t seq = pgdb_i64(r, 0, 0);
		if (!(rc = pgdb_add_event(db, seq, "state", e)))
			rc = pgdb_record_duration(db, seq, e);
	}
	PQclear(r);
	if (rc || (rc = pgdb_commit(db, e)))
		goto out;
	return pgdb_get(db, tenant_id, id, out, e);
out:
	pgdb_rollback(db);
	return rc;
}

int pgdb_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		int *n, struct err *e)
{
	static const char sql[] = "SELECT n, type, data FROM job_events"
				  " WHERE job_seq = $1::bigint AND n > $2::bigint ORDER BY n"
				  " LIMIT $3::int";
	struct pgdb_params p;
	struct job_event *a;
	PGresult *r;
	int cnt;

	if (limit < 1)
		limit = 1;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, after);
	pgdb_p_i64(&p, limit);
	if (!(r = pgdb_q(db, sql, &p, "reading events", e)))
		return ERR_IO;
	cnt = PQntuples(r);
	if (!(a = calloc((size_t)limit, sizeof *a))) {
		PQclear(r);
		return ERR_SET(e, ERR_NOMEM, "out of memory reading events");
	}
	for (int i = 0; i < cnt; i++) {
		a[i].n = pgdb_i64(r, i, 0);
		pgdb_copy(r, i, 1, a[i].type, sizeof a[i].type);
		if (!(a[i].data = pgdb_dup(r, i, 2))) {
			PQclear(r);
			queue_events_free(a, i);
			return ERR_SET(e, ERR_NOMEM, "out of memory reading events");
		}
	}
	PQclear(r);
	*v = a;
	*n = cnt;
	return 0;
}

int pgdb_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e)
{
	static const char sql[] = "SELECT state, count(*) FROM jobs GROUP BY state";
	PGresult *r = pgdb_q(db, sql, NULL, "counting jobs", e);

	if (!r)
		return ERR_IO;
	memset(counts, 0, sizeof(int64_t) * JOB_STATE_COUNT);
	for (int i = 0; i < PQntuples(r); i++) {
		int s = queue_state_parse(pgdb_text(r, i, 0));
		if (s >= 0)
			counts[s] = pgdb_i64(r, i, 1);
	}
	PQclear(r);
	return 0;
}

int pgdb_durations(struct db *db, struct queue_durations *d, struct err *e)
{
	static const char b_sql[] = "SELECT state, le, count FROM job_durations";
	static const char s_sql[] = "SELECT state, count, sum_s FROM job_duration_sums";
	PGresult *r;

	memset(d, 0, sizeof *d);
	if (!(r = pgdb_q(db, b_sql, NULL, "reading durations", e)))
		return ERR_IO;
	for (int k = 0; k < PQntuples(r); k++) {
		int s = queue_state_parse(pgdb_text(r, k, 0)) - JOB_SUCCEEDED;
		double le = pgdb_f64(r, k, 1);
		if (s < 0 || s > 2)
			continue;
		/* Cumulative: a job in bucket le counts in every bucket >= le. */
		for (int i = 0; i < QUEUE_DURATION_BUCKETS; i++)
			if (le >= 0 && le <= queue_duration_le[i])
				d->bucket[s][i] += pgdb_i64(r, k, 2);
	}
	PQclear(r);
	if (!(r = pgdb_q(db, s_sql, NULL, "reading durations", e)))
		return ERR_IO;
	for (int k = 0; k < PQntuples(r); k++) {
		int s = queue_state_parse(pgdb_text(r, k, 0)) - JOB_SUCCEEDED;
		if (s < 0 || s > 2)
			continue;
		d->count[s] = pgdb_i64(r, k, 1);
		d->sum_s[s] = pgdb_f64(r, k, 2);
	}
	PQclear(r);
	return 0;
}

int pgdb_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit,
			  struct expired_artifact **v, int *n, struct err *e)
{
	/* SKIP LOCKED: a row another process is expiring or quarantining is
	 * left to it (the next sweep looks again). */
	static const char sel_sql[] =
		"SELECT seq, tenant_id, artifact, artifact_bytes FROM jobs"
		" WHERE artifact IS NOT NULL AND finished_at < $1::bigint ORDER BY finished_at"
		" LIMIT $2::int FOR UPDATE SKIP LOCKED";
	static const char clr_sql[] =
		"UPDATE jobs SET artifact = NULL WHERE seq = $1::bigint AND artifact IS NOT NULL";
	static const char ev_sql[] = "DELETE FROM job_events WHERE job_seq = $1::bigint";
	struct expired_artifact *a;
	struct pgdb_params p;
	PGresult *r;
	int cnt = 0, rc;

	if (limit < 1)
		limit = 1;
	if (!(a = calloc((size_t)limit, sizeof *a)))
		return ERR_SET(e, ERR_NOMEM, "out of memory expiring artifacts");
	if ((rc = pgdb_begin(db, e)))
		goto fail;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, cutoff_ms);
	pgdb_p_i64(&p, limit);
	if (!(r = pgdb_q(db, sel_sql, &p, "expiring artifacts", e))) {
		rc = ERR_IO;
		goto out;
	}
	for (int i = 0; i < PQntuples(r) && i < limit && !rc; i++) {
		int64_t seq = pgdb_i64(r, i, 0), bytes = pgdb_i64(r, i, 3);
		a[cnt].tenant_id = pgdb_i64(r, i, 1);
		pgdb_copy(r, i, 2, a[cnt].name, sizeof a[cnt].name);
		pgdb_p_init(&p);
		pgdb_p_i64(&p, seq);
		if (!(rc = pgdb_run(db, clr_sql, &p, "expiring artifacts", e)) &&
		    !(rc = pgdb_run(db, ev_sql, &p, "expiring artifacts", e)))
			rc = pgdb_add_usage_locked(db, a[cnt].tenant_id, -bytes, e);
		cnt++;
	}
	PQclear(r);
	if (!rc)
		rc = pgdb_commit(db, e);
out:
	if (rc)
		pgdb_rollback(db);
fail:
	if (rc) {
		free(a);
		return rc;
	}
	*v = a;
	*n = cnt;
	return 0;
}

int pgdb_artifact_referenced(struct db *db, const char *job_id, const char *name)
{
	static const char sql[] =
		"SELECT 1 FROM jobs WHERE id = $1::text AND artifact = $2::text";
	struct pgdb_params p;
	PGresult *r;
	int ref;

	pgdb_p_init(&p);
	pgdb_p_text(&p, job_id);
	pgdb_p_text(&p, name);
	if (!(r = pgdb_q(db, sql, &p, "checking an artifact", NULL)))
		return 1; /* when unsure, keep the file */
	ref = PQntuples(r) > 0;
	PQclear(r);
	return ref;
}

int pgdb_savepoint(struct db *db, int end, int undo, struct err *e)
{
	return pgdb_exec(db,
			 !end ? "SAVEPOINT one" : undo ? "ROLLBACK TO SAVEPOINT one; RELEASE one" : "RELEASE one",
			 e);
}
