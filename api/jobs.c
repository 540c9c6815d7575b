/* jobs.c - /v1/jobs: submit (validated against the engine's parameter
 * description before queueing, Idempotency-Key), get, list with cursor
 * pagination, cancel.  Events and output live in events.c / output.c.
 */
#include "api/api_internal.h"
#include "api/api_json.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "engine/core/err.h"
#include "engine/engine.h"

#include <ctype.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Test-only failure modes (docs/service.md, "Fault injection"). */
static const char *const faults[] = {"segv", "alloc", "hang", "cpu", NULL};

json_t *api_job_json(const struct job_row *j)
{
	char t1[32], t2[32], t3[32], self[64], events[80], output[80];
	json_t *o, *params, *metrics, *err, *out;

	snprintf(self, sizeof self, "/v1/jobs/%s", j->id);
	snprintf(events, sizeof events, "/v1/jobs/%s/events", j->id);
	snprintf(output, sizeof output, "/v1/jobs/%s/output", j->id);
	params = j->params ? json_loads(j->params, 0, NULL) : NULL;
	metrics = j->metrics ? json_loads(j->metrics, 0, NULL) : NULL;
	err = j->error ? json_pack("{s:s, s:s}", "type", j->error_type, "detail", j->error)
		       : json_null();
	if (j->error && err && j->error_field[0])
		json_object_set_new(err, "field", json_string(j->error_field));
	if (j->state == JOB_SUCCEEDED && j->artifact[0]) {
		enum out_format f;
		struct err e;
		out = json_pack("{s:s, s:I, s:s, s:s}", "url", output, "bytes",
				(json_int_t)j->artifact_bytes, "sha256", j->artifact_sha256,
				"content_type",
				out_format_parse(j->format, &f, &e) == 0 ? out_format_mime(f)
									 : "application/octet-stream");
	} else {
		out = json_null();
	}
	o = json_pack("{s:s, s:s, s:s, s:s, s:s, s:o, s:s, s:s, s:f, s:i, s:i, s:i, s:i,"
		      " s:s, s:o, s:o, s:o, s:o, s:o, s:{s:s, s:s, s:s}}",
		      "id", j->id, "mesh_id", j->mesh_id, "engine", j->engine, "format", j->format,
		      "printer", j->printer, "params", params ? params : json_object(), "state",
		      queue_state_name(j->state), "stage", j->stage, "progress", j->progress,
		      "layers_done", j->layers_done, "layers_total", j->layers_total, "attempt",
		      j->attempt, "max_attempts", j->max_attempts, "created_at",
		      api_time(j->created_ms, t1, sizeof t1), "started_at",
		      j->started_ms ? json_string(api_time(j->started_ms, t2, sizeof t2)) : json_null(),
		      "finished_at",
		      j->finished_ms ? json_string(api_time(j->finished_ms, t3, sizeof t3))
				     : json_null(),
		      "error", err, "metrics", metrics ? metrics : json_null(), "output", out,
		      "links", "self", self, "events", events, "output", output);
	return o;
}

static enum MHD_Result spec_problem(struct api_req *r, struct err *e, const char *default_field)
{
	char field[ERR_FIELD_MAX + 8];
	char text[ERR_MSG_MAX + 128];

	snprintf(field, sizeof field, "%s", e->field[0] ? e->field : default_field);
	return api_problem(r, PROB_INVALID_PARAM, field, "%s", err_format(e, text, sizeof text));
}

/* Refuse at submission a part the mesh's stored analysis (size_mm, the
 * default placement) already shows cannot fit js's printer, with the
 * engine's own placement and fit check (engine_check_fit_size): 0 to go
 * on (also when the mesh or its analysis is missing: the worker decides),
 * else a 422 is queued in *ret. */
static int fit_refused(struct api_req *r, const struct job_spec *js, const char *mesh_id,
		       enum MHD_Result *ret)
{
	struct mesh_rec m;
	struct db *db = db_pool_get(r->srv->pool);
	json_t *a = NULL, *sz;
	struct err e;
	int rc, refused = 0;

