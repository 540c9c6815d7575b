/* tenants.c - tenants, API keys (SHA-256 in BYTEA, compared in constant
 * time by db_key_hash_eq()) and the admin key on PostgreSQL (tenants.h).
 *
 * Usage is charged with one conditional UPDATE: under READ COMMITTED a
 * concurrent writer of the same row makes the UPDATE wait and then
 * re-check its WHERE on the row it left, so two charges can never pass the
 * quota together.
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

#define TENANT_COLS \
	"id, name, max_jobs, max_upload_bytes, quota_bytes, used_bytes, created_at"

/* Columns TENANT_COLS of row i starting at column c0. */
static void read_tenant_at(const PGresult *r, int i, int c0, struct tenant *t)
{
	memset(t, 0, sizeof *t);
	t->id = pgdb_i64(r, i, c0);
	pgdb_copy(r, i, c0 + 1, t->name, sizeof t->name);
	t->max_jobs = pgdb_int(r, i, c0 + 2);
	t->max_upload_bytes = pgdb_i64(r, i, c0 + 3);
	t->quota_bytes = pgdb_i64(r, i, c0 + 4);
	t->used_bytes = pgdb_i64(r, i, c0 + 5);
	t->created_ms = pgdb_i64(r, i, c0 + 6);
}

int pgdb_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		    struct tenant *out, char *key, struct err *e)
{
	/* A new tenant starts at the current round-robin position, the last
	 * value serve_seq handed out (0 before the first claim): not ahead
	 * of tenants waiting since long ago. */
	static const char sql[] =
		"INSERT INTO tenants(name, key_id, key_hash, max_jobs, max_upload_bytes,"
		" quota_bytes, served_seq, created_at)"
		" VALUES ($1::text, $2::text, $3::bytea, $4::int, $5::bigint, $6::bigint,"
		"  (SELECT CASE WHEN is_called THEN last_value ELSE 0 END FROM serve_seq),"
		"  $7::bigint)"
		" RETURNING " TENANT_COLS;
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	struct pgdb_params p;
	PGresult *r;
	int rc;

	if ((rc = db_key_make("ifk", k, key_id, hash, e)) || (rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, name);
	pgdb_p_text(&p, key_id);
	pgdb_p_bin(&p, hash, sizeof hash);
	pgdb_p_i64(&p, l->max_jobs);
	pgdb_p_i64(&p, l->max_upload_bytes);
	pgdb_p_i64(&p, l->quota_bytes);
	pgdb_p_i64(&p, db_now_ms());
	r = pgdb_q(db, sql, &p, "adding tenant", e);
	if (!r) {
		/* unique_violation: the name is taken (key ids are random). */
		rc = !strcmp(((struct db_pg *)db)->sqlstate, "23505")
			     ? ERR_FIELD(e, "name", "tenant '%s' already exists", name)
			     : ERR_IO;
		goto out;
	}
	read_tenant_at(r, 0, 0, out);
	PQclear(r);
	rc = pgdb_commit(db, e);
out:
	if (rc)
		pgdb_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int pgdb_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e)
{
	static const char sql[] = "SELECT " TENANT_COLS " FROM tenants ORDER BY name";
	PGresult *r = pgdb_q(db, sql, NULL, "listing tenants", e);
	struct tenant *a;
	int cnt;

	if (!r)
		return ERR_IO;
	cnt = PQntuples(r);
	if (!(a = calloc((size_t)cnt + 1, sizeof *a))) {
		PQclear(r);
		return ERR_SET(e, ERR_NOMEM, "out of memory listing tenants");
	}
	for (int i = 0; i < cnt; i++)
		read_tenant_at(r, i, 0, &a[i]);
	PQclear(r);
	*v = a;
	*n = cnt;
	return 0;
}

static int get_one(struct db *db, const char *sql, const char *name, int64_t id,
		   struct tenant *out, struct err *e)
{
	struct pgdb_params p;
	PGresult *r;
	int rc = 0;

	pgdb_p_init(&p);
	if (name)
		pgdb_p_text(&p, name);
	else
		pgdb_p_i64(&p, id);
	if (!(r = pgdb_q(db, sql, &p, "reading tenant", e)))
		return ERR_IO;
	if (PQntuples(r) == 1)
		read_tenant_at(r, 0, 0, out);
	else
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name ? name : "(id)");
	PQclear(r);
	return rc;
}

