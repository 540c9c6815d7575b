/* queue.c - the SQLite backend's job queue (see queue.h; design in
 * docs/service.md).
 *
 * Every write is one BEGIN IMMEDIATE transaction.  Worker writes are
 * fenced by "seq = ? AND attempt = ? AND state = 'running'".  Each visible
 * change bumps jobs.event_seq and appends a job_events row whose data is a
 * JSON snapshot built by SQLite's json_object() (db/ knows no jansson).
 */
#include "db/queue.h"
#include "db/sqlite/sq_internal.h"
#include "db/tenants.h"
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

static void read_job(sqlite3_stmt *st, struct job_row *j)
{
	memset(j, 0, sizeof *j);
	j->seq = sqlite3_column_int64(st, 0);
	sq_col_copy(st, 1, j->id, sizeof j->id);
	j->tenant_id = sqlite3_column_int64(st, 2);
	sq_col_copy(st, 3, j->mesh_id, sizeof j->mesh_id);
	sq_col_copy(st, 4, j->engine, sizeof j->engine);
	sq_col_copy(st, 5, j->format, sizeof j->format);
	sq_col_copy(st, 6, j->printer, sizeof j->printer);
	j->params = sq_col_dup(st, 7);
	sq_col_copy(st, 8, j->fault, sizeof j->fault);
	j->state = queue_state_parse(sq_col_text(st, 9));
	sq_col_copy(st, 10, j->stage, sizeof j->stage);
	j->progress = sqlite3_column_double(st, 11);
	j->layers_done = sqlite3_column_int(st, 12);
	j->layers_total = sqlite3_column_int(st, 13);
	j->attempt = sqlite3_column_int(st, 14);
	j->max_attempts = sqlite3_column_int(st, 15);
	j->created_ms = sqlite3_column_int64(st, 16);
	j->started_ms = sqlite3_column_int64(st, 17);
	j->finished_ms = sqlite3_column_int64(st, 18);
	j->run_after_ms = sqlite3_column_int64(st, 19);
	j->lease_expires_ms = sqlite3_column_int64(st, 20);
	sq_col_copy(st, 21, j->error_type, sizeof j->error_type);
	j->error = sq_col_dup(st, 22);
	sq_col_copy(st, 23, j->error_field, sizeof j->error_field);
	j->metrics = sq_col_dup(st, 24);
	sq_col_copy(st, 25, j->artifact, sizeof j->artifact);
	j->artifact_bytes = sqlite3_column_int64(st, 26);
	sq_col_copy(st, 27, j->artifact_sha256, sizeof j->artifact_sha256);
	j->event_seq = sqlite3_column_int64(st, 28);
	j->artifact_damaged_ms = sqlite3_column_int64(st, 29);
	sq_col_copy(st, 30, j->mesh_name, sizeof j->mesh_name);
}

/* Step a statement expecting no row; 0 or ERR_IO. */
static int step_done(struct db *db, sqlite3_stmt *st, const char *what, struct err *e)
{
	int rc = sqlite3_step(st);

	sqlite3_reset(st);
	return rc == SQLITE_DONE ? 0 : sq_fail(db, e, what);
}

/* Append the job's current snapshot as event number event_seq (the caller
 * already bumped it in the same transaction). */
static int add_event(struct db *db, int64_t seq, const char *type, struct err *e)
{
	static const char sql[] =
		"INSERT INTO job_events(job_seq, n, type, data)"
		" SELECT seq, event_seq, ?2, json_object('id', id, 'state', state, 'stage', stage,"
		"  'progress', progress, 'layers_done', layers_done, 'layers_total', layers_total,"
		"  'attempt', attempt, 'error', CASE WHEN error IS NULL THEN NULL ELSE"
		"  json_object('type', error_type, 'detail', error, 'field', error_field) END)"
		" FROM jobs WHERE seq = ?1";
	sqlite3_stmt *st = sq_stmt(db, sql, e);

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_text(st, 2, type, -1, SQLITE_STATIC);
	return step_done(db, st, "appending job event", e);
}

