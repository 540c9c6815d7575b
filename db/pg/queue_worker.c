/* queue_worker.c - the PostgreSQL job queue, worker side: the fair claim,
 * fenced heartbeats, progress and completion, and the rescuer (queue.h).
 *
 * Worker writes are fenced by "seq = $1 AND attempt = $2 AND state =
 * 'running'", checked on the row as it is when the UPDATE (or SELECT ...
 * FOR UPDATE) holds its lock: under READ COMMITTED a statement that waited
 * for a concurrent writer re-evaluates its WHERE on the version that
 * writer committed, so a cancelled or rescued attempt changes nothing.
 *
 * The claim, and why it is correct with many claimers on many machines:
 *
 *  1. One statement lists candidate tenants in round-robin order
 *     (served_seq, id): a runnable queued job (run_after <= now) and,
 *     by that statement's snapshot, a free slot under max_jobs.
 *  2. For each candidate the claimer takes the tenant's claim lock, a
 *     session advisory lock PGDB_LOCK_CLAIM(id), first without waiting
 *     (a busy tenant is passed over, so claimers spread over tenants and
 *     run in parallel), and, when nothing else could be claimed, waiting
 *     for it.  A claimer holds at most one claim lock at a time (it lets
 *     go of a tenant it passes), so claimers cannot deadlock.  An advisory
 *     lock rather than SELECT ... FOR UPDATE on the tenant row: that row
 *     is also written by every charge of used_bytes, which would make
 *     claims skip or wait for uploads.
 *  3. With the lock held, a new statement (a new snapshot) counts the
 *     tenant's running jobs.  The lock is released only after COMMIT, so
 *     this count includes every earlier claim of the tenant: claims of one
 *     tenant are serialised and max_jobs is never exceeded.  Nothing but a
 *     claim makes a job running; succeed/fail/cancel/rescue only lower the
 *     count meanwhile, which errs on the safe side.
 *  4. The oldest runnable job is taken with FOR UPDATE SKIP LOCKED and its
 *     state re-checked on the locked row: a job another transaction is
 *     cancelling is skipped, one cancelled or claimed since the snapshot
 *     is no longer 'queued', so no job is ever claimed twice.  A cancel
 *     that comes after waits for the claim's row lock and then cancels
 *     the running attempt (its worker's fenced writes fail).
 *  5. served_seq = nextval('serve_seq') moves the tenant to the back of
 *     the round-robin; the event is appended and notified; COMMIT; unlock.
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <string.h>

#define CAND_MAX 8    /* candidate tenants per statement */
#define CLAIM_ROUNDS 4
#define EXCLUDE_MAX (CAND_MAX * CLAIM_ROUNDS)

/* Take the claim lock of tenant_id: 1 held, 0 busy (only when !wait),
 * ERR_IO. */
static int tenant_lock(struct db *db, int64_t tenant_id, int wait, struct err *e)
{
	static const char try_sql[] = "SELECT pg_try_advisory_lock($1::bigint)";
	static const char wait_sql[] = "SELECT pg_advisory_lock($1::bigint), true";
	struct pgdb_params p;
	PGresult *r;
	int held;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, PGDB_LOCK_CLAIM(tenant_id));
	if (!(r = pgdb_q(db, wait ? wait_sql : try_sql, &p, "locking tenant for a claim", e)))
		return ERR_IO;
	held = !strcmp(pgdb_text(r, 0, wait ? 1 : 0), "t");
	PQclear(r);
	return held;
}

/* Release it (outside or inside a live transaction); when that fails,
 * pgdb_claim() releases all (release_all()). */
static void tenant_unlock(struct db *db, int64_t tenant_id)
{
	static const char sql[] = "SELECT pg_advisory_unlock($1::bigint)";
	struct pgdb_params p;
	PGresult *r;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, PGDB_LOCK_CLAIM(tenant_id));
	if ((r = pgdb_q(db, sql, &p, "unlocking tenant", NULL)))
		PQclear(r);
}

