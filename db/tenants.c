/* tenants.c - tenants, API keys (hashed, constant-time compare) and the
 * admin key (see tenants.h).
 */
#include "db/tenants.h"
#include "db/db_internal.h"
#include "engine/core/err.h"

#include <ctype.h>
#include <errno.h>
#include <nettle/memops.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>

#define KEY_ID_LEN 12
#define KEY_SECRET_LEN 32 /* base32: 160 bits */

static const char key_alphabet[] = "abcdefghijklmnopqrstuvwxyz234567";

void db_sha256_hex(const unsigned char digest[32], char hex[SHA256_HEX_LEN + 1])
{
	static const char hx[] = "0123456789abcdef";

	for (int i = 0; i < 32; i++) {
		hex[2 * i] = hx[digest[i] >> 4];
		hex[2 * i + 1] = hx[digest[i] & 15];
	}
	hex[SHA256_HEX_LEN] = '\0';
}

static void sha256_of(const char *s, unsigned char out[SHA256_DIGEST_SIZE])
{
	struct sha256_ctx c;

	sha256_init(&c);
	sha256_update(&c, strlen(s), (const uint8_t *)s);
	sha256_digest(&c, SHA256_DIGEST_SIZE, out);
}

static int random_chars(char *buf, int n, struct err *e)
{
	unsigned char rnd[64];
	size_t got = 0;

	while (got < (size_t)n) {
		ssize_t r = getrandom(rnd + got, (size_t)n - got, 0);
		if (r < 0) {
			if (errno == EINTR)
				continue;
			return ERR_SET(e, ERR_IO, "getrandom: %s", strerror(errno));
		}
		got += (size_t)r;
	}
	for (int i = 0; i < n; i++)
		buf[i] = key_alphabet[rnd[i] & 31];
	buf[n] = '\0';
	return 0;
}

/* "ifk_" + id + "_" + secret; key_id gets the id. */
static int make_key(const char *kind, char *key, char key_id[KEY_ID_LEN + 1],
		    unsigned char hash[SHA256_DIGEST_SIZE], struct err *e)
{
	char secret[KEY_SECRET_LEN + 1];
	int rc = random_chars(key_id, KEY_ID_LEN, e);

	if (!rc)
		rc = random_chars(secret, KEY_SECRET_LEN, e);
	if (rc)
		return rc;
	snprintf(key, API_KEY_MAX, "%s_%s_%s", kind, key_id, secret);
	sha256_of(key, hash);
	return 0;
}

/* Split a presented key; 0 when it has the shape kind_<id>_<secret>. */
static int parse_key(const char *key, const char *kind, char key_id[KEY_ID_LEN + 1])
{
	size_t kl = strlen(kind);

	if (!key || strlen(key) != kl + 1 + KEY_ID_LEN + 1 + KEY_SECRET_LEN)
		return -1;
	if (strncmp(key, kind, kl) || key[kl] != '_' || key[kl + 1 + KEY_ID_LEN] != '_')
		return -1;
	for (int i = 0; i < KEY_ID_LEN; i++) {
		char c = key[kl + 1 + (size_t)i];
		if (!strchr(key_alphabet, c) || !c)
			return -1;
		key_id[i] = c;
	}
	key_id[KEY_ID_LEN] = '\0';
	return 0;
}

void db_tenant_limits_default(struct tenant_limits *l)
{
	l->max_jobs = 2;
	l->max_upload_bytes = 256ll << 20;
	l->quota_bytes = 10ll << 30;
}

int db_tenant_name_valid(const char *name)
{
	size_t n = name ? strlen(name) : 0;

	if (n == 0 || n >= TENANT_NAME_MAX || !isalnum((unsigned char)name[0]))
		return 0;
	for (size_t i = 0; i < n; i++)
		if (!isalnum((unsigned char)name[i]) && !strchr("._-", name[i]))
			return 0;
	return 1;
}

#define TENANT_COLS \
	"id, name, max_jobs, max_upload_bytes, quota_bytes, used_bytes, created_at"

