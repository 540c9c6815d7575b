/* problem.c - RFC 9457 problem details: the one table mapping our error
 * kinds to HTTP statuses and stable type URIs ("/problems/<slug>", which
 * GET /problems/<slug> describes), and the engine error codes to them.
 */
#include "api/api_internal.h"
#include "engine/core/err.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static const struct {
	const char *slug;
	unsigned status;
	const char *title;
	const char *doc; /* what it means and what to do */
} problems[PROB_COUNT] = {
	[PROB_BAD_REQUEST] = {"bad-request", 400, "Bad request",
			      "The request is malformed (headers, query or body shape)."},
	[PROB_MALFORMED_JSON] = {"malformed-json", 400, "Malformed JSON",
				 "The body is not valid JSON; detail gives line and column."},
	[PROB_UNAUTHORIZED] = {"unauthorized", 401, "Missing or invalid API key",
			       "Send 'Authorization: Bearer <key>' or 'X-Api-Key: <key>'."},
	[PROB_FORBIDDEN] = {"forbidden", 403, "Not allowed with this key",
			    "The route needs the admin key; tenant keys are refused."},
	[PROB_NOT_FOUND] = {"not-found", 404, "Not found",
			    "No such route or object (objects of other tenants are never visible)."},
	[PROB_METHOD_NOT_ALLOWED] = {"method-not-allowed", 405, "Method not allowed",
				     "The Allow header lists the methods of this route."},
	[PROB_CONFLICT] = {"conflict", 409, "Conflict",
			   "The object is in use or in a state that forbids the request."},
	[PROB_NOT_READY] = {"not-ready", 409, "Output not ready",
			    "The job has not succeeded (yet); follow its events or retry after the "
			    "Retry-After seconds."},
	[PROB_GONE] = {"gone", 410, "Artifact expired",
		       "The output was deleted by the retention policy; submit the job again."},
	[PROB_TOO_LARGE] = {"payload-too-large", 413, "Payload too large",
			    "The body exceeds the tenant's upload limit or the JSON body limit."},
	[PROB_UNSUPPORTED_MEDIA] = {"unsupported-media-type", 415, "Unsupported media type",
				    "Use model/stl, model/obj, application/octet-stream with "
				    "?format=, multipart/form-data, or application/json as documented."},
	[PROB_RANGE] = {"range-not-satisfiable", 416, "Range not satisfiable",
			"The Range header does not overlap the artifact."},
	[PROB_INVALID_PARAM] = {"invalid-parameter", 422, "Invalid parameter",
				"A field has a wrong type or value; 'field' names it."},
	[PROB_CHECKSUM] = {"checksum-mismatch", 422, "Checksum mismatch",
			   "The SHA-256 of the received body differs from the one sent."},
	[PROB_INVALID_MESH] = {"invalid-mesh", 422, "Invalid mesh",
			       "The mesh could not be read; detail names the problem and its place."},
	[PROB_IDEMPOTENCY] = {"idempotency-key-reused", 422, "Idempotency-Key reused",
			      "The Idempotency-Key was used before with a different request."},
	[PROB_QUOTA] = {"quota-exceeded", 403, "Storage quota exceeded",
			"Delete meshes or wait for artifacts to expire."},
	[PROB_INTERNAL] = {"internal", 500, "Internal error",
			   "Something failed on the server; the log has details."},
	[PROB_UNAVAILABLE] = {"unavailable", 503, "Service unavailable",
			      "The service is shutting down, cannot reach its database, or is at its "
			      "connection limit; retry after the Retry-After seconds."},
	[PROB_TIMEOUT] = {"request-timeout", 408, "Request timeout",
			  "The request head did not arrive in time (--head-timeout-s), or the body "
			  "arrived slower than the minimum rate; the connection is closed."},
	[PROB_HEAD_TOO_LARGE] = {"header-fields-too-large", 431, "Request header fields too large",
				 "The request line and header fields exceed 32 KiB."},
	[PROB_NOT_IMPLEMENTED] = {"not-implemented", 501, "Not implemented",
				  "The request uses a transfer coding other than chunked."},
};

