/* sq_internal.h - what the files of the SQLite backend share: the
 * connection struct, the prepared-statement cache and each op (listed in
 * the ops table of conn.c).  Nothing outside db/sqlite/ includes it.
 */
#ifndef INFILLD_DB_SQ_INTERNAL_H
#define INFILLD_DB_SQ_INTERNAL_H

#include <sqlite3.h>

#include "db/db_ops.h"

#define DB_STMT_CACHE 48

struct db_stmt_slot {
	const char *sql; /* static string: the cache key is the pointer */
	sqlite3_stmt *st;
};

/* One SQLite connection; base first, so a struct db * is one of these. */
struct db_sq {
	struct db base;
	sqlite3 *sq;
	struct db_stmt_slot cache[DB_STMT_CACHE];
	int ncache;
};

#define SQ(db) (((struct db_sq *)(db))->sq)

/* Prepared statement for a static SQL string, reset and unbound, owned by
 * the cache (never finalize it).  NULL with e filled (ERR_IO/ERR_INTERNAL). */
sqlite3_stmt *sq_stmt(struct db *db, const char *sql, struct err *e);

/* Fill e from the connection's last error: "what: sqlite message". */
int sq_fail(struct db *db, struct err *e, const char *what);

/* Run SQL with no result rows (one or more statements). */
int sq_exec(struct db *db, const char *sql, struct err *e);

/* sqlite3_column_text() as a C string, "" for NULL. */
const char *sq_col_text(sqlite3_stmt *st, int col);
/* Copy column text into buf (truncated to len-1). */
void sq_col_copy(sqlite3_stmt *st, int col, char *buf, size_t len);
/* Heap copy of column text (NULL for SQL NULL); caller frees with free(). */
char *sq_col_dup(sqlite3_stmt *st, int col);

/* Migrations (schema.c): apply everything past PRAGMA user_version. */
int sq_migrate(struct db *db, struct err *e);
int sq_schema_latest(void);

/* conn.c */
int sq_open(const char *path, struct db **out, struct err *e);
void sq_close(struct db *db);
int sq_schema_version(struct db *db);
int sq_begin(struct db *db, struct err *e);
int sq_commit(struct db *db, struct err *e);
void sq_rollback(struct db *db);
int sq_check_writable(struct db *db, struct err *e);

/* tenants.c */
int sq_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		  struct tenant *out, char *key, struct err *e);
int sq_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e);
int sq_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e);
int sq_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e);
int sq_tenant_rotate(struct db *db, const char *name, char *key, struct err *e);
int sq_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e);
int sq_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e);
int sq_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e);
int sq_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e);
int sq_admin_key_rotate(struct db *db, char *key, struct err *e);
int sq_admin_auth(struct db *db, const char *key, struct err *e);

/* meshes.c */
int sq_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e);
int sq_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		struct err *e);
int sq_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		 int limit, struct mesh_rec **v, int *n, int *more, struct err *e);
int sq_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		   struct err *e);

/* artifacts.c */
int sq_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		     int *n, struct err *e);
int sq_artifact_quarantine(struct db *db, int64_t seq, struct err *e);

/* queue.c */
int sq_submit_one(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
		  struct err *e);
int sq_savepoint(struct db *db, int end, int undo, struct err *e);
int sq_get(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	   struct err *e);
int sq_get_seq(struct db *db, int64_t seq, struct job_row *out, struct err *e);
int sq_list(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
	    struct job_row **v, int *n, int *more, struct err *e);
int sq_cancel(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
	      struct err *e);
int sq_claim(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out, int *got,
	     struct err *e);
int sq_heartbeat(struct db *db, int64_t seq, int attempt, int64_t lease_ms, struct err *e);
int sq_progress(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
		int64_t lease_ms, struct err *e);
int sq_succeed(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
	       const char *metrics_json, struct err *e);
int sq_fail_job(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
		struct err *e);
int sq_rescue(struct db *db, const char *worker, int *n, struct err *e);
int sq_events(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v, int *n,
	      struct err *e);
int sq_counts(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e);
int sq_durations(struct db *db, struct queue_durations *d, struct err *e);
int sq_expire_artifacts(struct db *db, int64_t cutoff_ms, int limit, struct expired_artifact **v,
			int *n, struct err *e);
int sq_artifact_referenced(struct db *db, const char *job_id, const char *name);

/* copy.c */
int sq_copy_out(struct db *db, const struct db_table *t,
		int (*row)(void *ctx, const struct db_val *v), void *ctx, struct err *e);
int sq_copy_in(struct db *db, const struct db_table *t, const struct db_val *v, struct err *e);

#endif