/* Count a finished job's duration in its (non-cumulative) bucket; index
 * QUEUE_DURATION_BUCKETS is +Inf. */
static int record_duration(struct db *db, int64_t seq, struct err *e)
{
	static const char get_sql[] =
		"SELECT state, (finished_at - coalesce(started_at, created_at)) / 1000.0"
		" FROM jobs WHERE seq = ?1";
	static const char bucket_sql[] =
		"INSERT INTO job_durations(state, le, count) VALUES (?1, ?2, 1)"
		" ON CONFLICT(state, le) DO UPDATE SET count = count + 1";
	static const char sum_sql[] =
		"INSERT INTO job_duration_sums(state, count, sum_s) VALUES (?1, 1, ?2)"
		" ON CONFLICT(state) DO UPDATE SET count = count + 1, sum_s = sum_s + ?2";
	sqlite3_stmt *st = sq_stmt(db, get_sql, e);
	char state[16];
	double d, le = -1; /* -1 encodes +Inf */
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, seq);
	if (sqlite3_step(st) != SQLITE_ROW) {
		sqlite3_reset(st);
		return sq_fail(db, e, "reading job duration");
	}
	sq_col_copy(st, 0, state, sizeof state);
	d = sqlite3_column_double(st, 1);
	sqlite3_reset(st);
	for (int i = 0; i < QUEUE_DURATION_BUCKETS; i++)
		if (d <= queue_duration_le[i]) {
			le = queue_duration_le[i];
			break;
		}
	if (!(st = sq_stmt(db, bucket_sql, e)))
		return ERR_IO;
	sqlite3_bind_text(st, 1, state, -1, SQLITE_TRANSIENT);
	sqlite3_bind_double(st, 2, le);
	if ((rc = step_done(db, st, "recording duration", e)))
		return rc;
	if (!(st = sq_stmt(db, sum_sql, e)))
		return ERR_IO;
	sqlite3_bind_text(st, 1, state, -1, SQLITE_TRANSIENT);
	sqlite3_bind_double(st, 2, d);
	return step_done(db, st, "recording duration", e);
}

static int get_by(struct db *db, const char *sql, int64_t tenant_id, const char *id, int64_t seq,
		  struct job_row *out, struct err *e)
{
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	if (id) {
		sqlite3_bind_int64(st, 1, tenant_id);
		sqlite3_bind_text(st, 2, id, -1, SQLITE_STATIC);
	} else {
		sqlite3_bind_int64(st, 1, seq);
	}
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		read_job(st, out);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		return 0;
	if (rc == SQLITE_DONE)
		return ERR_SET(e, ERR_NOTFOUND, "no such job");
	return sq_fail(db, e, "reading job");
}

int sq_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	      struct err *e)
{
	return get_by(db, "SELECT " JOB_COLS " FROM jobs WHERE tenant_id = ?1 AND id = ?2",
		      tenant_id, id, 0, out, e);
}

int sq_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e)
{
	return get_by(db, "SELECT " JOB_COLS " FROM jobs WHERE seq = ?1", 0, NULL, seq, out, e);
}

/* One submission inside the caller's transaction: *seq of the new or
 * replayed job. */
int sq_submit_one(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
		  struct err *e)
{
	static const char idem_sql[] =
		"SELECT seq, request_hash FROM jobs WHERE tenant_id = ?1 AND idem_key = ?2";
	static const char mesh_sql[] = "SELECT 1 FROM meshes WHERE tenant_id = ?1 AND id = ?2";
	static const char ins_sql[] =
		"INSERT INTO jobs(id, tenant_id, mesh_id, engine, format, printer, params,"
		" idem_key, request_hash, fault, max_attempts, created_at, event_seq)"
		" VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, 1) RETURNING seq";
	char id[DB_ID_MAX];
	sqlite3_stmt *st;
	int rc;

