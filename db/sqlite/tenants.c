/* tenants.c - the SQLite backend's tenants, API keys (hashed; keys.c
 * makes and compares them) and the admin key (see tenants.h).
 */
#include "db/tenants.h"
#include "db/sqlite/sq_internal.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TENANT_COLS \
	"id, name, max_jobs, max_upload_bytes, quota_bytes, used_bytes, created_at"

/* Columns TENANT_COLS starting at column c0. */
static void read_tenant_at(sqlite3_stmt *st, int c0, struct tenant *t)
{
	t->id = sqlite3_column_int64(st, c0);
	sq_col_copy(st, c0 + 1, t->name, sizeof t->name);
	t->max_jobs = sqlite3_column_int(st, c0 + 2);
	t->max_upload_bytes = sqlite3_column_int64(st, c0 + 3);
	t->quota_bytes = sqlite3_column_int64(st, c0 + 4);
	t->used_bytes = sqlite3_column_int64(st, c0 + 5);
	t->created_ms = sqlite3_column_int64(st, c0 + 6);
}

int sq_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		  struct tenant *out, char *key, struct err *e)
{
	static const char sql[] =
		"INSERT INTO tenants(name, key_id, key_hash, max_jobs, max_upload_bytes,"
		" quota_bytes, served_seq, created_at)"
		" VALUES (?1, ?2, ?3, ?4, ?5, ?6,"
		"  (SELECT value FROM meta WHERE key = 'serve_seq'), ?7)"
		" RETURNING " TENANT_COLS;
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	sqlite3_stmt *st;
	int rc;

	rc = db_key_make("ifk", k, key_id, hash, e);
	if (rc)
		return rc;
	rc = sq_begin(db, e);
	if (rc)
		return rc;
	st = sq_stmt(db, sql, e);
	if (!st) {
		rc = ERR_IO;
		goto out;
	}
	sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 2, key_id, -1, SQLITE_STATIC);
	sqlite3_bind_blob(st, 3, hash, sizeof hash, SQLITE_STATIC);
	sqlite3_bind_int(st, 4, l->max_jobs);
	sqlite3_bind_int64(st, 5, l->max_upload_bytes);
	sqlite3_bind_int64(st, 6, l->quota_bytes);
	sqlite3_bind_int64(st, 7, db_now_ms());
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		read_tenant_at(st, 0, out);
		sqlite3_reset(st);
		rc = sq_commit(db, e);
	} else {
		int ext = sqlite3_extended_errcode(SQ(db));
		if (ext == SQLITE_CONSTRAINT_UNIQUE)
			rc = ERR_FIELD(e, "name", "tenant '%s' already exists", name);
		else
			rc = sq_fail(db, e, "adding tenant");
		sqlite3_reset(st);
	}
out:
	if (rc)
		sq_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int sq_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e)
{
	static const char sql[] = "SELECT " TENANT_COLS " FROM tenants ORDER BY name";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	struct tenant *a = NULL;
	int cnt = 0, cap = 0, rc;

	if (!st)
		return ERR_IO;
	while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
		if (cnt == cap) {
			struct tenant *na = realloc(a, sizeof *a * (size_t)(cap = cap ? cap * 2 : 16));
			if (!na) {
				free(a);
				sqlite3_reset(st);
				return ERR_SET(e, ERR_NOMEM, "out of memory listing tenants");
			}
			a = na;
		}
		read_tenant_at(st, 0, &a[cnt++]);
	}
	sqlite3_reset(st);
	if (rc != SQLITE_DONE) {
		free(a);
		return sq_fail(db, e, "listing tenants");
	}
	*v = a;
	*n = cnt;
	return 0;
}

static int get_one(struct db *db, const char *sql, const char *name, int64_t id,
		   struct tenant *out, struct err *e)
{
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	if (name)
		sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	else
		sqlite3_bind_int64(st, 1, id);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		read_tenant_at(st, 0, out);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		return 0;
	if (rc == SQLITE_DONE)
		return ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name ? name : "(id)");
	return sq_fail(db, e, "reading tenant");
}

int sq_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE name = ?1", name, 0, out, e);
}

int sq_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE id = ?1", NULL, id, out, e);
}