/* After a failed claim (rolled back): no claim lock may stay with the
 * session, or every claim of that tenant would wait for it; the claim
 * locks are the only session-level locks db/pg takes.  When even this
 * fails, a new session drops them. */
static void release_all(struct db *db)
{
	PGresult *r = pgdb_q(db, "SELECT pg_advisory_unlock_all()", NULL, "unlocking", NULL);

	if (r)
		PQclear(r);
	else
		pgdb_reconnect(db, NULL);
}

/* With tenant_id's claim lock held: claim its oldest runnable job.  1
 * claimed (*seq), 0 nothing (at max_jobs, or no runnable job any more),
 * ERR_IO. */
static int claim_tenant(struct db *db, int64_t tenant_id, int max_jobs, const char *worker,
			int64_t now, int64_t lease_ms, int64_t *seq, struct err *e)
{
	static const char count_sql[] = "SELECT count(*) FROM jobs"
					" WHERE tenant_id = $1::bigint AND state = 'running'";
	/* The pick walks jobs_queued (schema.c), whatever the statistics:
	 * with "tenant_id = $1" the planner took the primary key's order for
	 * (tenant_id, seq) and filtered its way past every finished job (the
	 * old rows are the finished ones, which its uniform estimate does not
	 * know: 1.5 ms at 100k jobs and growing).  A range on tenant_id keeps
	 * tenant_id in the sort key, so only an index on (tenant_id, seq)
	 * gives the order, and the session's generic plans (conn.c) take the
	 * partial one. */
	static const char pick_sql[] =
		"UPDATE jobs SET state = 'running', attempt = attempt + 1,"
		" lease_expires = $2::bigint + $3::bigint, worker = $4::text,"
		" started_at = coalesce(started_at, $2::bigint), stage = 'starting',"
		" event_seq = event_seq + 1"
		" WHERE seq = (SELECT q.seq FROM jobs q"
		"   WHERE q.tenant_id BETWEEN $1::bigint AND $1::bigint"
		"   AND q.state = 'queued' AND q.run_after <= $2::bigint ORDER BY q.tenant_id, q.seq LIMIT 1"
		"   FOR UPDATE SKIP LOCKED)"
		"  AND state = 'queued'"
		" RETURNING seq";
	static const char served_sql[] =
		"UPDATE tenants SET served_seq = nextval('serve_seq') WHERE id = $1::bigint";
	struct pgdb_params p;
	PGresult *r;
	int64_t running;
	int got;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	if (!(r = pgdb_q(db, count_sql, &p, "claiming job", e)))
		return ERR_IO;
	running = pgdb_i64(r, 0, 0);
	PQclear(r);
	if (running >= max_jobs)
		return 0;
	pgdb_p_i64(&p, now);
	pgdb_p_i64(&p, lease_ms);
	pgdb_p_text(&p, worker);
	if (!(r = pgdb_q(db, pick_sql, &p, "claiming job", e)))
		return ERR_IO;
	got = PQntuples(r) == 1;
	if (got)
		*seq = pgdb_i64(r, 0, 0);
	PQclear(r);
	if (!got)
		return 0;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	if (pgdb_run(db, served_sql, &p, "claiming job", e) ||
	    pgdb_add_event(db, *seq, "state", e))
		return ERR_IO;
	return 1;
}

/* "{1,2,3}": the tenants already tried, as a bigint[] parameter. */
static void id_array(const int64_t *ids, int n, char *buf, size_t len)
{
	size_t k = (size_t)snprintf(buf, len, "{");

	for (int i = 0; i < n && k < len; i++)
		k += (size_t)snprintf(buf + k, len - k, "%s%lld", i ? "," : "", (long long)ids[i]);
	if (k < len)
		snprintf(buf + k, len - k, "}");
}

/* One round: candidates not in excl; 1 claimed (*seq, committed), 0 none
 * (those tried are added to excl; *more = 1 when further candidates may
 * exist), ERR_IO (rolled back). */
