/* queue.h - the job queue: submit, claim, lease, progress, finish.
 *
 * At-least-once delivery: a worker claims a job with a lease and extends
 * it by heartbeats; the rescuer re-queues jobs whose lease expired.  The
 * attempt number is a fencing token: every heartbeat, progress write and
 * completion names (seq, attempt) and changes nothing unless the job is
 * still running that attempt, so a stale worker cannot overwrite a re-run
 * or a cancellation.  Claims are fair: round-robin over tenants with
 * queued work and a free slot under their max_jobs.  Each visible change
 * appends a row to job_events (the SSE stream).  Design: docs/service.md.
 */
#ifndef INFILLD_DB_QUEUE_H
#define INFILLD_DB_QUEUE_H

#include <stdint.h>

#include "db/db.h"
#include "engine/core/err.h"

enum job_state { JOB_QUEUED, JOB_RUNNING, JOB_SUCCEEDED, JOB_FAILED, JOB_CANCELLED,
		 JOB_STATE_COUNT };

const char *queue_state_name(int state);
/* -1 if unknown. */
int queue_state_parse(const char *name);

struct job_row {
	int64_t seq;              /* queue order; list cursors use it */
	char id[DB_ID_MAX];
	int64_t tenant_id;
	char mesh_id[DB_ID_MAX];
	char engine[32], format[16], printer[32];
	char *params;             /* JSON object text, owned */
	char fault[16];           /* fault injection (test runs only), "" */
	int state;                /* enum job_state */
	char stage[32];
	double progress;          /* 0..1, never decreases */
	int layers_done, layers_total;
	int attempt, max_attempts;
	int64_t created_ms, started_ms, finished_ms; /* 0 = not yet */
	int64_t run_after_ms, lease_expires_ms;
	char error_type[24];      /* err_code_name() or "signal", "limit", "lost" */
	char *error;              /* owned, NULL when none */
	char error_field[64];
	char *metrics;            /* JSON text, owned, NULL until succeeded */
	char artifact[128];       /* file name under the tenant's artifacts dir */
	int64_t artifact_bytes;
	char artifact_sha256[65];
	int64_t event_seq;        /* last event number */
	int64_t artifact_damaged_ms; /* quarantined by fsck (artifact then ""), 0 = no */
	char mesh_name[128];      /* the mesh's name when the job succeeded, "" = unknown */
};

void queue_job_row_fini(struct job_row *j);
/* Free an array from queue_list(). */
void queue_job_rows_free(struct job_row *v, int n);

struct job_new {
	int64_t tenant_id;
	const char *mesh_id, *engine, *format, *printer;
	const char *params;       /* JSON text */
	const char *idem_key;     /* NULL = none */
	const char *request_hash; /* digest of the canonical request, with idem_key */
	const char *fault;        /* NULL unless fault injection is enabled */
	int max_attempts;
};

/* Queue a job.  The mesh must exist for the tenant (ERR_NOTFOUND, field
 * "mesh_id") and not be deleted meanwhile.  With an idempotency key seen
 * before: same request_hash -> *replayed = 1 and the existing job; other
 * hash -> ERR_PARAM with field "Idempotency-Key". */
int queue_submit(struct db *db, const struct job_new *jn, struct job_row *out, int *replayed,
		 struct err *e);

/* Group commit: n submissions in one transaction (one fsync), each in
 * its own savepoint.  res[i] gets each one's outcome (rc 0 and the job's
 * seq, or rc/err as queue_submit() would report).  Returns nonzero only
 * when the transaction itself failed (then every res[i].rc is set). */
struct job_submit {
	int rc;
	int64_t seq;
	int replayed;
	struct err err;
};
int queue_submit_batch(struct db *db, const struct job_new *v, int n, struct job_submit *res,
		       struct err *e);

/* The tenant's job by public id; ERR_NOTFOUND for any other tenant's. */
int queue_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	      struct err *e);
/* By seq, any tenant (workers, SSE).  ERR_NOTFOUND. */
int queue_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e);

