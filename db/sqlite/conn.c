/* conn.c - the SQLite backend's connection: set-up, transactions, the
 * statement cache, notifications (polling: SQLite has none) and the ops
 * table (see db.h, db_ops.h).
 */
#include "db/sqlite/sq_internal.h"
#include "engine/core/err.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

int sq_fail(struct db *db, struct err *e, const char *what)
{
	return ERR_SET(e, ERR_IO, "%s: %s", what, db && SQ(db) ? sqlite3_errmsg(SQ(db)) : "no database");
}

int sq_exec(struct db *db, const char *sql, struct err *e)
{
	char *msg = NULL;

	if (sqlite3_exec(SQ(db), sql, NULL, NULL, &msg) != SQLITE_OK) {
		ERR_SET(e, ERR_IO, "sql failed: %s", msg ? msg : sqlite3_errmsg(SQ(db)));
		sqlite3_free(msg);
		return ERR_IO;
	}
	return 0;
}

int sq_open(const char *path, struct db **out, struct err *e)
{
	struct db_sq *sd = calloc(1, sizeof *sd);
	struct db *db = &sd->base;
	int rc;

	if (!sd)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the database");
	db->ops = &db_sqlite_ops;
	rc = sqlite3_open_v2(path, &SQ(db),
			     SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, NULL);
	if (rc != SQLITE_OK) {
		rc = ERR_SET(e, ERR_IO, "cannot open database %s: %s", path,
			     SQ(db) ? sqlite3_errmsg(SQ(db)) : sqlite3_errstr(rc));
		goto out;
	}
	sqlite3_busy_timeout(SQ(db), DB_BUSY_TIMEOUT_MS);
	/* WAL: readers never block the writer.  synchronous=FULL: a commit is
	 * on disk before we acknowledge it (NORMAL could lose the last
	 * transactions on power loss).  The WAL is checkpointed by SQLite's
	 * auto-checkpoint at 1000 pages; journal_size_limit truncates it. */
	rc = sq_exec(db,
		     "PRAGMA journal_mode=WAL;"
		     "PRAGMA synchronous=FULL;"
		     "PRAGMA foreign_keys=ON;"
		     "PRAGMA journal_size_limit=67108864;"
		     "PRAGMA temp_store=MEMORY;",
		     e);
	if (rc)
		goto out;
	rc = sq_migrate(db, e);
out:
	if (rc) {
		sq_close(db);
		return rc;
	}
	*out = db;
	return 0;
}

void sq_close(struct db *db)
{
	struct db_sq *sd = (struct db_sq *)db;

	if (!sd)
		return;
	for (int i = 0; i < sd->ncache; i++)
		sqlite3_finalize(sd->cache[i].st);
	sqlite3_close_v2(sd->sq);
	free(sd);
}

int sq_schema_version(struct db *db)
{
	sqlite3_stmt *st = sq_stmt(db, "PRAGMA user_version", NULL);
	int v = -1;

	if (st && sqlite3_step(st) == SQLITE_ROW)
		v = sqlite3_column_int(st, 0);
	if (st)
		sqlite3_reset(st);
	return v;
}

sqlite3_stmt *sq_stmt(struct db *db, const char *sql, struct err *e)
{
	struct db_sq *sd = (struct db_sq *)db;
	sqlite3_stmt *st;

	for (int i = 0; i < sd->ncache; i++)
		if (sd->cache[i].sql == sql) {
			st = sd->cache[i].st;
			sqlite3_reset(st);
			sqlite3_clear_bindings(st);
			return st;
		}
	if (sqlite3_prepare_v3(SQ(db), sql, -1, SQLITE_PREPARE_PERSISTENT, &st, NULL) != SQLITE_OK) {
		sq_fail(db, e, "prepare");
		return NULL;
	}
	if (sd->ncache == DB_STMT_CACHE) {
		/* Full: evict the oldest (statements are few and static). */
		sqlite3_finalize(sd->cache[0].st);
		memmove(sd->cache, sd->cache + 1, sizeof sd->cache[0] * (DB_STMT_CACHE - 1));
		sd->ncache--;
	}
	sd->cache[sd->ncache].sql = sql;
	sd->cache[sd->ncache].st = st;
	sd->ncache++;
	return st;
}

static int step_done(struct db *db, const char *sql, struct err *e)
{
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		return sq_fail(db, e, sql);
	return 0;
}

int sq_begin(struct db *db, struct err *e)
{
	return step_done(db, "BEGIN IMMEDIATE", e);
}

