/* pg_internal.h - what the files of the PostgreSQL backend share: the
 * connection struct, the statement helpers (text parameters, prepared
 * statements cached per connection) and each op of db_pg_ops (listed in
 * conn.c).  Nothing outside db/pg/ includes it.  Design: docs/service.md
 * ("Queue and storage"), docs/operations.md ("Many machines").
 */
#ifndef INFILLD_DB_PG_INTERNAL_H
#define INFILLD_DB_PG_INTERNAL_H

#include <libpq-fe.h>

#include "db/db_ops.h"

#define PGDB_STMT_CACHE 96 /* the static statements of db/pg/ (about 60) */
#define PGDB_MAX_PARAMS 40 /* jobs has 31 columns (copy_in) */

struct pgdb_stmt_slot {
	const char *sql; /* static string: the cache key is the pointer */
	char name[16];   /* server-side prepared statement name */
};

/* One PostgreSQL connection; base first, so a struct db * is one of these.
 * Used by one thread at a time, like every struct db. */
struct db_pg {
	struct db base;
	PGconn *c;
	struct pgdb_stmt_slot cache[PGDB_STMT_CACHE];
	int ncache;
	int nprepared;       /* names handed out: s1, s2 ... (never reused) */
	int in_tx;           /* between pgdb_begin() and commit/rollback */
	int listening;       /* LISTEN issued: repeated after a reconnect */
	int lost_notify;     /* a reconnect may have lost notifications */
	char sqlstate[6];    /* SQLSTATE of the last failed statement, "" */
};

#define PGC(db) (((struct db_pg *)(db))->c)

/* Session statement_timeout (a stuck lock wait fails sooner: lock_timeout
 * 10 s, conn.c); copy_out lifts it while it streams a table. */
#define PGDB_STATEMENT_TIMEOUT "'300s'"

/* Statement parameters, all sent as text (or binary for bytea/raw text):
 * values are borrowed from the caller until the statement ran, except
 * numbers, which are formatted into num[]. */
struct pgdb_params {
	int n;
	const char *v[PGDB_MAX_PARAMS];
	int len[PGDB_MAX_PARAMS];
	int fmt[PGDB_MAX_PARAMS]; /* 0 text, 1 binary */
	char num[PGDB_MAX_PARAMS][32];
};

void pgdb_p_init(struct pgdb_params *p);
/* s = NULL sends SQL NULL. */
void pgdb_p_text(struct pgdb_params *p, const char *s);
void pgdb_p_i64(struct pgdb_params *p, int64_t v);
void pgdb_p_f64(struct pgdb_params *p, double v);
/* Raw bytes in binary format (bytea; or text without NUL termination). */
void pgdb_p_bin(struct pgdb_params *p, const void *b, size_t len);

/* Run the static SQL string sql (prepared once per connection, the cache
 * key being the pointer) with p (NULL = none).  Returns the result, which
 * the caller frees with PQclear(), or NULL with e = ERR_IO "what: libpq
 * message" (db_pg.sqlstate then says why).  A statement outside any
 * transaction that finds the connection broken reconnects once and runs
 * again (only BEGIN and reads run outside transactions here, so that is
 * never a write run twice). */
PGresult *pgdb_q(struct db *db, const char *sql, const struct pgdb_params *p, const char *what,
		 struct err *e);
/* Same for SQL built at run time (not prepared). */
PGresult *pgdb_q_once(struct db *db, const char *sql, const struct pgdb_params *p,
		      const char *what, struct err *e);
/* pgdb_q() for statements whose result is not needed: 0 or ERR_IO. */
int pgdb_run(struct db *db, const char *sql, const struct pgdb_params *p, const char *what,
	     struct err *e);
/* Rows changed by the command of r (UPDATE/DELETE/INSERT). */
int64_t pgdb_changes(PGresult *r);
/* Run one or more statements without parameters (DDL, SAVEPOINT). */
int pgdb_exec(struct db *db, const char *sql, struct err *e);

/* Fill e from r (or the connection when r is NULL): ERR_IO "what: msg". */
int pgdb_fail(struct db *db, PGresult *r, struct err *e, const char *what);
/* Make sure the connection is up before an op: reconnect once when it
 * broke (PQreset), then re-apply the session settings and LISTEN.  0 or
 * ERR_IO. */
int pgdb_ready(struct db *db, struct err *e);
/* Reconnect now (PQreset) and set the session up again; drops every
 * session-level lock.  0 or ERR_IO. */
int pgdb_reconnect(struct db *db, struct err *e);
/* Nonzero inside a transaction (also a failed one). */
int pgdb_in_tx(struct db *db);