int pgdb_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE name = $1::text", name, 0,
		       out, e);
}

int pgdb_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE id = $1::bigint", NULL, id,
		       out, e);
}

int pgdb_tenant_rotate(struct db *db, const char *name, char *key, struct err *e)
{
	static const char sql[] =
		"UPDATE tenants SET key_id = $2::text, key_hash = $3::bytea WHERE name = $1::text";
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	struct pgdb_params p;
	PGresult *r;
	int rc;

	if ((rc = db_key_make("ifk", k, key_id, hash, e)) || (rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, name);
	pgdb_p_text(&p, key_id);
	pgdb_p_bin(&p, hash, sizeof hash);
	if (!(r = pgdb_q(db, sql, &p, "rotating key", e)))
		rc = ERR_IO;
	else if (pgdb_changes(r) != 1)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	PQclear(r);
	if (!rc)
		rc = pgdb_commit(db, e);
	if (rc)
		pgdb_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int pgdb_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e)
{
	/* ON DELETE CASCADE removes its meshes, jobs and their events. */
	static const char sql[] = "DELETE FROM tenants WHERE name = $1::text RETURNING id";
	struct pgdb_params p;
	PGresult *r;
	int64_t rid = 0;
	int rc = 0;

	if ((rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, name);
	if (!(r = pgdb_q(db, sql, &p, "removing tenant", e)))
		rc = ERR_IO;
	else if (PQntuples(r) != 1)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	else
		rid = pgdb_i64(r, 0, 0);
	PQclear(r);
	if (!rc)
		rc = pgdb_commit(db, e);
	if (rc)
		pgdb_rollback(db);
	else
		*id = rid;
	return rc;
}

int pgdb_add_usage_locked(struct db *db, int64_t tenant_id, int64_t delta, struct err *e)
{
	static const char sql[] = "UPDATE tenants SET used_bytes = greatest(0, used_bytes + $2::bigint)"
				  " WHERE id = $1::bigint";
	struct pgdb_params p;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_i64(&p, delta);
	return pgdb_run(db, sql, &p, "updating usage", e);
}

int pgdb_charge_locked(struct db *db, int64_t tenant_id, int64_t bytes, const char *what,
		       struct err *e)
{
	/* One statement checks and charges (see the top of this file). */
	static const char sql[] =
		"UPDATE tenants SET used_bytes = used_bytes + $2::bigint WHERE id = $1::bigint"
		" AND (quota_bytes = 0 OR used_bytes + $2::bigint <= quota_bytes)";
	struct pgdb_params p;
	struct tenant t;
	PGresult *r;
	int64_t changed;
	int rc;

	pgdb_p_init(&p);
	pgdb_p_i64(&p, tenant_id);
	pgdb_p_i64(&p, bytes);
	if (!(r = pgdb_q(db, sql, &p, "charging usage", e)))
		return ERR_IO;
	changed = pgdb_changes(r);
	PQclear(r);
	if (changed == 1)
		return 0;
	if ((rc = pgdb_tenant_get_id(db, tenant_id, &t, e)))
		return rc;
	if (!what)
		return ERR_SET(e, ERR_LIMIT,
			       "%lld bytes more would take the tenant past its storage quota of "
			       "%lld bytes (%lld in use)",
			       (long long)bytes, (long long)t.quota_bytes, (long long)t.used_bytes);
	return ERR_SET(e, ERR_LIMIT,
		       "%s (%lld bytes) would take the tenant past its storage quota of %lld bytes "
		       "(%lld in use)",
		       what, (long long)bytes, (long long)t.quota_bytes, (long long)t.used_bytes);
}

/* Charge (or add usage) inside the caller's transaction, or in one of
 * its own. */
static int in_tx(struct db *db, int64_t tenant_id, int64_t n, int charge, struct err *e)
{
	int own = !pgdb_in_tx(db), rc;

	if (own && (rc = pgdb_begin(db, e)))
		return rc;
	rc = charge ? pgdb_charge_locked(db, tenant_id, n, NULL, e)
		    : pgdb_add_usage_locked(db, tenant_id, n, e);
	if (own) {
		if (!rc)
			rc = pgdb_commit(db, e);
		if (rc)
			pgdb_rollback(db);
	}
	return rc;
}

int pgdb_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e)
{
	return in_tx(db, tenant_id, delta, 0, e);
}

int pgdb_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e)
{
	return in_tx(db, tenant_id, bytes, 1, e);
}