/* Columns TENANT_COLS starting at column c0. */
static void read_tenant_at(sqlite3_stmt *st, int c0, struct tenant *t)
{
	t->id = sqlite3_column_int64(st, c0);
	db_col_copy(st, c0 + 1, t->name, sizeof t->name);
	t->max_jobs = sqlite3_column_int(st, c0 + 2);
	t->max_upload_bytes = sqlite3_column_int64(st, c0 + 3);
	t->quota_bytes = sqlite3_column_int64(st, c0 + 4);
	t->used_bytes = sqlite3_column_int64(st, c0 + 5);
	t->created_ms = sqlite3_column_int64(st, c0 + 6);
}

int db_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		  struct tenant *out, char *key, struct err *e)
{
	static const char sql[] =
		"INSERT INTO tenants(name, key_id, key_hash, max_jobs, max_upload_bytes,"
		" quota_bytes, served_seq, created_at)"
		" VALUES (?1, ?2, ?3, ?4, ?5, ?6,"
		"  (SELECT value FROM meta WHERE key = 'serve_seq'), ?7)"
		" RETURNING " TENANT_COLS;
	char key_id[KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[SHA256_DIGEST_SIZE];
	sqlite3_stmt *st;
	int rc;

	if (!db_tenant_name_valid(name))
		return ERR_FIELD(e, "name",
				 "tenant name must be 1-63 characters of A-Z a-z 0-9 . _ -, "
				 "starting with a letter or digit");
	if (l->max_jobs < 1 || l->max_upload_bytes < 1 || l->quota_bytes < 0)
		return ERR_FIELD(e, "max_jobs", "limits must be positive");
	rc = make_key("ifk", k, key_id, hash, e);
	if (rc)
		return rc;
	rc = db_begin(db, e);
	if (rc)
		return rc;
	st = db_stmt(db, sql, e);
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
		rc = db_commit(db, e);
	} else {
		int ext = sqlite3_extended_errcode(db->sq);
		if (ext == SQLITE_CONSTRAINT_UNIQUE)
			rc = ERR_FIELD(e, "name", "tenant '%s' already exists", name);
		else
			rc = db_fail(db, e, "adding tenant");
		sqlite3_reset(st);
	}
out:
	if (rc)
		db_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int db_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e)
{
	static const char sql[] = "SELECT " TENANT_COLS " FROM tenants ORDER BY name";
	sqlite3_stmt *st = db_stmt(db, sql, e);
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
		return db_fail(db, e, "listing tenants");
	}
	*v = a;
	*n = cnt;
	return 0;
}

static int get_one(struct db *db, const char *sql, const char *name, int64_t id,
		   struct tenant *out, struct err *e)
{
	sqlite3_stmt *st = db_stmt(db, sql, e);
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
	return db_fail(db, e, "reading tenant");
}

int db_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE name = ?1", name, 0, out, e);
}

int db_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e)
{
	return get_one(db, "SELECT " TENANT_COLS " FROM tenants WHERE id = ?1", NULL, id, out, e);
}

int db_tenant_rotate(struct db *db, const char *name, char *key, struct err *e)
{
	static const char sql[] = "UPDATE tenants SET key_id = ?2, key_hash = ?3 WHERE name = ?1";
	char key_id[KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[SHA256_DIGEST_SIZE];
	sqlite3_stmt *st;
	int rc = make_key("ifk", k, key_id, hash, e);

	if (rc)
		return rc;
	if ((rc = db_begin(db, e)))
		return rc;
	if (!(st = db_stmt(db, sql, e))) {
		db_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	sqlite3_bind_text(st, 2, key_id, -1, SQLITE_STATIC);
	sqlite3_bind_blob(st, 3, hash, sizeof hash, SQLITE_STATIC);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		rc = db_fail(db, e, "rotating key");
	else if (sqlite3_changes(db->sq) != 1)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	else
		rc = db_commit(db, e);
	if (rc)
		db_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}

int db_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e)
{
	static const char sql[] = "DELETE FROM tenants WHERE name = ?1 RETURNING id";
	sqlite3_stmt *st;
	int64_t rid = 0;
	int rc;

	if ((rc = db_begin(db, e)))
		return rc;
	if (!(st = db_stmt(db, sql, e))) {
		db_rollback(db);
		return ERR_IO;
	}
	sqlite3_bind_text(st, 1, name, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW)
		rid = sqlite3_column_int64(st, 0);
	sqlite3_reset(st);
	if (rc == SQLITE_ROW)
		rc = db_commit(db, e);
	else if (rc == SQLITE_DONE)
		rc = ERR_SET(e, ERR_NOTFOUND, "no tenant '%s'", name);
	else
		rc = db_fail(db, e, "removing tenant");
	if (rc)
		db_rollback(db);
	else
		*id = rid;
	return rc;
}

int db_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e)
{
	static const char sql[] =
		"UPDATE tenants SET used_bytes = max(0, used_bytes + ?2) WHERE id = ?1";
	sqlite3_stmt *st = db_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_int64(st, 2, delta);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	return rc == SQLITE_DONE ? 0 : db_fail(db, e, "updating usage");
}