/* Column values of row i; SQL NULL reads as 0 / "" / NULL. */
int64_t pgdb_i64(const PGresult *r, int i, int col);
int pgdb_int(const PGresult *r, int i, int col);
double pgdb_f64(const PGresult *r, int i, int col);
const char *pgdb_text(const PGresult *r, int i, int col);
/* Copy into buf (truncated to len-1). */
void pgdb_copy(const PGresult *r, int i, int col, char *buf, size_t len);
/* Heap copy (NULL for SQL NULL or out of memory); caller frees with free(). */
char *pgdb_dup(const PGresult *r, int i, int col);
/* A bytea column in text (hex) output form decoded into out (cap bytes);
 * its length, or -1 when not hex bytea or longer than cap. */
long pgdb_bytea(const PGresult *r, int i, int col, unsigned char *out, size_t cap);

/* conn.c */
int pgdb_open(const char *url, struct db **out, struct err *e);
void pgdb_close(struct db *db);
int pgdb_begin(struct db *db, struct err *e);
int pgdb_commit(struct db *db, struct err *e);
void pgdb_rollback(struct db *db);
int pgdb_check_writable(struct db *db, struct err *e);
int pgdb_listen(struct db *db, struct err *e);
int pgdb_wait(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e);

/* schema.c */
int pgdb_migrate(struct db *db, struct err *e);
int pgdb_schema_version(struct db *db);
int pgdb_schema_latest(void);
/* Advisory lock keys (pg_advisory_xact_lock): one for migrations, one
 * namespace of per-tenant claim locks (the tenant id in the low bits). */
#define PGDB_LOCK_MIGRATE 0x696e66696c6c64LL /* "infilld" */
#define PGDB_LOCK_CLAIM(tenant_id) ((int64_t)0x69660000 << 32 | ((tenant_id) & 0xffffffffLL))

/* tenants.c */
int pgdb_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		    struct tenant *out, char *key, struct err *e);
int pgdb_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e);
int pgdb_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e);
int pgdb_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e);
int pgdb_tenant_rotate(struct db *db, const char *name, char *key, struct err *e);
int pgdb_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e);
int pgdb_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e);
int pgdb_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e);
int pgdb_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e);
int pgdb_admin_key_rotate(struct db *db, char *key, struct err *e);
int pgdb_admin_auth(struct db *db, const char *key, struct err *e);
/* Inside the caller's transaction: charge bytes if they fit the quota;
 * ERR_LIMIT with the message "<what> (N bytes) would take the tenant past
 * its storage quota of Q bytes (U in use)" (what NULL: "N bytes more
 * would ..."). */
int pgdb_charge_locked(struct db *db, int64_t tenant_id, int64_t bytes, const char *what,
		       struct err *e);
int pgdb_add_usage_locked(struct db *db, int64_t tenant_id, int64_t delta, struct err *e);

/* meshes.c */
int pgdb_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e);
int pgdb_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		  struct err *e);
int pgdb_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		   int limit, struct mesh_rec **v, int *n, int *more, struct err *e);
int pgdb_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		     struct err *e);

/* artifacts.c */
int pgdb_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		       int *n, struct err *e);
int pgdb_artifact_quarantine(struct db *db, int64_t seq, struct err *e);

/* queue.c */
int pgdb_submit_one(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
		    struct err *e);
int pgdb_savepoint(struct db *db, int end, int undo, struct err *e);
int pgdb_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	     struct err *e);
int pgdb_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e);
int pgdb_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	      struct job_row **v, int *n, int *more, struct err *e);
int pgdb_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		struct err *e);
int pgdb_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		int *n, struct err *e);
int pgdb_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e);
int pgdb_durations(struct db *db, struct queue_durations *d, struct err *e);
int pgdb_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit,
			  struct expired_artifact **v, int *n, struct err *e);
int pgdb_artifact_referenced(struct db *db, const char *job_id, const char *name);
/* Shared with queue_worker.c: append the job's snapshot as event number
 * event_seq (the caller bumped it in the same transaction) and notify
 * LISTENers of channel infilld_job with the seq (delivered on commit). */
int pgdb_add_event(struct db *db, int64_t seq, const char *type, struct err *e);
/* Count a finished job's duration in the histogram (same transaction). */
int pgdb_record_duration(struct db *db, int64_t seq, struct err *e);

/* queue_worker.c */
int pgdb_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
	       int *got, struct err *e);
int pgdb_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e);
int pgdb_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
		  int64_t lease_ms, struct err *e);
int pgdb_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		 const char *metrics_json, struct err *e);
int pgdb_fail_job(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
		  struct err *e);
int pgdb_rescue(struct db *db, const char *worker, int *n, struct err *e);

/* copy.c */
int pgdb_copy_out(struct db *db, const struct db_table *t,
		  int (*row)(void *ctx, const struct db_val *v), void *ctx, struct err *e);
int pgdb_copy_in(struct db *db, const struct db_table *t, const struct db_val *v,
		 struct err *e);
int pgdb_copy_done(struct db *db, struct err *e);

#endif