/* Look the key id up with sql and compare hashes in constant time. */
static int auth_key(struct db *db, const char *sql, const char *kind, const char *key,
		    struct tenant *out, struct err *e)
{
	char key_id[DB_KEY_ID_LEN + 1];
	unsigned char hash[DB_KEY_HASH_LEN], stored[DB_KEY_HASH_LEN];
	struct pgdb_params p;
	PGresult *r;
	int ok = 0;

	if (db_key_parse(key, kind, key_id))
		return ERR_SET(e, ERR_NOTFOUND, "invalid key");
	db_key_hash(key, hash);
	pgdb_p_init(&p);
	pgdb_p_text(&p, key_id);
	if (!(r = pgdb_q(db, sql, &p, "checking key", e)))
		return ERR_IO;
	if (PQntuples(r) == 1) {
		long len = pgdb_bytea(r, 0, 0, stored, sizeof stored);
		ok = len > 0 && db_key_hash_eq(stored, (size_t)len, hash);
		if (ok && out)
			read_tenant_at(r, 0, 1, out);
	}
	PQclear(r);
	return ok ? 0 : ERR_SET(e, ERR_NOTFOUND, "invalid key");
}

int pgdb_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e)
{
	return auth_key(db, "SELECT key_hash, " TENANT_COLS " FROM tenants WHERE key_id = $1::text",
			"ifk", key, out, e);
}

int pgdb_admin_auth(struct db *db, const char *key, struct err *e)
{
	return auth_key(db, "SELECT key_hash FROM admin_keys WHERE key_id = $1::text", "ifa", key,
			NULL, e);
}

int pgdb_admin_key_rotate(struct db *db, char *key, struct err *e)
{
	/* The table lock (it conflicts with itself, not with readers) makes
	 * concurrent rotations leave exactly one key, as SQLite's single
	 * writer does. */
	static const char lock_sql[] = "LOCK TABLE admin_keys IN SHARE ROW EXCLUSIVE MODE";
	static const char del_sql[] = "DELETE FROM admin_keys";
	static const char ins_sql[] = "INSERT INTO admin_keys(key_id, key_hash, created_at)"
				      " VALUES ($1::text, $2::bytea, $3::bigint)";
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	struct pgdb_params p;
	int rc;

	if ((rc = db_key_make("ifa", k, key_id, hash, e)) || (rc = pgdb_begin(db, e)))
		return rc;
	pgdb_p_init(&p);
	pgdb_p_text(&p, key_id);
	pgdb_p_bin(&p, hash, sizeof hash);
	pgdb_p_i64(&p, db_now_ms());
	if (!(rc = pgdb_run(db, lock_sql, NULL, "storing admin key", e)) &&
	    !(rc = pgdb_run(db, del_sql, NULL, "storing admin key", e)) &&
	    !(rc = pgdb_run(db, ins_sql, &p, "storing admin key", e)))
		rc = pgdb_commit(db, e);
	if (rc)
		pgdb_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}