static int claim_round(struct db *db, const char *worker, int64_t now, int64_t lease_ms,
		       int64_t *excl, int *nexcl, int *more, int64_t *seq, struct err *e)
{
	static const char cand_sql[] =
		"SELECT t.id, t.max_jobs FROM tenants t"
		" WHERE t.id <> ALL($2::bigint[])"
		"  AND EXISTS (SELECT 1 FROM jobs q WHERE q.tenant_id = t.id AND q.state = 'queued'"
		"   AND q.run_after <= $1::bigint)"
		"  AND (SELECT count(*) FROM jobs r WHERE r.tenant_id = t.id"
		"   AND r.state = 'running') < t.max_jobs"
		" ORDER BY t.served_seq, t.id LIMIT $3::int";
	int64_t cand[CAND_MAX], busy[CAND_MAX];
	int maxj[CAND_MAX], busy_max[CAND_MAX], ncand, nbusy = 0, rc;
	char arr[EXCLUDE_MAX * 21 + 4];
	struct pgdb_params p;
	PGresult *r;

	*more = 0;
	id_array(excl, *nexcl, arr, sizeof arr);
	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, now);
	pgdb_p_text(&p, arr);
	pgdb_p_i64(&p, CAND_MAX);
	if (!(r = pgdb_q(db, cand_sql, &p, "claiming job", e))) {
		pgdb_rollback(db);
		return ERR_IO;
	}
	ncand = PQntuples(r) < CAND_MAX ? PQntuples(r) : CAND_MAX;
	for (int i = 0; i < ncand; i++) {
		cand[i] = pgdb_i64(r, i, 0);
		maxj[i] = pgdb_int(r, i, 1);
	}
	PQclear(r);
	*more = ncand == CAND_MAX;
	/* Pass 0 passes busy tenants over; pass 1 waits for them. */
	for (int pass = 0; pass < 2; pass++) {
		int n = pass ? nbusy : ncand;
		for (int i = 0; i < n; i++) {
			int64_t t = pass ? busy[i] : cand[i];
			int mj = pass ? busy_max[i] : maxj[i], held, got;

			if ((held = tenant_lock(db, t, pass, e)) < 0)
				goto fail;
			if (!held) {
				busy[nbusy] = t;
				busy_max[nbusy++] = mj;
				continue;
			}
			got = claim_tenant(db, t, mj, worker, now, lease_ms, seq, e);
			if (got == 1 && !(rc = pgdb_commit(db, e))) {
				tenant_unlock(db, t);
				return 1;
			}
			if (got < 0 || rc) {
				pgdb_rollback(db);
				tenant_unlock(db, t);
				return got < 0 ? got : rc;
			}
			tenant_unlock(db, t);
			if (*nexcl < EXCLUDE_MAX)
				excl[(*nexcl)++] = t;
		}
	}
	pgdb_rollback(db);
	return 0;
fail:
	pgdb_rollback(db);
	return ERR_IO;
}

int pgdb_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
	       int *got, struct err *e)
{
	int64_t excl[EXCLUDE_MAX], seq = 0, now = db_now_ms();
	int nexcl = 0, more = 1, rc = 0;

	*got = 0;
	for (int round = 0; round < CLAIM_ROUNDS && more && !rc; round++)
		rc = claim_round(db, worker, now, lease_ms, excl, &nexcl, &more, &seq, e);
	if (rc < 0)
		release_all(db);
	if (rc <= 0)
		return rc;
	if ((rc = pgdb_get_seq(db, seq, out, e)))
		return rc;
	*got = 1;
	return 0;
}

int pgdb_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET lease_expires = $3::bigint"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running'";
	struct pgdb_params p;
	PGresult *r;
	int64_t changed;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, attempt);
	pgdb_p_i64(&p, db_now_ms() + lease_ms);
	if (!(r = pgdb_q(db, sql, &p, "heartbeat", e))) {
		pgdb_rollback(db);
		return ERR_IO;
	}
	changed = pgdb_changes(r);
	PQclear(r);
	if (pgdb_commit(db, e))
		return ERR_IO;
	return changed == 1;
}

