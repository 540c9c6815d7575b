/* http.c - response helpers: JSON bodies, timestamps, header and query
 * access, and parking connections (suspend/resume) so no handler thread
 * ever waits.
 */
#include "api/api_internal.h"
#include "api/gate.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* --cors-origin: responses to that origin's requests may be read by its
 * pages (no credentials: keys travel in headers, never cookies). */
static int cors_allowed(struct api_req *r)
{
	const char *origin = r->srv->cfg.cors_origin ? api_header(r, "Origin") : NULL;

	return origin && !strcmp(origin, r->srv->cfg.cors_origin);
}

static void cors_headers(struct api_req *r, struct MHD_Response *resp)
{
	if (!r->srv->cfg.cors_origin)
		return;
	MHD_add_response_header(resp, "Vary", "Origin");
	if (!cors_allowed(r))
		return;
	MHD_add_response_header(resp, "Access-Control-Allow-Origin", r->srv->cfg.cors_origin);
	MHD_add_response_header(resp, "Access-Control-Expose-Headers",
				"ETag, Location, Retry-After, Repr-Digest, Content-Disposition, "
				"Content-Range, X-Artifact-Length, X-Layer-Count, "
				"Idempotent-Replayed");
}

enum MHD_Result api_cors_preflight(struct api_req *r, const char *allow)
{
	struct MHD_Response *resp = MHD_create_response_from_buffer(0, NULL,
								    MHD_RESPMEM_PERSISTENT);

	if (!resp)
		return MHD_NO;
	if (cors_allowed(r)) {
		MHD_add_response_header(resp, "Access-Control-Allow-Methods", allow);
		MHD_add_response_header(resp, "Access-Control-Allow-Headers",
					"Authorization, X-Api-Key, Content-Type, Idempotency-Key, "
					"Last-Event-ID, Range, If-None-Match, If-Range");
		MHD_add_response_header(resp, "Access-Control-Max-Age", "600");
	}
	return api_queue(r, MHD_HTTP_NO_CONTENT, resp);
}

enum MHD_Result api_queue(struct api_req *r, unsigned status, struct MHD_Response *resp)
{
	enum MHD_Result ret;

	if (!resp)
		return MHD_NO; /* out of memory: MHD closes the connection */
	MHD_add_response_header(resp, "Cache-Control", "no-store");
	cors_headers(r, resp);
	/* Past 3/4 of the connection limit, keep-alive gives way: the next
	 * request comes through the head gate again instead of holding a
	 * slot while its head trickles in. */
	if (r->srv->gate && api_gate_live(r->srv->gate) * 4 >= r->srv->cfg.max_connections * 3)
		MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close");
	if (status >= 400 && r->upload)
		api_upload_discard(r->upload); /* a refused upload leaves no file */
	r->status = status;
	ret = MHD_queue_response(r->conn, status, resp);
	MHD_destroy_response(resp);
	return ret;
}

struct MHD_Response *api_json_response(json_t *body)
{
	return api_json_response_as(body, "application/json");
}

struct MHD_Response *api_json_response_as(json_t *body, const char *content_type)
{
	struct MHD_Response *resp;
	char *text;

	if (!body)
		return NULL;
	text = json_dumps(body, JSON_COMPACT | JSON_ENSURE_ASCII);
	json_decref(body);
	if (!text)
		return NULL;
	resp = MHD_create_response_from_buffer_with_free_callback(strlen(text), text, free);
	if (!resp) {
		free(text);
		return NULL;
	}
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, content_type);
	return resp;
}

enum MHD_Result api_json(struct api_req *r, unsigned status, json_t *body)
{
	struct MHD_Response *resp = api_json_response(body);

	if (!resp) {
		unsigned st;
		resp = api_problem_response(PROB_INTERNAL, r->url, NULL, "out of memory", &st);
		status = st;
	}
	return api_queue(r, status, resp);
}

const char *api_time(int64_t ms, char *buf, size_t len)
{
	time_t s = (time_t)(ms / 1000);
	struct tm tm;

	gmtime_r(&s, &tm);
	snprintf(buf, len, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
		 tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, (int)(ms % 1000));
	return buf;
}

const char *api_header(struct api_req *r, const char *name)
{
	return MHD_lookup_connection_value(r->conn, MHD_HEADER_KIND, name);
}

const char *api_query(struct api_req *r, const char *name)
{
	return MHD_lookup_connection_value(r->conn, MHD_GET_ARGUMENT_KIND, name);
}

void api_park(struct api_req *r)
{
	r->suspended = 1;
	MHD_suspend_connection(r->conn);
}

void api_wake(struct api_server *s, struct MHD_Connection *conn)
{
	(void)s;
	MHD_resume_connection(conn);
}

void api_reject_field(struct api_req *r, const char *field)
{
	snprintf(r->reject_field, sizeof r->reject_field, "%s", field);
}

void api_reject(struct api_req *r, enum problem p, const char *fmt, ...)
{
	va_list ap;

	if (r->rejected)
		return;
	r->rejected = 1;
	r->reject_p = p;
	va_start(ap, fmt);
	vsnprintf(r->reject_detail, sizeof r->reject_detail, fmt, ap);
	va_end(ap);
}

int api_text_valid(const char *s)
{
	const unsigned char *p = (const unsigned char *)s;

	while (*p) {
		unsigned c = *p;
		int n;
		uint32_t cp;

		if (c < 0x20 || c == 0x7f)
			return 0;
		if (c < 0x80) {
			p++;
			continue;
		}
		if (c >= 0xc2 && c <= 0xdf)
			n = 1, cp = c & 0x1f;
		else if (c >= 0xe0 && c <= 0xef)
			n = 2, cp = c & 0x0f;
		else if (c >= 0xf0 && c <= 0xf4)
			n = 3, cp = c & 0x07;
		else
			return 0;
		for (int i = 1; i <= n; i++) {
			if ((p[i] & 0xc0) != 0x80)
				return 0;
			cp = cp << 6 | (p[i] & 0x3f);
		}
		/* overlong, surrogates, past U+10FFFF */
		if ((n == 2 && cp < 0x800) || (n == 3 && (cp < 0x10000 || cp > 0x10ffff)) ||
		    (cp >= 0xd800 && cp <= 0xdfff))
			return 0;
		p += n + 1;
	}
	return 1;
}