	*replayed = 0;
	if ((rc = db_make_id("j_", id, e)))
		return rc;
	if (jn->idem_key) {
		if (!(st = sq_stmt(db, idem_sql, e)))
			return ERR_IO;
		sqlite3_bind_int64(st, 1, jn->tenant_id);
		sqlite3_bind_text(st, 2, jn->idem_key, -1, SQLITE_STATIC);
		if (sqlite3_step(st) == SQLITE_ROW) {
			int same = !strcmp(sq_col_text(st, 1), jn->request_hash ? jn->request_hash : "");
			*seq = sqlite3_column_int64(st, 0);
			sqlite3_reset(st);
			if (!same)
				return ERR_FIELD(e, "Idempotency-Key",
						 "this Idempotency-Key was used with a different request");
			*replayed = 1;
			return 0;
		}
		sqlite3_reset(st);
	}
	if (!(st = sq_stmt(db, mesh_sql, e)))
		return ERR_IO;
	sqlite3_bind_int64(st, 1, jn->tenant_id);
	sqlite3_bind_text(st, 2, jn->mesh_id, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc == SQLITE_DONE) {
		ERR_SET(e, ERR_NOTFOUND, "no mesh '%s'", jn->mesh_id);
		snprintf(e->field, sizeof e->field, "mesh_id");
		return ERR_NOTFOUND;
	}
	if (rc != SQLITE_ROW)
		return sq_fail(db, e, "checking mesh");
	if (!(st = sq_stmt(db, ins_sql, e)))
		return ERR_IO;
	sqlite3_bind_text(st, 1, id, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 2, jn->tenant_id);
	sqlite3_bind_text(st, 3, jn->mesh_id, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 4, jn->engine, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 5, jn->format, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 6, jn->printer, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 7, jn->params ? jn->params : "{}", -1, SQLITE_STATIC);
	if (jn->idem_key)
		sqlite3_bind_text(st, 8, jn->idem_key, -1, SQLITE_STATIC);
	if (jn->request_hash)
		sqlite3_bind_text(st, 9, jn->request_hash, -1, SQLITE_STATIC);
	if (jn->fault && jn->fault[0])
		sqlite3_bind_text(st, 10, jn->fault, -1, SQLITE_STATIC);
	sqlite3_bind_int(st, 11, jn->max_attempts > 0 ? jn->max_attempts : 3);
	sqlite3_bind_int64(st, 12, db_now_ms());
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		*seq = sqlite3_column_int64(st, 0);
	sqlite3_reset(st);
	if (rc != SQLITE_ROW)
		return sq_fail(db, e, "queueing job");
	return add_event(db, *seq, "state", e);
}

int sq_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	       struct job_row **v, int *n, int *more, struct err *e)
{
	static const char all_sql[] = "SELECT " JOB_COLS " FROM jobs WHERE tenant_id = ?1"
				      " AND seq < ?3 ORDER BY seq DESC LIMIT ?4";
	static const char state_sql[] = "SELECT " JOB_COLS " FROM jobs WHERE tenant_id = ?1"
					" AND state = ?2 AND seq < ?3 ORDER BY seq DESC LIMIT ?4";
	sqlite3_stmt *st = sq_stmt(db, state >= 0 ? state_sql : all_sql, e);
	struct job_row *a;
	int cnt = 0, rc;

	if (!st)
		return ERR_IO;
	if (limit < 1 || limit > 1000)
		limit = 50;
	if (!(a = calloc((size_t)limit + 1, sizeof *a))) {
		sqlite3_reset(st);
		return ERR_SET(e, ERR_NOMEM, "out of memory listing jobs");
	}
	sqlite3_bind_int64(st, 1, tenant_id);
	if (state >= 0)
		sqlite3_bind_text(st, 2, queue_state_name(state), -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 3, before_seq > 0 ? before_seq : INT64_MAX);
	sqlite3_bind_int(st, 4, limit + 1);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW)
		read_job(st, &a[cnt++]);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE) {
		queue_job_rows_free(a, cnt);
		return sq_fail(db, e, "listing jobs");
	}
	*more = cnt > limit;
	if (*more)
		queue_job_row_fini(&a[--cnt]);
	*v = a;
	*n = cnt;
	return 0;
}

