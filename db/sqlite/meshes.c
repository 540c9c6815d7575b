/* meshes.c - the SQLite backend's uploaded-mesh index (see meshes.h). */
#include "db/meshes.h"
#include "db/sqlite/sq_internal.h"
#include "db/tenants.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

#define MESH_COLS "id, tenant_id, name, format, size_bytes, sha256, analysis, created_at"

static void read_mesh(sqlite3_stmt *st, struct mesh_rec *m)
{
	memset(m, 0, sizeof *m);
	sq_col_copy(st, 0, m->id, sizeof m->id);
	m->tenant_id = sqlite3_column_int64(st, 1);
	sq_col_copy(st, 2, m->name, sizeof m->name);
	sq_col_copy(st, 3, m->format, sizeof m->format);
	m->size_bytes = sqlite3_column_int64(st, 4);
	sq_col_copy(st, 5, m->sha256, sizeof m->sha256);
	m->analysis = sq_col_dup(st, 6);
	m->created_ms = sqlite3_column_int64(st, 7);
}

int sq_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e)
{
	static const char sql[] = "INSERT INTO meshes(" MESH_COLS ")"
				  " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
	sqlite3_stmt *st;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_text(st, 1, m->id, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 2, m->tenant_id);
	sqlite3_bind_text(st, 3, m->name, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 4, m->format, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 5, m->size_bytes);
	sqlite3_bind_text(st, 6, m->sha256, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 7, m->analysis ? m->analysis : "{}", -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 8, m->created_ms);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	rc = rc == SQLITE_DONE ? sq_tenant_charge(db, m->tenant_id, m->size_bytes, e)
			       : sq_fail(db, e, "recording mesh");
	if (!rc)
		rc = sq_commit(db, e);
	if (rc)
		sq_rollback(db);
	return rc;
}

int sq_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		struct err *e)
{
	static const char sql[] = "SELECT " MESH_COLS " FROM meshes WHERE id = ?1 AND tenant_id = ?2";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_text(st, 1, id, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 2, tenant_id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		read_mesh(st, out);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		return 0;
	return rc == SQLITE_DONE ? ERR_SET(e, ERR_NOTFOUND, "no such mesh")
				 : sq_fail(db, e, "reading mesh");
}

int sq_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		 int limit, struct mesh_rec **v, int *n, int *more, struct err *e)
{
	static const char sql[] =
		"SELECT " MESH_COLS " FROM meshes WHERE tenant_id = ?1"
		" AND (created_at, id) < (?2, ?3) ORDER BY created_at DESC, id DESC LIMIT ?4";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	struct mesh_rec *a;
	int cnt = 0, rc;

	if (!st)
		return ERR_IO;
	if (limit < 1 || limit > 1000)
		limit = 50;
	if (!(a = calloc((size_t)limit + 1, sizeof *a))) {
		sqlite3_reset(st);
		return ERR_SET(e, ERR_NOMEM, "out of memory listing meshes");
	}
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_int64(st, 2, before_ms > 0 ? before_ms : INT64_MAX);
	sqlite3_bind_text(st, 3, before_ms > 0 && before_id ? before_id : "~", -1, SQLITE_STATIC);
	sqlite3_bind_int(st, 4, limit + 1);
	while ((rc = sqlite3_step(st)) == SQLITE_ROW)
		read_mesh(st, &a[cnt++]);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE) {
		db_mesh_recs_free(a, cnt);
		return sq_fail(db, e, "listing meshes");
	}
	*more = cnt > limit;
	if (*more)
		db_mesh_rec_fini(&a[--cnt]);
	*v = a;
	*n = cnt;
	return 0;
}

int sq_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		   struct err *e)
{
	static const char busy_sql[] =
		"SELECT 1 FROM jobs WHERE mesh_id = ?1 AND state IN ('queued', 'running')";
	static const char del_sql[] = "DELETE FROM meshes WHERE id = ?1 AND tenant_id = ?2";
	struct mesh_rec m;
	sqlite3_stmt *st;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if ((rc = sq_mesh_get(db, tenant_id, id, &m, e)))
		goto out;
	if (!(st = sq_stmt(db, busy_sql, e))) {
		rc = ERR_IO;
		goto out_m;
	}
	sqlite3_bind_text(st, 1, id, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW) {
		rc = ERR_SET(e, ERR_LIMIT, "mesh %s is used by queued or running jobs", id);
		goto out_m;
	}
	if (!(st = sq_stmt(db, del_sql, e))) {
		rc = ERR_IO;
		goto out_m;
	}
	sqlite3_bind_text(st, 1, id, -1, SQLITE_STATIC);
	sqlite3_bind_int64(st, 2, tenant_id);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	rc = rc == SQLITE_DONE ? sq_tenant_add_usage(db, tenant_id, -m.size_bytes, e)
			       : sq_fail(db, e, "deleting mesh");
	if (!rc && !(rc = sq_commit(db, e))) {
		*out = m;
		return 0;
	}
out_m:
	db_mesh_rec_fini(&m);
out:
	sq_rollback(db);
	return rc;
}
