/* artifacts.c - walking and quarantining the artifact index on
 * PostgreSQL (artifacts.h).
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

int pgdb_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		       int *n, struct err *e)
{
	static const char sql[] =
		"SELECT seq, id, tenant_id, artifact, artifact_bytes, artifact_sha256 FROM jobs"
		" WHERE seq > $1::bigint AND artifact IS NOT NULL ORDER BY seq LIMIT $2::int";
	struct artifact_rec *a;
	struct pgdb_params p;
	PGresult *r;
	int k;

	if (limit < 1 || !(a = calloc((size_t)limit, sizeof *a)))
		return ERR_SET(e, ERR_NOMEM, "out of memory listing artifacts");
	pgdb_p_init(&p);
	pgdb_p_i64(&p, after_seq);
	pgdb_p_i64(&p, limit);
	if (!(r = pgdb_q(db, sql, &p, "listing artifacts", e))) {
		free(a);
		return ERR_IO;
	}
	for (k = 0; k < PQntuples(r) && k < limit; k++) {
		a[k].seq = pgdb_i64(r, k, 0);
		pgdb_copy(r, k, 1, a[k].job_id, sizeof a[k].job_id);
		a[k].tenant_id = pgdb_i64(r, k, 2);
		pgdb_copy(r, k, 3, a[k].name, sizeof a[k].name);
		a[k].bytes = pgdb_i64(r, k, 4);
		pgdb_copy(r, k, 5, a[k].sha256, sizeof a[k].sha256);
	}
	PQclear(r);
	*v = a;
	*n = k;
	return 0;
}

int pgdb_artifact_quarantine(struct db *db, int64_t seq, struct err *e)
{
	/* The UPDATE re-checks "artifact IS NOT NULL" on the row a concurrent
	 * quarantine or expiry left, so the bytes are credited once. */
	static const char sql[] =
		"UPDATE jobs SET artifact = NULL, artifact_damaged_at = $2::bigint"
		" WHERE seq = $1::bigint AND artifact IS NOT NULL RETURNING tenant_id, artifact_bytes";
	struct pgdb_params p;
	int64_t tenant_id, bytes;
	PGresult *r;
	int rc;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_i64(&p, seq);
	pgdb_p_i64(&p, db_now_ms());
	if (!(r = pgdb_q(db, sql, &p, "quarantining an artifact", e))) {
		pgdb_rollback(db);
		return ERR_IO;
	}
	if (PQntuples(r) != 1) {
		PQclear(r);
		pgdb_rollback(db);
		return ERR_SET(e, ERR_NOTFOUND, "job holds no artifact");
	}
	tenant_id = pgdb_i64(r, 0, 0);
	bytes = pgdb_i64(r, 0, 1);
	PQclear(r);
	if ((rc = pgdb_add_usage_locked(db, tenant_id, -bytes, e)) || (rc = pgdb_commit(db, e))) {
		pgdb_rollback(db);
		return rc;
	}
	return 0;
}