int sq_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		 struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET state = 'cancelled', stage = 'cancelled', finished_at = ?3,"
		" lease_expires = NULL, event_seq = event_seq + 1"
		" WHERE tenant_id = ?1 AND id = ?2 AND state IN ('queued', 'running') RETURNING seq";
	sqlite3_stmt *st;
	int64_t seq = 0;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_text(st, 2, id, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 3, db_now_ms());
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		seq = sqlite3_column_int64(st, 0);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW) {
		rc = add_event(db, seq, "state", e);
		if (!rc)
			rc = record_duration(db, seq, e);
	} else {
		rc = rc == SQLITE_DONE ? 0 : sq_fail(db, e, "cancelling job");
	}
	if (rc)
		goto out;
	if ((rc = sq_commit(db, e)))
		return rc;
	return sq_get(db, tenant_id, id, out, e);
out:
	sq_rollback(db);
	return rc;
}

const char *queue_claim_sql(void)
{
	/* Round-robin: among tenants with a runnable queued job and a free
	 * slot, the one served longest ago; its oldest runnable job.  The
	 * inner lookups walk jobs_tenant_state, the outer tenants_served
	 * (test_db.c checks the plan). */
	static const char sql[] =
		"UPDATE jobs SET state = 'running', attempt = attempt + 1, lease_expires = ?1 + ?2,"
		" worker = ?3, started_at = coalesce(started_at, ?1), stage = 'starting',"
		" event_seq = event_seq + 1"
		" WHERE seq = ("
		"  SELECT (SELECT q.seq FROM jobs q WHERE q.tenant_id = t.id AND q.state = 'queued'"
		"          AND q.run_after <= ?1 ORDER BY q.seq LIMIT 1) AS next_seq"
		"  FROM tenants t"
		"  WHERE next_seq IS NOT NULL"
		"   AND (SELECT count(*) FROM jobs r WHERE r.tenant_id = t.id"
		"        AND r.state = 'running') < t.max_jobs"
		"  ORDER BY t.served_seq, t.id LIMIT 1)"
		" RETURNING seq, tenant_id";
	return sql;
}