int sq_commit(struct db *db, struct err *e)
{
	int rc = step_done(db, "COMMIT", e);

	if (rc)
		sq_rollback(db);
	return rc;
}

void sq_rollback(struct db *db)
{
	if (!sqlite3_get_autocommit(SQ(db)))
		sqlite3_exec(SQ(db), "ROLLBACK", NULL, NULL, NULL);
}

int sq_check_writable(struct db *db, struct err *e)
{
	int rc = sq_begin(db, e);

	if (rc)
		return rc;
	rc = step_done(db, "UPDATE meta SET value = value WHERE key = 'serve_seq'", e);
	if (rc) {
		sq_rollback(db);
		return rc;
	}
	return sq_commit(db, e);
}

const char *sq_col_text(sqlite3_stmt *st, int col)
{
	const unsigned char *t = sqlite3_column_text(st, col);

	return t ? (const char *)t : "";
}

void sq_col_copy(sqlite3_stmt *st, int col, char *buf, size_t len)
{
	const char *t = sq_col_text(st, col);
	size_t n = strlen(t);

	if (n >= len)
		n = len - 1;
	memcpy(buf, t, n);
	buf[n] = '\0';
}

char *sq_col_dup(sqlite3_stmt *st, int col)
{
	if (sqlite3_column_type(st, col) == SQLITE_NULL)
		return NULL;
	return strdup(sq_col_text(st, col));
}

/* SQLite has no notifications: listening is free and waiting sleeps, and
 * the caller re-reads what it watches (*n = -1). */
static int sq_listen(struct db *db, struct err *e)
{
	(void)db;
	(void)e;
	return 0;
}

static int sq_wait(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e)
{
	struct timespec ts = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};

	(void)db;
	(void)seqs;
	(void)cap;
	(void)e;
	while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
		;
	*n = -1;
	return 0;
}

/* Ids are INTEGER PRIMARY KEY / AUTOINCREMENT: copied ids need nothing
 * more (AUTOINCREMENT's sqlite_sequence follows the largest inserted). */
static int sq_copy_done(struct db *db, struct err *e)
{
	(void)db;
	(void)e;
	return 0;
}

static int sq_analyze(struct db *db, struct err *e)
{
	return sq_exec(db, "ANALYZE", e);
}

static int sq_schema_latest_of(void)
{
	return sq_schema_latest();
}

const struct db_ops db_sqlite_ops = {
	.name = "sqlite",
	.open = sq_open,
	.close = sq_close,
	.schema_version = sq_schema_version,
	.schema_latest = sq_schema_latest_of,
	.begin = sq_begin,
	.commit = sq_commit,
	.rollback = sq_rollback,
	.check_writable = sq_check_writable,
	.listen = sq_listen,
	.wait = sq_wait,
	.tenant_add = sq_tenant_add,
	.tenant_list = sq_tenant_list,
	.tenant_get = sq_tenant_get,
	.tenant_get_id = sq_tenant_get_id,
	.tenant_rotate = sq_tenant_rotate,
	.tenant_remove = sq_tenant_remove,
	.tenant_add_usage = sq_tenant_add_usage,
	.tenant_charge = sq_tenant_charge,
	.tenant_auth = sq_tenant_auth,
	.admin_key_rotate = sq_admin_key_rotate,
	.admin_auth = sq_admin_auth,
	.mesh_add = sq_mesh_add,
	.mesh_get = sq_mesh_get,
	.mesh_list = sq_mesh_list,
	.mesh_delete = sq_mesh_delete,
	.artifact_list = sq_artifact_list,
	.artifact_quarantine = sq_artifact_quarantine,
	.submit_one = sq_submit_one,
	.savepoint = sq_savepoint,
	.get = sq_get,
	.get_seq = sq_get_seq,
	.list = sq_list,
	.cancel = sq_cancel,
	.claim = sq_claim,
	.heartbeat = sq_heartbeat,
	.progress = sq_progress,
	.succeed = sq_succeed,
	.fail = sq_fail_job,
	.rescue = sq_rescue,
	.events = sq_events,
	.counts = sq_counts,
	.durations = sq_durations,
	.expire_artifacts = sq_expire_artifacts,
	.artifact_referenced = sq_artifact_referenced,
	.copy_out = sq_copy_out,
	.copy_in = sq_copy_in,
	.copy_done = sq_copy_done,
	.analyze = sq_analyze,
};
