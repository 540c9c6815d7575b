/* db_ops.h - the backend ops table behind db/'s public API.
 *
 * A struct db is the first member of each backend's connection struct
 * (struct db_sq in db/sqlite/, struct db_pg in db/pg/); db->ops names the
 * backend.  The public functions of db.h, tenants.h, meshes.h,
 * artifacts.h and queue.h check their arguments that need no SQL and
 * dispatch here, so every backend keeps the same meaning: the comments of
 * the public headers are the contract of each op.  Nothing outside db/
 * includes this file.
 */
#ifndef INFILLD_DB_OPS_H
#define INFILLD_DB_OPS_H

#include "db/artifacts.h"
#include "db/db.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "db/tenants.h"

/* One column value for copy_out/copy_in. */
struct db_val {
	char type;          /* 0 = SQL NULL, 'i' int64, 'r' double, 't' text, 'b' blob */
	int64_t i;
	double r;
	const void *p;      /* text (not NUL-terminated) or blob bytes; valid during the call */
	size_t len;
};

/* A table as migrate-db copies it (copy.c lists them, parents first). */
struct db_table {
	const char *name;
	int ncols;
	const char *const *cols;
	const char *types;  /* per column: 'i', 'r', 't' or 'b' */
	const char *order_by;
};

struct db_ops {
	const char *name; /* "sqlite", "postgresql" */

	/* Connection.  open: target is what follows the URL scheme (a file
	 * path for SQLite, the whole URL for PostgreSQL); migrates. */
	int (*open)(const char *target, struct db **out, struct err *e);
	void (*close)(struct db *db);
	int (*schema_version)(struct db *db);
	int (*schema_latest)(void);
	int (*begin)(struct db *db, struct err *e);
	int (*commit)(struct db *db, struct err *e);
	void (*rollback)(struct db *db);
	int (*check_writable)(struct db *db, struct err *e);
	/* Job-change notifications (see db_listen() in db.h). */
	int (*listen)(struct db *db, struct err *e);
	int (*wait)(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e);

	/* tenants.h */
	int (*tenant_add)(struct db *db, const char *name, const struct tenant_limits *l,
			  struct tenant *out, char *key, struct err *e);
	int (*tenant_list)(struct db *db, struct tenant **v, int *n, struct err *e);
	int (*tenant_get)(struct db *db, const char *name, struct tenant *out, struct err *e);
	int (*tenant_get_id)(struct db *db, int64_t id, struct tenant *out, struct err *e);
	int (*tenant_rotate)(struct db *db, const char *name, char *key, struct err *e);
	int (*tenant_remove)(struct db *db, const char *name, int64_t *id, struct err *e);
	int (*tenant_add_usage)(struct db *db, int64_t tenant_id, int64_t delta, struct err *e);
	int (*tenant_charge)(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e);
	int (*tenant_auth)(struct db *db, const char *key, struct tenant *out, struct err *e);
	int (*admin_key_rotate)(struct db *db, char *key, struct err *e);
	int (*admin_auth)(struct db *db, const char *key, struct err *e);

	/* meshes.h */
	int (*mesh_add)(struct db *db, const struct mesh_rec *m, struct err *e);
	int (*mesh_get)(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
			struct err *e);
	int (*mesh_list)(struct db *db, int64_t tenant_id, int64_t before_ms,
			 const char *before_id, int limit, struct mesh_rec **v, int *n, int *more,
			 struct err *e);
	int (*mesh_delete)(struct db *db, int64_t tenant_id, const char *id,
			   struct mesh_rec *out, struct err *e);

	/* artifacts.h */
	int (*artifact_list)(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
			     int *n, struct err *e);
	int (*artifact_quarantine)(struct db *db, int64_t seq, struct err *e);

