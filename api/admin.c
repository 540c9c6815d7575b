/* admin.c - /v1/tenants: tenant administration over HTTP with the admin
 * key (the same operations as `infilld tenant ...`).  A new or rotated
 * key appears once, in the response body.
 */
#include "api/api_internal.h"
#include "api/log.h"
#include "db/store.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static json_t *tenant_json(const struct tenant *t)
{
	char ts[32];

	return json_pack("{s:s, s:i, s:I, s:I, s:I, s:s}", "name", t->name, "max_jobs", t->max_jobs,
			 "max_upload_bytes", (json_int_t)t->max_upload_bytes, "quota_bytes",
			 (json_int_t)t->quota_bytes, "used_bytes", (json_int_t)t->used_bytes,
			 "created_at", api_time(t->created_ms, ts, sizeof ts));
}

static json_t *parse_body(struct api_req *r, enum MHD_Result *ret)
{
	json_error_t jerr;
	json_t *b;

	if (r->body.len == 0)
		return json_object();
	b = json_loadb((const char *)r->body.data, r->body.len, JSON_REJECT_DUPLICATES, &jerr);
	if (!b) {
		*ret = api_problem(r, PROB_MALFORMED_JSON, NULL, "line %d, column %d: %s", jerr.line,
				   jerr.column, jerr.text);
		return NULL;
	}
	if (!json_is_object(b)) {
		json_decref(b);
		*ret = api_problem(r, PROB_INVALID_PARAM, NULL, "the body must be a JSON object");
		return NULL;
	}
	return b;
}

enum MHD_Result api_tenant_create(struct api_req *r)
{
	struct tenant_limits l;
	struct tenant t;
	char key[API_KEY_MAX];
	enum MHD_Result ret = MHD_NO;
	json_t *b = parse_body(r, &ret), *v, *o;
	const char *name, *k;
	struct err e;
	struct db *db;
	int rc;

	if (!b)
		return ret;
	err_clear(&e); /* the problem prints its place fields */
	db_tenant_limits_default(&l);
	json_object_foreach(b, k, v) {
		if (!strcmp(k, "name"))
			continue;
		if (!json_is_integer(v) || json_integer_value(v) < 0) {
			ret = api_problem(r, PROB_INVALID_PARAM, k, "'%s' must be a non-negative integer", k);
			goto out;
		}
		if (!strcmp(k, "max_jobs") && json_integer_value(v) >= 1 && json_integer_value(v) <= 1024)
			l.max_jobs = (int)json_integer_value(v);
		else if (!strcmp(k, "max_upload_bytes") && json_integer_value(v) >= 1)
			l.max_upload_bytes = json_integer_value(v);
		else if (!strcmp(k, "quota_bytes"))
			l.quota_bytes = json_integer_value(v);
		else {
			ret = api_problem(r, PROB_INVALID_PARAM, k, "unknown or out-of-range field '%s'", k);
			goto out;
		}
	}
	v = json_object_get(b, "name");
	name = json_is_string(v) ? json_string_value(v) : NULL;
	if (!name) {
		ret = api_problem(r, PROB_INVALID_PARAM, "name", "'name' (string) is required");
		goto out;
	}
	db = db_pool_get(r->srv->pool);
	rc = db_tenant_add(db, name, &l, &t, key, &e);
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_PARAM && strstr(e.msg, "already exists")) {
		ret = api_problem(r, PROB_CONFLICT, "name", "%s", e.msg);
	} else if (rc) {
		ret = api_problem_err(r, &e);
	} else {
		char loc[96];
		struct MHD_Response *resp;
		o = tenant_json(&t);
		json_object_set_new(o, "api_key", json_string(key));
		resp = api_json_response(o);
		snprintf(loc, sizeof loc, "/v1/tenants/%s", t.name);
		if (resp)
			MHD_add_response_header(resp, MHD_HTTP_HEADER_LOCATION, loc);
		log_msg(LOG_INFO, "admin", "tenant %s added", t.name);
		ret = api_queue(r, MHD_HTTP_CREATED, resp);
	}
out:
	json_decref(b);
	return ret;
}

enum MHD_Result api_tenant_list(struct api_req *r)
{
	struct tenant *v;
	struct err e;
	json_t *arr;
	int n, rc;
	struct db *db = db_pool_get(r->srv->pool);

	err_clear(&e);
	rc = db_tenant_list(db, &v, &n, &e);
	db_pool_put(r->srv->pool, db);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	arr = json_array();
	for (int i = 0; i < n; i++)
		json_array_append_new(arr, tenant_json(&v[i]));
	free(v);
	return api_json(r, MHD_HTTP_OK, json_pack("{s:o}", "tenants", arr));
}

enum MHD_Result api_tenant_get(struct api_req *r)
{
	struct tenant t;
	struct err e;
	struct db *db = db_pool_get(r->srv->pool);
	int rc = db_tenant_get(db, r->arg[0], &t, &e);

	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no tenant '%s'", r->arg[0]);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	return api_json(r, MHD_HTTP_OK, tenant_json(&t));
}

enum MHD_Result api_tenant_delete(struct api_req *r)
{
	char dir[STORE_PATH_MAX];
	struct err e;
	int64_t id;
	struct db *db = db_pool_get(r->srv->pool);
	int rc = db_tenant_remove(db, r->arg[0], &id, &e);

	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no tenant '%s'", r->arg[0]);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	store_tenant_dir(r->srv->cfg.store_dir, id, dir, sizeof dir);
	if (store_remove_tree(dir, &e))
		log_msg(LOG_WARN, "admin", "%s", e.msg);
	log_msg(LOG_INFO, "admin", "tenant %s removed", r->arg[0]);
	return api_queue(r, MHD_HTTP_NO_CONTENT,
			 MHD_create_response_from_buffer(0, NULL, MHD_RESPMEM_PERSISTENT));
}

enum MHD_Result api_tenant_rotate(struct api_req *r)
{
	char key[API_KEY_MAX];
	struct tenant t;
	struct err e;
	struct db *db = db_pool_get(r->srv->pool);
	int rc = db_tenant_rotate(db, r->arg[0], key, &e);
	json_t *o;

	if (!rc)
		rc = db_tenant_get(db, r->arg[0], &t, &e);
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no tenant '%s'", r->arg[0]);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	o = tenant_json(&t);
	json_object_set_new(o, "api_key", json_string(key));
	log_msg(LOG_INFO, "admin", "key of tenant %s rotated", r->arg[0]);
	return api_json(r, MHD_HTTP_CREATED, o);
}