int db_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e)
{
	/* One statement checks and charges: concurrent writers of a tenant
	 * each see the usage the previous one left (BEGIN IMMEDIATE). */
	static const char sql[] =
		"UPDATE tenants SET used_bytes = used_bytes + ?2 WHERE id = ?1"
		" AND (quota_bytes = 0 OR used_bytes + ?2 <= quota_bytes)";
	sqlite3_stmt *st = db_stmt(db, sql, e);
	struct tenant t;
	int rc;

	if (!st)
		return ERR_IO;
	sqlite3_bind_int64(st, 1, tenant_id);
	sqlite3_bind_int64(st, 2, bytes);
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		return db_fail(db, e, "charging usage");
	if (sqlite3_changes(db->sq) == 1)
		return 0;
	if ((rc = db_tenant_get_id(db, tenant_id, &t, e)))
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
	char key_id[KEY_ID_LEN + 1];
	unsigned char hash[SHA256_DIGEST_SIZE];
	sqlite3_stmt *st;
	int rc, ok = 0;

	if (parse_key(key, kind, key_id))
		return ERR_SET(e, ERR_NOTFOUND, "invalid key");
	sha256_of(key, hash);
	if (!(st = db_stmt(db, sql, e)))
		return ERR_IO;
	sqlite3_bind_text(st, 1, key_id, -1, SQLITE_STATIC);
	rc = sqlite3_step(st);
	if (rc == SQLITE_ROW && sqlite3_column_bytes(st, 0) == SHA256_DIGEST_SIZE) {
		ok = memeql_sec(sqlite3_column_blob(st, 0), hash, SHA256_DIGEST_SIZE);
		if (ok && out)
			read_tenant_at(st, 1, out);
	}
	sqlite3_reset(st);
	if (rc != SQLITE_ROW && rc != SQLITE_DONE)
		return db_fail(db, e, "checking key");
	return ok ? 0 : ERR_SET(e, ERR_NOTFOUND, "invalid key");
}

int db_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e)
{
	return auth_key(db, "SELECT key_hash, " TENANT_COLS " FROM tenants WHERE key_id = ?1", "ifk",
			key, out, e);
}

int db_admin_auth(struct db *db, const char *key, struct err *e)
{
	return auth_key(db, "SELECT key_hash FROM admin_keys WHERE key_id = ?1", "ifa", key, NULL,
			e);
}

int db_admin_key_rotate(struct db *db, char *key, struct err *e)
{
	static const char sql[] =
		"INSERT INTO admin_keys(key_id, key_hash, created_at) VALUES (?1, ?2, ?3)";
	char key_id[KEY_ID_LEN + 1], k[API_KEY_MAX];
	unsigned char hash[SHA256_DIGEST_SIZE];
	sqlite3_stmt *st;
	int rc = make_key("ifa", k, key_id, hash, e);

	if (rc || (rc = db_begin(db, e)))
		return rc;
	rc = db_exec(db, "DELETE FROM admin_keys", e);
	if (!rc && !(st = db_stmt(db, sql, e)))
		rc = ERR_IO;
	if (!rc) {
		sqlite3_bind_text(st, 1, key_id, -1, SQLITE_STATIC);
		sqlite3_bind_blob(st, 2, hash, sizeof hash, SQLITE_STATIC);
		sqlite3_bind_int64(st, 3, db_now_ms());
		rc = sqlite3_step(st) == SQLITE_DONE ? 0 : db_fail(db, e, "storing admin key");
		sqlite3_reset(st);
	}
	if (!rc)
		rc = db_commit(db, e);
	if (rc)
		db_rollback(db);
	else
		memcpy(key, k, API_KEY_MAX);
	return rc;
}