/* Newest first: jobs with seq < before_seq (0 = from the newest), state
 * filter (-1 = any), at most limit (1..1000).  *more = 1 when further
 * rows exist.  Caller frees with queue_job_rows_free(). */
int queue_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	       struct job_row **v, int *n, int *more, struct err *e);

/* Cancel a queued or running job (a running one is stopped by its
 * worker, which sees its fenced writes fail).  Finished jobs unchanged.
 * *out = the job after. */
int queue_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		 struct err *e);

/* Claim the next job fairly; *got = 0 when nothing is runnable.  Sets
 * state running, attempt + 1, the lease and worker name. */
int queue_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
		int *got, struct err *e);

/* The SQLite backend's claim statement (static), for its EXPLAIN QUERY
 * PLAN test. */
const char *queue_claim_sql(void);

/* Fenced writes: return 1 when applied, 0 when the job is no longer
 * running this attempt (cancelled, rescued, removed), negative on error. */
int queue_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e);
struct job_progress {
	const char *stage;
	double fraction;
	int layers_done, layers_total;
};
int queue_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
		   int64_t lease_ms, struct err *e);
struct job_artifact {
	const char *name;         /* file name in the tenant's artifacts dir */
	int64_t bytes;
	const char *sha256;       /* hex */
	const char *mesh_name;    /* the client's name of the input, NULL = unknown */
};
/* Record success and charge a->bytes to the tenant's used bytes; ERR_LIMIT
 * (nothing recorded) when that would pass the tenant's quota. */
int queue_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		  const char *metrics_json, struct err *e);

struct job_failure {
	const char *type;         /* "parse", "param", "signal", "limit", "lost"... */
	const char *message;
	const char *field;        /* "" or NULL */
	int retryable;            /* infrastructure trouble: try again if attempts remain */
};
/* Fail the attempt: re-queue with capped exponential backoff when
 * retryable and attempts remain, else state failed. */
int queue_fail(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
	       struct err *e);

/* Backoff before attempt n+1 after n failed attempts: 1 s, 2 s, 4 s ...
 * capped at 60 s. */
int64_t queue_backoff_ms(int attempts_done);

/* Rescuer: jobs running past their lease (or, with worker != NULL, held
 * by that dead worker regardless of lease; worker = "*" for all running
 * jobs at start-up) are re-queued or failed.  *n = jobs touched. */
int queue_rescue(struct db *db, const char *worker, int *n, struct err *e);

struct job_event {
	int64_t n;
	char type[16];            /* "progress" or "state" */
	char *data;               /* JSON text, owned */
};
void queue_events_free(struct job_event *v, int n);
/* Events of job seq with number > after, oldest first, at most limit. */
int queue_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		 int *n, struct err *e);

/* Counts by state (index enum job_state) for /metrics and /readyz. */
int queue_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e);

/* Histogram of finished job durations (seconds) for /metrics. */
#define QUEUE_DURATION_BUCKETS 10
extern const double queue_duration_le[QUEUE_DURATION_BUCKETS];
struct queue_durations {
	int64_t bucket[3][QUEUE_DURATION_BUCKETS]; /* succeeded, failed, cancelled; cumulative */
	int64_t count[3];
	double sum_s[3];
};
int queue_durations(struct db *db, struct queue_durations *d, struct err *e);

/* Retention: artifacts of jobs finished before cutoff_ms, oldest first
 * (at most limit): names them in *v (tenant id + artifact name) and
 * clears them in the rows (with usage). */
struct expired_artifact {
	int64_t tenant_id;
	char name[128];
};
int queue_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit,
			   struct expired_artifact **v, int *n, struct err *e);
/* Nonzero when job job_id holds artifact file name (orphan sweep; also
 * nonzero when the database cannot say, so files are kept). */
int queue_artifact_referenced(struct db *db, const char *job_id, const char *name);

#endif