	/* queue.h */
	/* One submission inside the caller's transaction and savepoint
	 * (queue_submit_batch() in db/queue.c holds both): 0 with *seq, or
	 * the error queue_submit() reports. */
	int (*submit_one)(struct db *db, const struct job_new *jn, int64_t *seq, int *replayed,
			  struct err *e);
	/* end = 0: open the savepoint of one submission; end = 1: close it,
	 * undoing its writes first when undo. */
	int (*savepoint)(struct db *db, int end, int undo, struct err *e);
	int (*get)(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		   struct err *e);
	int (*get_seq)(struct db *db, int64_t seq, struct job_row *out, struct err *e);
	int (*list)(struct db *db, int64_t tenant_id, int state, int64_t before_seq, int limit,
		    struct job_row **v, int *n, int *more, struct err *e);
	int (*cancel)(struct db *db, int64_t tenant_id, const char *id, struct job_row *out,
		      struct err *e);
	int (*claim)(struct db *db, const char *worker, int64_t lease_ms, struct job_row *out,
		     int *got, struct err *e);
	int (*heartbeat)(struct db *db, int64_t seq, int attempt, int64_t lease_ms,
			 struct err *e);
	int (*progress)(struct db *db, int64_t seq, int attempt, const struct job_progress *p,
			int64_t lease_ms, struct err *e);
	int (*succeed)(struct db *db, int64_t seq, int attempt, const struct job_artifact *a,
		       const char *metrics_json, struct err *e);
	int (*fail)(struct db *db, int64_t seq, int attempt, const struct job_failure *f,
		    struct err *e);
	int (*rescue)(struct db *db, const char *worker, int *n, struct err *e);
	int (*events)(struct db *db, int64_t seq, int64_t after, int limit, struct job_event **v,
		      int *n, struct err *e);
	int (*counts)(struct db *db, int64_t counts[JOB_STATE_COUNT], struct err *e);
	int (*durations)(struct db *db, struct queue_durations *d, struct err *e);
	int (*expire_artifacts)(struct db *db, int64_t cutoff_ms, int limit,
				struct expired_artifact **v, int *n, struct err *e);
	int (*artifact_referenced)(struct db *db, const char *job_id, const char *name);

	/* `infilld migrate-db` (copy.c): copy_out calls row() for every row
	 * of t in t->order_by order, values in t->cols order (a nonzero
	 * return from row() stops it and is returned); copy_in inserts one
	 * row as given, ids included, inside the caller's db_begin();
	 * copy_done runs after the last table (PostgreSQL: moves identity
	 * sequences past the copied ids). */
	int (*copy_out)(struct db *db, const struct db_table *t,
			int (*row)(void *ctx, const struct db_val *v), void *ctx, struct err *e);
	int (*copy_in)(struct db *db, const struct db_table *t, const struct db_val *v,
		       struct err *e);
	int (*copy_done)(struct db *db, struct err *e);
	/* Refresh the planner's statistics (after a bulk load). */
	int (*analyze)(struct db *db, struct err *e);
};

struct db {
	const struct db_ops *ops;
};

/* API keys, shared by the backends (db/keys.c): "KIND_<id>_<secret>",
 * KIND "ifk" (tenant) or "ifa" (admin); only SHA-256 of the whole key is
 * stored, found by its public id and compared in constant time. */
#define DB_KEY_ID_LEN 12
#define DB_KEY_HASH_LEN 32
/* New random key into key (API_KEY_MAX bytes), its id and hash.  ERR_IO. */
int db_key_make(const char *kind, char *key, char key_id[DB_KEY_ID_LEN + 1],
		unsigned char hash[DB_KEY_HASH_LEN], struct err *e);
/* 0 when key has the shape KIND_<id>_<secret>; key_id gets the id. */
int db_key_parse(const char *key, const char *kind, char key_id[DB_KEY_ID_LEN + 1]);
void db_key_hash(const char *key, unsigned char hash[DB_KEY_HASH_LEN]);
/* Nonzero when the stored hash (len bytes) equals hash; constant time. */
int db_key_hash_eq(const void *stored, size_t len, const unsigned char hash[DB_KEY_HASH_LEN]);

extern const struct db_ops db_sqlite_ops;
extern const struct db_ops db_pg_ops;

#endif