int pgdb_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *pr,
		  int64_t lease_ms, struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET stage = $3::text,"
		" progress = greatest(progress, least(1.0, $4::float8)),"
		" layers_done = $5::int, layers_total = $6::int, lease_expires = $7::bigint,"
		" event_seq = event_seq + 1"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running'";
	struct pgdb_params p;
	PGresult *r;
	int64_t changed;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, attempt);
	pgdb_p_text(&p, pr->stage ? pr->stage : "running");
	pgdb_p_f64(&p, pr->fraction >= 0 ? pr->fraction : 0);
	pgdb_p_i64(&p, pr->layers_done);
	pgdb_p_i64(&p, pr->layers_total);
	pgdb_p_i64(&p, db_now_ms() + lease_ms);
	if (!(r = pgdb_q(db, sql, &p, "progress", e))) {
		rc = ERR_IO;
		goto out;
	}
	changed = pgdb_changes(r);
	PQclear(r);
	if (changed && (rc = pgdb_add_event(db, seq, "progress", e)))
		goto out;
	if ((rc = pgdb_commit(db, e)))
		return rc;
	return changed == 1;
out:
	pgdb_rollback(db);
	return rc;
}

/* Lock the fenced row: 1 (with its max_attempts and tenant), 0 when the
 * job no longer runs this attempt, ERR_IO. */
static int fenced_row(struct db *db, int64_t seq, int attempt, int *max_attempts,
		      int64_t *tenant_id, struct err *e)
{
	static const char sql[] =
		"SELECT max_attempts, tenant_id FROM jobs"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running' FOR UPDATE";
	struct pgdb_params p;
	PGresult *r;
	int ours;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, attempt);
	if (!(r = pgdb_q(db, sql, &p, "reading job", e)))
		return ERR_IO;
	ours = PQntuples(r) == 1;
	if (ours) {
		*max_attempts = pgdb_int(r, 0, 0);
		*tenant_id = pgdb_i64(r, 0, 1);
	}
	PQclear(r);
	return ours;
}

int pgdb_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		 const char *metrics_json, struct err *e)
{
	/* The metrics' layer count is final: a short job can exit before its
	 * worker wrote any progress row with the total. */
	static const char sql[] =
		"UPDATE jobs SET state = 'succeeded', stage = 'done', progress = 1.0,"
		" layers_total = COALESCE(CASE WHEN jsonb_typeof($7::text::jsonb -> 'layers') ="
		"  'number' THEN ($7::text::jsonb ->> 'layers')::numeric::int END, layers_total),"
		" layers_done = COALESCE(CASE WHEN jsonb_typeof($7::text::jsonb -> 'layers') ="
		"  'number' THEN ($7::text::jsonb ->> 'layers')::numeric::int END, layers_total),"
		" finished_at = $3::bigint, artifact = $4::text, artifact_bytes = $5::bigint,"
		" artifact_sha256 = $6::text, metrics = $7::text, mesh_name = $8::text,"
		" lease_expires = NULL, worker = NULL,"
		" error_type = NULL, error = NULL, error_field = NULL, event_seq = event_seq + 1"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running'";
	int max_attempts, rc, ours;
	struct pgdb_params p;
	int64_t tenant_id;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	ours = fenced_row(db, seq, attempt, &max_attempts, &tenant_id, e);
	if (ours <= 0) {
		pgdb_rollback(db);
		return ours;
	}
	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, attempt);
	pgdb_p_i64(&p, db_now_ms());
	pgdb_p_text(&p, a->name);
	pgdb_p_i64(&p, a->bytes);
	pgdb_p_text(&p, a->sha256);
	pgdb_p_text(&p, metrics_json ? metrics_json : "{}");
	pgdb_p_text(&p, a->mesh_name);
	/* Checked and charged in one statement (tenants.c): concurrent jobs
	 * of a tenant cannot pass the quota together. */
	if ((rc = pgdb_charge_locked(db, tenant_id, a->bytes, "the output", e)) ||
	    (rc = pgdb_run(db, sql, &p, "completing job", e)) ||
	    (rc = pgdb_add_event(db, seq, "state", e)) ||
	    (rc = pgdb_record_duration(db, seq, e)))
		goto out;
	if ((rc = pgdb_commit(db, e)))
		return rc;
	return 1;
