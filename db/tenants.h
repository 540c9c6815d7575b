/* tenants.h - tenants, their API keys and the admin key.
 *
 * A key is "ifk_<key id>_<secret>" (tenants) or "ifa_<key id>_<secret>"
 * (admin): the key id (12 chars) finds the row, the row holds SHA-256 of
 * the whole key, compared in constant time.  The secret carries 160 random
 * bits, so a plain hash is enough (no password stretching needed).  Keys
 * are shown once, when made; the database never holds them.
 */
#ifndef INFILLD_DB_TENANTS_H
#define INFILLD_DB_TENANTS_H

#include <stdint.h>

struct db;
struct err;

#define TENANT_NAME_MAX 64
#define API_KEY_MAX 64

struct tenant {
	int64_t id;
	char name[TENANT_NAME_MAX];
	int max_jobs;             /* concurrently running jobs, >= 1 */
	int64_t max_upload_bytes; /* one upload */
	int64_t quota_bytes;      /* meshes + artifacts; 0 = unlimited */
	int64_t used_bytes;
	int64_t created_ms;
};

struct tenant_limits {
	int max_jobs;
	int64_t max_upload_bytes;
	int64_t quota_bytes;
};

/* Defaults for `tenant add` without options (docs/operations.md). */
void db_tenant_limits_default(struct tenant_limits *l);

/* Names: 1..63 chars of [A-Za-z0-9._-], starting alphanumeric. */
int db_tenant_name_valid(const char *name);

/* Create tenant name; key receives its new API key (API_KEY_MAX bytes).
 * ERR_PARAM (field "name") if the name is invalid or taken. */
int db_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		  struct tenant *out, char *key, struct err *e);
/* All tenants ordered by name; caller frees *v with free(). */
int db_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e);
/* ERR_NOTFOUND if no such tenant. */
int db_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e);
int db_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e);
/* Replace the tenant's key (the old one stops working at once). */
int db_tenant_rotate(struct db *db, const char *name, char *key, struct err *e);
/* Delete the tenant with its meshes, jobs and events (rows only; the
 * caller removes DATA/tenants/<id>/).  *id receives the removed id. */
int db_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e);
/* Add delta to the tenant's used_bytes (inside the caller's transaction or
 * on its own). */
int db_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e);
/* Charge bytes (>= 0) to the tenant's used_bytes only if they fit its
 * quota (0 = none), checked and charged in one statement inside the
 * caller's transaction.  ERR_LIMIT (nothing charged) when they would pass
 * it; ERR_NOTFOUND for a missing tenant. */
int db_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e);

/* Authenticate a tenant key: 0 and *out, or ERR_NOTFOUND for any key that
 * is malformed, unknown or wrong (callers answer 401 without saying why). */
int db_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e);

/* Replace every admin key with a new one (key: API_KEY_MAX bytes). */
int db_admin_key_rotate(struct db *db, char *key, struct err *e);
/* 0 when key is a valid admin key, ERR_NOTFOUND otherwise. */
int db_admin_auth(struct db *db, const char *key, struct err *e);

/* SHA-256 helpers (nettle) shared by uploads and artifacts. */
#define SHA256_HEX_LEN 64
void db_sha256_hex(const unsigned char digest[32], char hex[SHA256_HEX_LEN + 1]);

#endif