	memset(&m, 0, sizeof m);
	err_clear(&e);
	rc = db ? db_mesh_get(db, r->tenant.id, mesh_id, &m, &e) : -1;
	if (db)
		db_pool_put(r->srv->pool, db);
	if (rc == 0 && m.analysis)
		a = json_loads(m.analysis, 0, NULL);
	sz = a ? json_object_get(a, "size_mm") : NULL;
	if (json_is_object(sz)) {
		struct vec3 size = v3(json_number_value(json_object_get(sz, "x")),
				      json_number_value(json_object_get(sz, "y")),
				      json_number_value(json_object_get(sz, "z")));
		err_clear(&e);
		if (engine_check_fit_size(js, size, &e) == ERR_FIT) {
			*ret = spec_problem(r, &e, "params");
			refused = 1;
		}
	}
	json_decref(a);
	db_mesh_rec_fini(&m);
	return refused;
}

/* Idempotency-Key: 1..255 visible ASCII characters. */
static int idem_key_valid(const char *k)
{
	size_t n = strlen(k);

	if (n == 0 || n > 255)
		return 0;
	for (size_t i = 0; i < n; i++)
		if (!isgraph((unsigned char)k[i]))
			return 0;
	return 1;
}

enum MHD_Result api_job_submit(struct api_req *r)
{
	static const char *const allowed[] = {"mesh_id", "engine", "format", "printer",
					      "params", "fault", NULL};
	const char *mesh_id, *engine = NULL, *format = NULL, *printer = NULL, *fault = NULL;
	const char *idem = api_header(r, "Idempotency-Key");
	json_t *body, *v, *params = NULL;
	json_error_t jerr;
	struct job_spec js;
	struct err e;
	const char *key;
	char *canon = NULL, *params_text = NULL, hash_hex[65];
	unsigned char digest[SHA256_DIGEST_SIZE];
	struct sha256_ctx sha;
	enum MHD_Result ret;
	int rc;