int sq_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
		int *got, struct err *e)
{
	const char *claim_sql = queue_claim_sql();
	static const char seq_sql[] =
		"UPDATE meta SET value = value + 1 WHERE key = 'serve_seq' RETURNING value";
	static const char served_sql[] = "UPDATE tenants SET served_seq = ?2 WHERE id = ?1";
	sqlite3_stmt *st;
	int64_t seq = 0, tenant = 0, serve = 0, now = db_now_ms();
	int rc;

	*got = 0;
	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, claim_sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_int64(st, 1, now);
	sqlite3_bind_int64(st, 2, lease_ms);
	sqlite3_bind_text(st, 3, worker, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		seq = sqlite3_column_int64(st, 0);
		tenant = sqlite3_column_int64(st, 1);
	}
	sqlite3_reset(st);
	if (rc == SQLITE_DONE) {
		sq_rollback(db);
		return 0;
	}
	if (rc != SQLITE_ROW) {
		rc = sq_fail(db, e, "claiming job");
		goto out;
	}
	if (!(st = sq_stmt(db, seq_sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		serve = sqlite3_column_int64(st, 0);
	sqlite3_reset(st);
	if (rc != SQLITE_ROW) {
		rc = sq_fail(db, e, "claiming job");
		goto out;
	}
	if (!(st = sq_stmt(db, served_sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_int64(st, 1, tenant);
	sqlite3_bind_int64(st, 2, serve);
	if ((rc = step_done(db, st, "claiming job", e)) || (rc = add_event(db, seq, "state", e)))
		goto out;
	if ((rc = sq_commit(db, e)))
		return rc;
	if ((rc = sq_get_seq(db, seq, out, e)))
		return rc;
	*got = 1;
	return 0;
out:
	sq_rollback(db);
	return rc;
}

int sq_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e)
{
	static const char sql[] = "UPDATE jobs SET lease_expires = ?3"
				  " WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	sqlite3_stmt *st;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int(st, 2, attempt);
	sqlite3_bind_int64(st, 3, db_now_ms() + lease_ms);
	if ((rc = step_done(db, st, "heartbeat", e))) {
		sq_rollback(db);
		return rc;
	}
	rc = sqlite3_changes(SQ(db));
	if (sq_commit(db, e))
		return ERR_IO;
	return rc == 1;
}

int sq_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
		   int64_t lease_ms, struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET stage = ?3, progress = max(progress, min(1.0, ?4)),"
		" layers_done = ?5, layers_total = ?6, lease_expires = ?7, event_seq = event_seq + 1"
		" WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	sqlite3_stmt *st;
	int rc, changed;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int(st, 2, attempt);
	sqlite3_bind_text(st, 3, p->stage ? p->stage : "running", -1, SQLITE_TRANSIENT);
	sqlite3_bind_double(st, 4, p->fraction >= 0 ? p->fraction : 0);
	sqlite3_bind_int(st, 5, p->layers_done);
	sqlite3_bind_int(st, 6, p->layers_total);
	sqlite3_bind_int64(st, 7, db_now_ms() + lease_ms);
	if ((rc = step_done(db, st, "progress", e)))
		goto out;
	changed = sqlite3_changes(SQ(db));
	if (changed && (rc = add_event(db, seq, "progress", e)))
		goto out;
	if ((rc = sq_commit(db, e)))
		return rc;
	return changed == 1;
out:
	sq_rollback(db);
	return rc;
}

/* The fenced row's (attempt, max_attempts), or 0 when not ours. */
static int fenced_row(struct db *db, int64_t seq, int attempt, int *max_attempts,
		      int64_t *tenant_id, struct err *e)
{
	static const char sql[] = "SELECT max_attempts, tenant_id FROM jobs"
				  " WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int(st, 2, attempt);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		*max_attempts = sqlite3_column_int(st, 0);
		*tenant_id = sqlite3_column_int64(st, 1);
	}
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		return 1;
	return rc == SQLITE_DONE ? 0 : sq_fail(db, e, "reading job");
}

/* ERR_LIMIT when bytes more would take the tenant past its storage quota
 * (checked in the caller's transaction, so concurrent jobs of a tenant
 * cannot pass it together). */
static int quota_room(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e)
{
	static const char sql[] = "SELECT quota_bytes, used_bytes FROM tenants WHERE id = ?1";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int64_t quota = 0, used = 0;
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, tenant_id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		quota = sqlite3_column_int64(st, 0);
		used = sqlite3_column_int64(st, 1);
	}
	sqlite3_reset(st);
	if (rc != SQLITE_ROW && rc != SQLITE_DONE)
		return sq_fail(db, e, "reading the quota");
	if (quota > 0 && used + bytes > quota)
		return ERR_SET(e, ERR_LIMIT,
			       "the output (%lld bytes) would take the tenant past its storage quota "
			       "of %lld bytes (%lld in use)",
			       (long long)bytes, (long long)quota, (long long)used);
	return 0;
}

int sq_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		  const char *metrics_json, struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET state = 'succeeded', stage = 'done', progress = 1.0,"
		/* The metrics' layer count is final: a short job can exit before
		 * its worker wrote any progress row with the total. */
		" layers_total = COALESCE(json_extract(?7, '$.layers'), layers_total),"
		" layers_done = COALESCE(json_extract(?7, '$.layers'), layers_total),"
		" finished_at = ?3, artifact = ?4, artifact_bytes = ?5,"
		" artifact_sha256 = ?6, metrics = ?7, mesh_name = ?8, lease_expires = NULL,"
		" worker = NULL,"
		" error_type = NULL, error = NULL, error_field = NULL, event_seq = event_seq + 1"
		" WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	int max_attempts, rc, ours;
	int64_t tenant_id;
	sqlite3_stmt *st;

	if ((rc = sq_begin(db, e)))
		return rc;
	ours = fenced_row(db, seq, attempt, &max_attempts, &tenant_id, e);
	if (ours <= 0) {
		sq_rollback(db);
		return ours;
	}
	if (!(st = sq_stmt(db, sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int(st, 2, attempt);
	sqlite3_bind_int64(st, 3, db_now_ms());
	sqlite3_bind_text(st, 4, a->name, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 5, a->bytes);
	sqlite3_bind_text(st, 6, a->sha256, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 7, metrics_json ? metrics_json : "{}", -1, SQLITE_STATIC);
	if (a->mesh_name)
		sqlite3_bind_text(st, 8, a->mesh_name, -1, SQLITE_STATIC);
	if ((rc = quota_room(db, tenant_id, a->bytes, e)) ||
	    (rc = step_done(db, st, "completing job", e)) ||
	    (rc = sq_tenant_add_usage(db, tenant_id, a->bytes, e)) ||
	    (rc = add_event(db, seq, "state", e)) || (rc = record_duration(db, seq, e)))
		goto out;
	if ((rc = sq_commit(db, e)))
		return rc;
	return 1;
out:
	sq_rollback(db);
	return rc;
}

/* sq_fail_job() inside the caller's transaction. */
static int fail_locked(struct db *db, int64_t seq, int attempt, int max_attempts,
		       const struct job_failure *f, struct err *e)
{
	static const char retry_sql[] =
		"UPDATE jobs SET state = 'queued', stage = 'retrying', run_after = ?3,"
		" lease_expires = NULL, worker = NULL, error_type = ?4, error = ?5,"
		" error_field = ?6, event_seq = event_seq + 1"
		" WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	static const char fail_sql[] =
		"UPDATE jobs SET state = 'failed', stage = 'failed', finished_at = ?3,"
		" lease_expires = NULL, worker = NULL, error_type = ?4, error = ?5,"
		" error_field = ?6, event_seq = event_seq + 1"
		" WHERE seq = ?1 AND attempt = ?2 AND state = 'running'";
	int retry = f->retryable && attempt < max_attempts;
	sqlite3_stmt *st = sq_stmt(db, retry ? retry_sql : fail_sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int(st, 2, attempt);
	sqlite3_bind_int64(st, 3, db_now_ms() + (retry ? queue_backoff_ms(attempt) : 0));
	sqlite3_bind_text(st, 4, f->type ? f->type : "internal", -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 5, f->message ? f->message : "", -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 6, f->field ? f->field : "", -1, SQLITE_STATIC);
	if ((rc = step_done(db, st, "failing job", e)) || (rc = add_event(db, seq, "state", e)))
		return rc;
	return retry ? 0 : record_duration(db, seq, e);
}

int sq_fail_job(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
	       struct err *e)
{
	int max_attempts, rc, ours;
	int64_t tenant_id;

	if ((rc = sq_begin(db, e)))
		return rc;
	ours = fenced_row(db, seq, attempt, &max_attempts, &tenant_id, e);
	if (ours <= 0) {
		sq_rollback(db);
		return ours;
	}
	if ((rc = fail_locked(db, seq, attempt, max_attempts, f, e))) {
		sq_rollback(db);
		return rc;
	}
	return sq_commit(db, e) ? ERR_IO : 1;
}

int sq_rescue(struct db *db, const char *worker, int *n, struct err *e)
{
	static const char lease_sql[] = "SELECT seq, attempt, max_attempts FROM jobs"
					" WHERE state = 'running' AND lease_expires < ?1";
	static const char worker_sql[] = "SELECT seq, attempt, max_attempts FROM jobs"
					 " WHERE state = 'running' AND (?2 = '*' OR worker = ?2)";
	struct job_failure f = {"lost", NULL, "", 1};
	struct { int64_t seq; int attempt, max; } v[64];
	sqlite3_stmt *st;
	int cnt = 0, rc;

	*n = 0;
	f.message = worker ? "the worker running this attempt stopped"
			   : "the worker running this attempt stopped renewing its lease";
	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, worker ? worker_sql : lease_sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_int64(st, 1, db_now_ms());
	if (worker)
		sqlite3_bind_text(st, 2, worker, -1, SQLITE_STATIC);
	while (cnt < 64 && (rc = sqlite3_step(st)) == SQLITE_ROW) {
		v[cnt].seq = sqlite3_column_int64(st, 0);
		v[cnt].attempt = sqlite3_column_int(st, 1);
		v[cnt].max = sqlite3_column_int(st, 2);
		cnt++;
	}
	sqlite3_reset(st);
	for (int i = 0; i < cnt; i++)
		if ((rc = fail_locked(db, v[i].seq, v[i].attempt, v[i].max, &f, e))) {
			sq_rollback(db);
			return rc;
		}
	if ((rc = sq_commit(db, e)))
		return rc;
	*n = cnt;
	return 0;
}

int sq_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		 int *n, struct err *e)
{
	static const char sql[] = "SELECT n, type, data FROM job_events"
				  " WHERE job_seq = ?1 AND n > ?2 ORDER BY n LIMIT ?3";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	struct job_event *a;
	int cnt = 0, rc;

	if (!st)
		return ERR_IO;
	if (limit < 1)
		limit = 1;
	if (!(a = calloc((size_t)limit, sizeof *a))) {
		sqlite3_reset(st);
		return ERR_SET(e, ERR_NOMEM, "out of memory reading events");
	}
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int64(st, 2, after);
	sqlite3_bind_int(st, 3, limit);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		a[cnt].n = sqlite3_column_int64(st, 0);
		sq_col_copy(st, 1, a[cnt].type, sizeof a[cnt].type);
		if (!(a[cnt].data = sq_col_dup(st, 2))) {
			rc = SQLITE_NOMEM;
			break;
		}
		cnt++;
	}
	sqlite3_reset(st);
	if (rc != SQLITE_DONE) {
		queue_events_free(a, cnt);
		return sq_fail(db, e, "reading events");
	}
	*v = a;
	*n = cnt;
	return 0;
}

int sq_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e)
{
	static const char sql[] = "SELECT state, count(*) FROM jobs GROUP BY state";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	memset(counts, 0, sizeof(int64_t) * JOB_STATE_COUNT);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		int s = queue_state_parse(sq_col_text(st, 0));
		if (s >= 0)
			counts[s] = sqlite3_column_int64(st, 1);
	}
	sqlite3_reset(st);
	return rc == SQLITE_DONE ? 0 : sq_fail(db, e, "counting jobs");
}

int sq_durations(struct db *db, struct queue_durations *d, struct err *e)
{
	static const char b_sql[] = "SELECT state, le, count FROM job_durations";
	static const char s_sql[] = "SELECT state, count, sum_s FROM job_duration_sums";
	sqlite3_stmt *st;
	int rc;

	memset(d, 0, sizeof *d);
	if (!(st = sq_stmt(db, b_sql, e)))
		return ERR_IO;
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		int s = queue_state_parse(sq_col_text(st, 0)) - JOB_SUCCEEDED;
		double le = sqlite3_column_double(st, 1);
		if (s < 0 || s > 2)
			continue;
		/* Cumulative: a job in bucket le counts in every bucket >= le. */
		for (int i = 0; i < QUEUE_DURATION_BUCKETS; i++)
			if (le >= 0 && le <= queue_duration_le[i])
				d->bucket[s][i] += sqlite3_column_int64(st, 2);
	}
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		return sq_fail(db, e, "reading durations");
	if (!(st = sq_stmt(db, s_sql, e)))
		return ERR_IO;
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		int s = queue_state_parse(sq_col_text(st, 0)) - JOB_SUCCEEDED;
		if (s < 0 || s > 2)
			continue;
		d->count[s] = sqlite3_column_int64(st, 1);
		d->sum_s[s] = sqlite3_column_double(st, 2);
	}
	sqlite3_reset(st);
	return rc == SQLITE_DONE ? 0 : sq_fail(db, e, "reading durations");
}