out:
	pgdb_rollback(db);
	return rc;
}

/* Fail the attempt inside the caller's transaction, the row locked. */
static int fail_locked(struct db *db, int64_t seq, int attempt, int max_attempts,
		       const struct job_failure *f, struct err *e)
{
	static const char retry_sql[] =
		"UPDATE jobs SET state = 'queued', stage = 'retrying', run_after = $3::bigint,"
		" lease_expires = NULL, worker = NULL, error_type = $4::text, error = $5::text,"
		" error_field = $6::text, event_seq = event_seq + 1"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running'";
	static const char fail_sql[] =
		"UPDATE jobs SET state = 'failed', stage = 'failed', finished_at = $3::bigint,"
		" lease_expires = NULL, worker = NULL, error_type = $4::text, error = $5::text,"
		" error_field = $6::text, event_seq = event_seq + 1"
		" WHERE seq = $1::bigint AND attempt = $2::int AND state = 'running'";
	int retry = f->retryable && attempt < max_attempts, rc;
	struct pgdb_params p;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, attempt);
	pgdb_p_i64(&p, db_now_ms() + (retry ? queue_backoff_ms(attempt) : 0));
	pgdb_p_text(&p, f->type ? f->type : "internal");
	pgdb_p_text(&p, f->message ? f->message : "");
	pgdb_p_text(&p, f->field ? f->field : "");
	if ((rc = pgdb_run(db, retry ? retry_sql : fail_sql, &p, "failing job", e)) ||
	    (rc = pgdb_add_event(db, seq, "state", e)))
		return rc;
	return retry ? 0 : pgdb_record_duration(db, seq, e);
}

int pgdb_fail_job(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
		  struct err *e)
{
	int max_attempts, rc, ours;
	int64_t tenant_id;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	ours = fenced_row(db, seq, attempt, &max_attempts, &tenant_id, e);
	if (ours <= 0) {
		pgdb_rollback(db);
		return ours;
	}
	if ((rc = fail_locked(db, seq, attempt, max_attempts, f, e))) {
		pgdb_rollback(db);
		return rc;
	}
	return pgdb_commit(db, e) ? ERR_IO : 1;
}

int pgdb_rescue(struct db *db, const char *worker, int *n, struct err *e)
{
	/* An expired lease whose row is locked is being renewed or finished
	 * right now: SKIP LOCKED leaves it (the next sweep looks again).  A
	 * dead worker's jobs are all taken, waiting for their locks. */
	static const char lease_sql[] =
		"SELECT seq, attempt, max_attempts FROM jobs"
		" WHERE state = 'running' AND lease_expires < $1::bigint ORDER BY seq LIMIT 64"
		" FOR UPDATE SKIP LOCKED";
	static const char worker_sql[] =
		"SELECT seq, attempt, max_attempts FROM jobs"
		" WHERE state = 'running' AND ($1::text = '*' OR worker = $1::text) ORDER BY seq"
		" LIMIT 64 FOR UPDATE";
	struct job_failure f = {"lost", NULL, "", 1};
	struct pgdb_params p;
	PGresult *r;
	int cnt, rc = 0;

	*n = 0;
	f.message = worker ? "the worker running this attempt stopped"
			   : "the worker running this attempt stopped renewing its lease";
	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	if (worker)
		pgdb_p_text(&p, worker);
	else
		pgdb_p_i64(&p, db_now_ms());
	if (!(r = pgdb_q(db, worker ? worker_sql : lease_sql, &p, "rescuing jobs", e))) {
		pgdb_rollback(db);
		return ERR_IO;
	}
	cnt = PQntuples(r);
	for (int i = 0; i < cnt && !rc; i++)
		rc = fail_locked(db, pgdb_i64(r, i, 0), pgdb_int(r, i, 1), pgdb_int(r, i, 2), &f, e);
	PQclear(r);
	if (rc) {
		pgdb_rollback(db);
		return rc;
	}
	if ((rc = pgdb_commit(db, e)))
		return rc;
	*n = cnt;
	return 0;
}
