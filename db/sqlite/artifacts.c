/* artifacts.c - the SQLite backend's artifact index walk and quarantine
 * (artifacts.h). */
#include "db/artifacts.h"
#include "db/sqlite/sq_internal.h"
#include "db/tenants.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

int sq_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		     int *n, struct err *e)
{
	static const char sql[] =
		"SELECT seq, id, tenant_id, artifact, artifact_bytes, artifact_sha256 FROM jobs"
		" WHERE seq > ?1 AND artifact IS NOT NULL ORDER BY seq LIMIT ?2";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	struct artifact_rec *a;
	int k = 0, rc;

	if (!st)
		return ERR_IO;
	if (limit < 1 || !(a = calloc((size_t)limit, sizeof *a)))
		return ERR_SET(e, ERR_NOMEM, "out of memory listing artifacts");
	sqlite3_bind_int64(st, 1, after_seq);
	sqlite3_bind_int(st, 2, limit);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW && k < limit) {
		a[k].seq = sqlite3_column_int64(st, 0);
		sq_col_copy(st, 1, a[k].job_id, sizeof a[k].job_id);
		a[k].tenant_id = sqlite3_column_int64(st, 2);
		sq_col_copy(st, 3, a[k].name, sizeof a[k].name);
		a[k].bytes = sqlite3_column_int64(st, 4);
		sq_col_copy(st, 5, a[k].sha256, sizeof a[k].sha256);
		k++;
	}
	sqlite3_reset(st);
	if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
		free(a);
		return sq_fail(db, e, "listing artifacts");
	}
	*v = a;
	*n = k;
	return 0;
}

int sq_artifact_quarantine(struct db *db, int64_t seq, struct err *e)
{
	static const char sql[] =
		"UPDATE jobs SET artifact = NULL, artifact_damaged_at = ?2"
		" WHERE seq = ?1 AND artifact IS NOT NULL RETURNING tenant_id, artifact_bytes";
	sqlite3_stmt *st;
	int64_t tenant_id, bytes;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_int64(st, 1, seq);
	sqlite3_bind_int64(st, 2, db_now_ms());
	rc = sqlite3_step(st);
	if (rc != SQLITE_ROW) {
		sqlite3_reset(st);
		sq_rollback(db);
		return rc == SQLITE_DONE ? ERR_SET(e, ERR_NOTFOUND, "job holds no artifact")
					 : sq_fail(db, e, "quarantining an artifact");
	}
	tenant_id = sqlite3_column_int64(st, 0);
	bytes = sqlite3_column_int64(st, 1);
	sqlite3_reset(st);
	if ((rc = sq_tenant_add_usage(db, tenant_id, -bytes, e)) || (rc = sq_commit(db, e))) {
		sq_rollback(db);
		return rc;
	}
	return 0;
}