int sq_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit,
			   struct expired_artifact **v, int *n, struct err *e)
{
	static const char sel_sql[] =
		"SELECT seq, tenant_id, artifact, artifact_bytes FROM jobs"
		" WHERE artifact IS NOT NULL AND finished_at < ?1 ORDER BY finished_at LIMIT ?2";
	static const char clr_sql[] = "UPDATE jobs SET artifact = NULL WHERE seq = ?1";
	static const char ev_sql[] =
		"DELETE FROM job_events WHERE job_seq = ?1";
	struct expired_artifact *a;
	sqlite3_stmt *st;
	int64_t *seqs = NULL, *bytes = NULL;
	int cnt = 0, rc;

	if (limit < 1)
		limit = 1;
	a = calloc((size_t)limit, sizeof *a);
	seqs = calloc((size_t)limit, sizeof *seqs);
	bytes = calloc((size_t)limit, sizeof *bytes);
	if (!a || !seqs || !bytes) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory expiring artifacts");
		goto fail;
	}
	if ((rc = sq_begin(db, e)))
		goto fail;
	if (!(st = sq_stmt(db, sel_sql, e))) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_int64(st, 1, cutoff_ms);
	sqlite3_bind_int(st, 2, limit);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		seqs[cnt] = sqlite3_column_int64(st, 0);
		a[cnt].tenant_id = sqlite3_column_int64(st, 1);
		sq_col_copy(st, 2, a[cnt].name, sizeof a[cnt].name);
		bytes[cnt] = sqlite3_column_int64(st, 3);
		cnt++;
	}
	sqlite3_reset(st);
	if (rc != SQLITE_DONE) {
		rc = sq_fail(db, e, "expiring artifacts");
		goto out;
	}
	rc = 0;
	for (int i = 0; i < cnt && !rc; i++) {
		if (!(st = sq_stmt(db, clr_sql, e))) {
			rc = ERR_IO;
			break;
		}
		sqlite3_bind_int64(st, 1, seqs[i]);
		if ((rc = step_done(db, st, "expiring artifacts", e)))
			break;
		if (!(st = sq_stmt(db, ev_sql, e))) {
			rc = ERR_IO;
			break;
		}
		sqlite3_bind_int64(st, 1, seqs[i]);
		if (!(rc = step_done(db, st, "expiring artifacts", e)))
			rc = sq_tenant_add_usage(db, a[i].tenant_id, -bytes[i], e);
	}
	if (!rc)
		rc = sq_commit(db, e);
out:
	if (rc)
		sq_rollback(db);
fail:
	free(seqs);
	free(bytes);
	if (rc) {
		free(a);
		return rc;
	}
	*v = a;
	*n = cnt;
	return 0;
}

int sq_artifact_referenced(struct db *db, const char *job_id, const char *name)
{
	static const char sql[] = "SELECT 1 FROM jobs WHERE id = ?1 AND artifact = ?2";
	sqlite3_stmt *st = sq_stmt(db, sql, NULL);
	int rc;

	if (!st)
		return 1; /* when unsure, keep the file */
	sqlite3_bind_text(st, 1, job_id, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 2, name, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	return rc != SQLITE_DONE;
}

int sq_savepoint(struct db *db, int end, int undo, struct err *e)
{
	return sq_exec(db, !end ? "SAVEPOINT one" : undo ? "ROLLBACK TO one; RELEASE one" : "RELEASE one",
		       e);
}