	if (idem && !idem_key_valid(idem))
		return api_problem(r, PROB_BAD_REQUEST, "Idempotency-Key",
				   "Idempotency-Key must be 1-255 visible ASCII characters");
	body = json_loadb((const char *)r->body.data, r->body.len, JSON_REJECT_DUPLICATES, &jerr);
	if (!body)
		return api_problem(r, PROB_MALFORMED_JSON, NULL, "line %d, column %d: %s", jerr.line,
				   jerr.column, jerr.text);
	if (!json_is_object(body)) {
		json_decref(body);
		return api_problem(r, PROB_INVALID_PARAM, NULL, "the body must be a JSON object");
	}
	json_object_foreach(body, key, v) {
		int ok = 0;
		for (int i = 0; allowed[i]; i++)
			ok |= !strcmp(key, allowed[i]);
		if (!ok || (!strcmp(key, "fault") && !r->srv->cfg.fault_injection)) {
			ret = api_problem(r, PROB_INVALID_PARAM, key,
					  "unknown field '%s' (allowed: mesh_id, engine, format, "
					  "printer, params)", key);
			goto out;
		}
	}
#define STR_FIELD(name, dst, required)                                                      \
	v = json_object_get(body, name);                                                    \
	if (v && !json_is_null(v) && !json_is_string(v)) {                                  \
		ret = api_problem(r, PROB_INVALID_PARAM, name, "'%s' must be a string", name); \
		goto out;                                                                   \
	}                                                                                   \
	dst = v && json_is_string(v) ? json_string_value(v) : NULL;                         \
	if ((required) && !dst) {                                                           \
		ret = api_problem(r, PROB_INVALID_PARAM, name, "'%s' is required", name);      \
		goto out;                                                                   \
	}
	STR_FIELD("mesh_id", mesh_id, 1)
	STR_FIELD("engine", engine, 0)
	STR_FIELD("format", format, 0)
	STR_FIELD("printer", printer, 0)
	STR_FIELD("fault", fault, 0)
#undef STR_FIELD
	params = json_object_get(body, "params");
	if (params && !json_is_object(params)) {
		ret = api_problem(r, PROB_INVALID_PARAM, "params",
				  "'params' must be an object of parameter names to values");
		goto out;
	}
	if (fault) {
		int ok = 0;
		for (int i = 0; faults[i]; i++)
			ok |= !strcmp(fault, faults[i]);
		if (!ok) {
			ret = api_problem(r, PROB_INVALID_PARAM, "fault",
					  "fault must be segv, alloc, hang or cpu");
			goto out;
		}
	}
	if (!db_id_valid("m_", mesh_id)) {
		ret = api_problem(r, PROB_INVALID_PARAM, "mesh_id", "no mesh '%s'", mesh_id);
		goto out;
	}
	/* Validate exactly as the worker will build the job. */
	err_clear(&e);
	rc = job_spec_init(&js, engine, format, printer, &e);
	if (!rc && params)
		rc = api_params_apply(&js, params, 0, &e);
	if (!rc)
		rc = job_spec_validate(&js, &e);
	if (rc) {
		const char *df = !js.engine ? "engine" : "params";
		job_spec_fini(&js);
		ret = spec_problem(r, &e, df);
		goto out;
	}
	if (fit_refused(r, &js, mesh_id, &ret)) {
		job_spec_fini(&js);
		goto out;
	}
	{
		json_t *c = json_pack("{s:s, s:s, s:s, s:s, s:O, s:s?}", "mesh_id", mesh_id, "engine",
				      js.engine->name, "format", out_format_name(js.format),
				      "printer", js.printer.name, "params",
				      params ? params : json_object(), "fault", fault);
		canon = c ? json_dumps(c, JSON_SORT_KEYS | JSON_COMPACT) : NULL;
		json_decref(c);
		params_text = json_dumps(params ? params : json_object(),
					 JSON_SORT_KEYS | JSON_COMPACT);
	}
	if (!canon || !params_text) {
		job_spec_fini(&js);
		ret = api_problem(r, PROB_INTERNAL, NULL, "out of memory");
		goto out;
	}
	sha256_init(&sha);
	sha256_update(&sha, strlen(canon), (const uint8_t *)canon);
	sha256_digest(&sha, sizeof digest, digest);
	db_sha256_hex(digest, hash_hex);
	if (r->tenant.quota_bytes && r->tenant.used_bytes >= r->tenant.quota_bytes) {
		job_spec_fini(&js);
		ret = api_problem(r, PROB_QUOTA, NULL,
				  "storage quota of %lld bytes is used up (%lld in use); delete meshes "
				  "or wait for artifacts to expire",
				  (long long)r->tenant.quota_bytes, (long long)r->tenant.used_bytes);
		goto out;
	}
	{
		struct job_new jn = {r->tenant.id, mesh_id, js.engine->name,
				     out_format_name(js.format), js.printer.name, params_text,
				     idem, hash_hex, fault, r->srv->cfg.max_attempts};
		rc = api_submit_enqueue(r, &jn);
	}
	job_spec_fini(&js);
	ret = rc ? MHD_NO : MHD_YES; /* answered by the committer */
out:
	free(canon);
	free(params_text);
	json_decref(body);
	return ret;
}

struct MHD_Response *api_submit_response(const struct job_row *j, int replayed)
{
	struct MHD_Response *resp = api_json_response(api_job_json(j));
	char loc[64];

	snprintf(loc, sizeof loc, "/v1/jobs/%s", j->id);
	if (resp) {
		MHD_add_response_header(resp, MHD_HTTP_HEADER_LOCATION, loc);
		MHD_add_response_header(resp, MHD_HTTP_HEADER_RETRY_AFTER, "1");
		if (replayed)
			MHD_add_response_header(resp, "Idempotent-Replayed", "true");
	}
	return resp;
}

/* Load the tenant's job named in the path; on failure a response is
 * queued and *ret set. */
static int load_job(struct api_req *r, struct job_row *j, enum MHD_Result *ret)
{
	struct err e;
	struct db *db;
	int rc;

	if (!db_id_valid("j_", r->arg[0])) {
		*ret = api_problem(r, PROB_NOT_FOUND, NULL, "no job '%s'", r->arg[0]);
		return -1;
	}
	db = db_pool_get(r->srv->pool);
	rc = queue_get(db, r->tenant.id, r->arg[0], j, &e);
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		*ret = api_problem(r, PROB_NOT_FOUND, NULL, "no job '%s'", r->arg[0]);
	else if (rc)
		*ret = api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	return rc ? -1 : 0;
}