unsigned problem_status(enum problem p)
{
	return problems[p].status;
}

const char *problem_slug(enum problem p)
{
	return problems[p].slug;
}

const char *problem_title(enum problem p)
{
	return problems[p].title;
}

int problem_find(const char *slug)
{
	for (int i = 0; i < PROB_COUNT; i++)
		if (!strcmp(problems[i].slug, slug))
			return i;
	return -1;
}

struct MHD_Response *api_problem_response(enum problem p, const char *instance,
					  const char *field, const char *detail,
					  unsigned *status)
{
	return api_problem_response_members(p, instance, field, detail, NULL, status);
}

struct MHD_Response *api_problem_response_members(enum problem p, const char *instance,
						  const char *field, const char *detail,
						  json_t *members, unsigned *status)
{
	char type[64];
	json_t *o;
	struct MHD_Response *resp;

	snprintf(type, sizeof type, "/problems/%s", problems[p].slug);
	o = json_pack("{s:s, s:s, s:i, s:s}", "type", type, "title", problems[p].title, "status",
		      (int)problems[p].status, "detail", detail ? detail : problems[p].title);
	if (o && instance)
		json_object_set_new(o, "instance", json_string(instance));
	if (o && field && field[0])
		json_object_set_new(o, "field", json_string(field));
	if (o && members)
		json_object_update_missing(o, members);
	json_decref(members);
	resp = api_json_response_as(o, "application/problem+json");
	*status = problems[p].status;
	return resp;
}

json_t *api_problem_members(const struct api_req *r, enum problem p)
{
	if (p != PROB_QUOTA)
		return NULL;
	return json_pack("{s:I, s:I}", "used_bytes", (json_int_t)r->tenant.used_bytes,
			 "quota_bytes", (json_int_t)r->tenant.quota_bytes);
}

enum MHD_Result api_problem(struct api_req *r, enum problem p, const char *field,
			    const char *fmt, ...)
{
	char detail[768];
	unsigned status;
	struct MHD_Response *resp;
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(detail, sizeof detail, fmt, ap);
	va_end(ap);
	resp = api_problem_response_members(p, r->url, field, detail, api_problem_members(r, p),
					    &status);
	if (resp && p == PROB_UNAUTHORIZED)
		MHD_add_response_header(resp, MHD_HTTP_HEADER_WWW_AUTHENTICATE,
					"Bearer realm=\"infilld\"");
	return api_queue(r, status, resp);
}

enum MHD_Result api_problem_err(struct api_req *r, const struct err *e)
{
	char text[ERR_MSG_MAX + 128];
	enum problem p;

	switch (e->code) {
	case ERR_PARAM:
	case ERR_FIT:
	case ERR_UNSUPPORTED:
		p = PROB_INVALID_PARAM;
		break;
	case ERR_PARSE:
	case ERR_GEOMETRY:
		p = PROB_INVALID_MESH;
		break;
	case ERR_NOTFOUND:
		p = e->field[0] ? PROB_INVALID_PARAM : PROB_NOT_FOUND;
		break;
	case ERR_LIMIT:
		p = PROB_TOO_LARGE;
		break;
	default:
		p = PROB_INTERNAL;
		break;
	}
	return api_problem(r, p, e->field, "%s", err_format(e, text, sizeof text));
}

enum MHD_Result api_problem_doc(struct api_req *r)
{
	int i = problem_find(r->arg[0]);
	char text[1024];
	struct MHD_Response *resp;
	int n;

	if (i < 0)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no problem type '%s'", r->arg[0]);
	n = snprintf(text, sizeof text, "%s (HTTP %u)\n\n%s\n", problems[i].title,
		     problems[i].status, problems[i].doc);
	resp = MHD_create_response_from_buffer((size_t)n, text, MHD_RESPMEM_MUST_COPY);
	if (resp)
		MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
					"text/plain; charset=utf-8");
	return api_queue(r, MHD_HTTP_OK, resp);
}
