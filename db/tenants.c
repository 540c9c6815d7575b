/* tenants.c - tenants and keys, backend-independent part (see tenants.h):
 * defaults, name and limit checks, and the calls into the backend's ops.
 */
#include "db/tenants.h"
#include "db/db_ops.h"
#include "engine/core/err.h"

#include <ctype.h>
#include <string.h>

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

int db_tenant_add(struct db *db, const char *name, const struct tenant_limits *l,
		  struct tenant *out, char *key, struct err *e)
{
	if (!db_tenant_name_valid(name))
		return ERR_FIELD(e, "name",
				 "tenant name must be 1-63 characters of A-Z a-z 0-9 . _ -, "
				 "starting with a letter or digit");
	if (l->max_jobs < 1 || l->max_upload_bytes < 1 || l->quota_bytes < 0)
		return ERR_FIELD(e, "max_jobs", "limits must be positive");
	return db->ops->tenant_add(db, name, l, out, key, e);
}

int db_tenant_list(struct db *db, struct tenant **v, int *n, struct err *e)
{
	return db->ops->tenant_list(db, v, n, e);
}

int db_tenant_get(struct db *db, const char *name, struct tenant *out, struct err *e)
{
	return db->ops->tenant_get(db, name, out, e);
}

int db_tenant_get_id(struct db *db, int64_t id, struct tenant *out, struct err *e)
{
	return db->ops->tenant_get_id(db, id, out, e);
}

int db_tenant_rotate(struct db *db, const char *name, char *key, struct err *e)
{
	return db->ops->tenant_rotate(db, name, key, e);
}

int db_tenant_remove(struct db *db, const char *name, int64_t *id, struct err *e)
{
	return db->ops->tenant_remove(db, name, id, e);
}

int db_tenant_add_usage(struct db *db, int64_t tenant_id, int64_t delta, struct err *e)
{
	return db->ops->tenant_add_usage(db, tenant_id, delta, e);
}

int db_tenant_charge(struct db *db, int64_t tenant_id, int64_t bytes, struct err *e)
{
	return db->ops->tenant_charge(db, tenant_id, bytes, e);
}

int db_tenant_auth(struct db *db, const char *key, struct tenant *out, struct err *e)
{
	return db->ops->tenant_auth(db, key, out, e);
}

int db_admin_key_rotate(struct db *db, char *key, struct err *e)
{
	return db->ops->admin_key_rotate(db, key, e);
}

int db_admin_auth(struct db *db, const char *key, struct err *e)
{
	return db->ops->admin_auth(db, key, e);
}
