/* meshes.c - the uploaded-mesh index on PostgreSQL (see meshes.h).
 *
 * A submit locks the mesh row FOR SHARE while it queues a job
 * (queue.c) and a delete locks it FOR UPDATE before it looks for queued
 * or running jobs: so either the delete waits for the submit and then sees
 * its job (ERR_LIMIT), or the submit waits for the delete and then finds
 * no mesh (ERR_NOTFOUND); never a job for a deleted mesh.
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

#define MESH_COLS "id, tenant_id, name, format, size_bytes, sha256, analysis, created_at"

static void read_mesh(const PGresult *r, int i, struct mesh_rec *m)
{
	memset(m, 0, sizeof *m);
	pgdb_copy(r, i, 0, m->id, sizeof m->id);
	m->tenant_id = pgdb_i64(r, i, 1);
	pgdb_copy(r, i, 2, m->name, sizeof m->name);
	pgdb_copy(r, i, 3, m->format, sizeof m->format);
	m->size_bytes = pgdb_i64(r, i, 4);
	pgdb_copy(r, i, 5, m->sha256, sizeof m->sha256);
	m->analysis = pgdb_dup(r, i, 6);
	m->created_ms = pgdb_i64(r, i, 7);
}

int pgdb_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e)
{
	static const char sql[] = "INSERT INTO meshes(" MESH_COLS ")"
				  " VALUES ($1::text, $2::bigint, $3::text, $4::text, $5::bigint,"
				  "  $6::text, $7::text, $8::bigint)";
	struct pgdb_params p;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, m->id);
	pgdb_p_i64(&p, m->tenant_id);
	pgdb_p_text(&p, m->name);
	pgdb_p_text(&p, m->format);
	pgdb_p_i64(&p, m->size_bytes);
	pgdb_p_text(&p, m->sha256);
	pgdb_p_text(&p, m->analysis ? m->analysis : "{}");
	pgdb_p_i64(&p, m->created_ms);
	if (!(rc = pgdb_run(db, sql, &p, "recording mesh", e)) &&
	    !(rc = pgdb_charge_locked(db, m->tenant_id, m->size_bytes, NULL, e)))
		rc = pgdb_commit(db, e);
	if (rc)
		pgdb_rollback(db);
	return rc;
}

/* The mesh row, FOR UPDATE when lock (inside a transaction). */
static int get_mesh(struct db *db, int64_t tenant_id, const char *id, int lock,
		    struct mesh_rec *out, struct err *e)
{
	static const char sql[] = "SELECT " MESH_COLS " FROM meshes"
				  " WHERE id = $1::text AND tenant_id = $2::bigint";
	static const char lock_sql[] = "SELECT " MESH_COLS " FROM meshes"
				       " WHERE id = $1::text AND tenant_id = $2::bigint FOR UPDATE";
	struct pgdb_params p;
	PGresult *r;
	int rc = 0;

	pgdb_p_init(&p);
	pgdb_p_text(&p, id);
	pgdb_p_i64(&p, tenant_id);
	if (!(r = pgdb_q(db, lock ? lock_sql : sql, &p, "reading mesh", e)))
		return ERR_IO;
	if (PQntuples(r) == 1)
		read_mesh(r, 0, out);
	else
		rc = ERR_SET(e, ERR_NOTFOUND, "no such mesh");
	PQclear(r);
	return rc;
}

int pgdb_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		  struct err *e)
{
	return get_mesh(db, tenant_id, id, 0, out, e);
}

int pgdb_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		   int limit, struct mesh_rec **v, int *n, int *more, struct err *e)
{
	/* "~" sorts after every id character in byte order (COLLATE "C"). */
	static const char sql[] =
		"SELECT " MESH_COLS " FROM meshes WHERE tenant_id = $1::bigint"
		" AND (created_at, id) < ($2::bigint, $3::text) ORDER BY created_at DESC, id DESC"
		" LIMIT $4::int";
	struct pgdb_params p;
	struct mesh_rec *a;
	PGresult *r;
	int cnt;

	if (limit < 1 || limit > 1000)
		limit = 50;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_i64(&p, before_ms > 0 ? before_ms : INT64_MAX);
	pgdb_p_text(&p, before_ms > 0 && before_id ? before_id : "~");
	pgdb_p_i64(&p, limit + 1);
	if (!(r = pgdb_q(db, sql, &p, "listing meshes", e)))
		return ERR_IO;
	cnt = PQntuples(r);
	if (!(a = calloc((size_t)cnt + 1, sizeof *a))) {
		PQclear(r);
		return ERR_SET(e, ERR_NOMEM, "out of memory listing meshes");
	}
	for (int i = 0; i < cnt; i++)
		read_mesh(r, i, &a[i]);
	PQclear(r);
	*more = cnt > limit;
	if (*more)
		db_mesh_rec_fini(&a[--cnt]);
	*v = a;
	*n = cnt;
	return 0;
}

int pgdb_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		     struct err *e)
{
	static const char busy_sql[] = "SELECT 1 FROM jobs WHERE mesh_id = $1::text"
				       " AND state IN ('queued', 'running') LIMIT 1";
	static const char del_sql[] =
		"DELETE FROM meshes WHERE id = $1::text AND tenant_id = $2::bigint";
	struct pgdb_params p;
	struct mesh_rec m;
	PGresult *r;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	if ((rc = get_mesh(db, tenant_id, id, 1, &m, e)))
		goto out;
	pgdb_p_init(&p);
	pgdb_p_text(&p, id);
	if (!(r = pgdb_q(db, busy_sql, &p, "checking mesh use", e))) {
		rc = ERR_IO;
		goto out_m;
	}
	if (PQntuples(r) > 0)
		rc = ERR_SET(e, ERR_LIMIT, "mesh %s is used by queued or running jobs", id);
	PQclear(r);
	if (rc)
		goto out_m;
	pgdb_p_i64(&p, tenant_id);
	if ((rc = pgdb_run(db, del_sql, &p, "deleting mesh", e)) ||
	    (rc = pgdb_add_usage_locked(db, tenant_id, -m.size_bytes, e)) ||
	    (rc = pgdb_commit(db, e)))
		goto out_m;
	*out = m;
	return 0;
out_m:
	db_mesh_rec_fini(&m);
out:
	pgdb_rollback(db);
	return rc;
}