int sq_tenant_rotate(struct db *db, const char *name, char *key, struct err *e)
{
	static const char sql[] = "UPDATE tenants SET key_id = ?2, key_hash = ?3 WHERE name = ?1";
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	sqlite3_stmt *st;
	int rc = db_key_make("ifk", k, key_id, hash, e);

	if (rc)
		return rc;
	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 2, key_id, -1, SQLITE_STATIC);
	sqlite3_bind_blob(st, 3, hash, sizeof hash, SQLITE_STATIC);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		rc = sq_fail(db, e, "rotating key");
	else if (sqlite3_changes(SQ(db)) != 1)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	else
		rc = sq_commit(db, e);
	if (rc)
		sq_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int sq_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e)
{
	static const char sql[] = "DELETE FROM tenants WHERE name = ?1 RETURNING id";
	sqlite3_stmt *st;
	int64_t rid = 0;
	int rc;

	if ((rc = sq_begin(db, e)))
		return rc;
	if (!(st = sq_stmt(db, sql, e))) {
		sq_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		rid = sqlite3_column_int64(st, 0);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		rc = sq_commit(db, e);
	else if (rc == SQLITE_DONE)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	else
		rc = sq_fail(db, e, "removing tenant");
	if (rc)
		sq_rollback(db);
	else
		*id = rid;
	return rc;
}

int sq_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e)
{
	static const char sql[] =
		"UPDATE tenants SET used_bytes = max(0, used_bytes + ?2) WHERE id = ?1";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_int64(st, 2, delta);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	return rc == SQLITE_DONE ? 0 : sq_fail(db, e, "updating usage");
}

int sq_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e)
{
	/* One statement checks and charges: concurrent writers of a tenant
	 * each see the usage the previous one left (BEGIN IMMEDIATE). */
	static const char sql[] =
		"UPDATE tenants SET used_bytes = used_bytes + ?2 WHERE id = ?1"
		" AND (quota_bytes = 0 OR used_bytes + ?2 <= quota_bytes)";
	sqlite3_stmt *st = sq_stmt(db, sql, e);
	struct tenant t;
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_int64(st, 2, bytes);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		return sq_fail(db, e, "charging usage");
	if (sqlite3_changes(SQ(db)) == 1)
		return 0;
	if ((rc = sq_tenant_get_id(db, tenant_id, &t, e)))
		return rc;
	return ERR_SET(e, ERR_LIMIT,
		       "%lld bytes more would take the tenant past its storage quota of %lld bytes "
		       "(%lld in use)",
		       (long long)bytes, (long long)t.quota_bytes, (long long)t.used_bytes);
}

/* Look the key id up with sql and compare hashes in constant time. */
static int auth_key(struct db *db, const char *sql, const char *kind, const char *key,
		    struct tenant *out, struct err *e)
{
	char key_id[DB_KEY_ID_LEN + 1];
	unsigned char hash[DB_KEY_HASH_LEN];
	sqlite3_stmt *st;
	int rc, ok = 0;

	if (db_key_parse(key, kind, key_id))
		return ERR_SET(e, ERR_NOTFOUND, "invalid key");
	db_key_hash(key, hash);
	if (!(st = sq_stmt(db, sql, e)))
		return ERR_IO;
	sqlite3_bind_text(st, 1, key_id, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW) {
		ok = db_key_hash_eq(sqlite3_column_blob(st, 0), (size_t)sqlite3_column_bytes(st, 0),
				    hash);
		if (ok && out)
			read_tenant_at(st, 1, out);
	}
	sqlite3_reset(st);
	if (rc != SQLITE_ROW && rc != SQLITE_DONE)
		return sq_fail(db, e, "checking key");
	return ok ? 0 : ERR_SET(e, ERR_NOTFOUND, "invalid key");
}

int sq_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e)
{
	return auth_key(db, "SELECT key_hash, " TENANT_COLS " FROM tenants WHERE key_id = ?1", "ifk",
			key, out, e);
}

int sq_admin_auth(struct db *db, const char *key, struct err *e)
{
	return auth_key(db, "SELECT key_hash FROM admin_keys WHERE key_id = ?1", "ifa", key, NULL,
			e);
}

int sq_admin_key_rotate(struct db *db, char *key, struct err *e)
{
	static const char sql[] =
		"INSERT INTO admin_keys(key_id, key_hash, created_at) VALUES (?1, ?2, ?3)";
	char key_id[DB_KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[DB_KEY_HASH_LEN];
	sqlite3_stmt *st;
	int rc = db_key_make("ifa", k, key_id, hash, e);

	if (rc || (rc = sq_begin(db, e)))
		return rc;
	rc = sq_exec(db, "DELETE FROM admin_keys", e);
	if (!rc && !(st = sq_stmt(db, sql, e)))
		rc = ERR_IO;
	if (!rc) {
		sqlite3_bind_text(st, 1, key_id, -1, SQLITE_STATIC);
		sqlite3_bind_blob(st, 2, hash, sizeof hash, SQLITE_STATIC);
		sqlite3_bind_int64(st, 3, db_now_ms());
		rc = sqlite3_step(st) == SQLITE_DONE ? 0 : sq_fail(db, e, "storing admin key");
		sqlite3_reset(st);
	}
	if (!rc)
		rc = sq_commit(db, e);
	if (rc)
		sq_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}