int api_load_job(struct api_req *r, struct job_row *j, enum MHD_Result *ret)
{
	return load_job(r, j, ret);
}

int api_load_done_job(struct api_req *r, struct job_row *j, enum MHD_Result *ret,
		      const char *waiting_msg, const char *failed_msg)
{
	struct MHD_Response *resp;
	unsigned status;
	int waiting;

	if (load_job(r, j, ret))
		return -1;
	if (j->state == JOB_SUCCEEDED)
		return 0;
	waiting = j->state == JOB_QUEUED || j->state == JOB_RUNNING;
	resp = api_problem_response(PROB_NOT_READY, r->url, NULL, waiting ? waiting_msg : failed_msg,
				    &status);
	if (resp && waiting)
		MHD_add_response_header(resp, MHD_HTTP_HEADER_RETRY_AFTER, "2");
	queue_job_row_fini(j);
	*ret = api_queue(r, status, resp);
	return -1;
}

enum MHD_Result api_job_get(struct api_req *r)
{
	struct job_row j;
	enum MHD_Result ret;
	json_t *o;

	if (load_job(r, &j, &ret))
		return ret;
	o = api_job_json(&j);
	queue_job_row_fini(&j);
	return api_json(r, MHD_HTTP_OK, o);
}

enum MHD_Result api_job_list(struct api_req *r)
{
	const char *st = api_query(r, "state"), *lim = api_query(r, "limit");
	const char *cur = api_query(r, "cursor");
	int state = -1, limit = 50, n, more, rc;
	int64_t before = 0;
	struct job_row *v;
	struct err e;
	struct db *db;
	json_t *arr, *o;

	if (st && (state = queue_state_parse(st)) < 0)
		return api_problem(r, PROB_INVALID_PARAM, "state",
				   "state must be queued, running, succeeded, failed or cancelled");
	if (lim) {
		limit = atoi(lim);
		if (limit < 1 || limit > 1000 || strspn(lim, "0123456789") != strlen(lim))
			return api_problem(r, PROB_INVALID_PARAM, "limit", "limit must be 1..1000");
	}
	if (cur) {
		char *end;
		before = strtoll(cur, &end, 10);
		if (*end || before <= 0 || end == cur)
			return api_problem(r, PROB_INVALID_PARAM, "cursor", "malformed cursor");
	}
	db = db_pool_get(r->srv->pool);
	rc = queue_list(db, r->tenant.id, state, before, limit, &v, &n, &more, &e);
	db_pool_put(r->srv->pool, db);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	arr = json_array();
	for (int i = 0; i < n; i++)
		json_array_append_new(arr, api_job_json(&v[i]));
	o = json_pack("{s:o}", "jobs", arr);
	if (more && n > 0) {
		/* The cursor is the queue position of the last job returned:
		 * opaque to clients, stable while jobs are added. */
		char c[32];
		snprintf(c, sizeof c, "%lld", (long long)v[n - 1].seq);
		json_object_set_new(o, "next_cursor", json_string(c));
	} else {
		json_object_set_new(o, "next_cursor", json_null());
	}
	queue_job_rows_free(v, n);
	return api_json(r, MHD_HTTP_OK, o);
}

enum MHD_Result api_job_cancel(struct api_req *r)
{
	struct job_row j;
	enum MHD_Result ret;
	struct err e;
	struct db *db;
	int rc;

	if (load_job(r, &j, &ret))
		return ret;
	queue_job_row_fini(&j);
	db = db_pool_get(r->srv->pool);
	rc = queue_cancel(db, r->tenant.id, r->arg[0], &j, &e);
	db_pool_put(r->srv->pool, db);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	if (j.state == JOB_SUCCEEDED || j.state == JOB_FAILED) {
		queue_job_row_fini(&j);
		return api_problem(r, PROB_CONFLICT, NULL, "job %s already %s", r->arg[0],
				   queue_state_name(j.state));
	}
	{
		json_t *o = api_job_json(&j);
		queue_job_row_fini(&j);
		return api_json(r, MHD_HTTP_OK, o);
	}
}
