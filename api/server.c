/* server.c - the libmicrohttpd daemon: hardening options, routing, auth,
 * body dispatch, start and stop.
 *
 * Threads: MHD's internal pool (epoll), the gate (gate.c), the notifier
 * that resumes parked SSE streams (notify.c), the committer (committer.c)
 * and the analysis pool (analyze.c).  Handlers never block: slow work parks the
 * connection (MHD_suspend_connection) and a helper resumes it.  Request
 * bodies are read raw (MHD's POST processor is not used).
 */
#include "api/api_internal.h"
#include "api/gate.h"
#include "api/log.h"
#include "db/store.h"
#include "engine/core/err.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static const struct route routes[] = {
	{"GET", "/", AUTH_NONE, BODY_NONE, api_web_index, "/"},
	{"GET", "/web/{}", AUTH_NONE, BODY_NONE, api_web_asset, "/web/{file}"},
	{"GET", "/livez", AUTH_NONE, BODY_NONE, api_livez, "/livez"},
	{"GET", "/readyz", AUTH_NONE, BODY_NONE, api_readyz, "/readyz"},
	{"GET", "/metrics", AUTH_NONE, BODY_NONE, api_metrics, "/metrics"},
	{"GET", "/problems/{}", AUTH_NONE, BODY_NONE, api_problem_doc, "/problems/{slug}"},
	{"GET", "/v1/engines", AUTH_TENANT, BODY_NONE, api_engines, "/v1/engines"},
	{"POST", "/v1/meshes", AUTH_TENANT, BODY_UPLOAD, api_mesh_upload, "/v1/meshes"},
	{"GET", "/v1/meshes", AUTH_TENANT, BODY_NONE, api_mesh_list, "/v1/meshes"},
	{"GET", "/v1/meshes/{}", AUTH_TENANT, BODY_NONE, api_mesh_get, "/v1/meshes/{id}"},
	{"DELETE", "/v1/meshes/{}", AUTH_TENANT, BODY_NONE, api_mesh_delete, "/v1/meshes/{id}"},
	{"POST", "/v1/jobs", AUTH_TENANT, BODY_JSON, api_job_submit, "/v1/jobs"},
	{"GET", "/v1/jobs", AUTH_TENANT, BODY_NONE, api_job_list, "/v1/jobs"},
	{"GET", "/v1/jobs/{}", AUTH_TENANT, BODY_NONE, api_job_get, "/v1/jobs/{id}"},
	{"DELETE", "/v1/jobs/{}", AUTH_TENANT, BODY_NONE, api_job_cancel, "/v1/jobs/{id}"},
	{"GET", "/v1/jobs/{}/events", AUTH_TENANT, BODY_NONE, api_job_events,
	 "/v1/jobs/{id}/events"},
	{"GET", "/v1/jobs/{}/output", AUTH_TENANT, BODY_NONE, api_job_output,
	 "/v1/jobs/{id}/output"},
	{"GET", "/v1/jobs/{}/layers/{}", AUTH_TENANT, BODY_NONE, api_job_layer,
	 "/v1/jobs/{id}/layers/{k}"},
	{"POST", "/v1/tenants", AUTH_ADMIN, BODY_JSON, api_tenant_create, "/v1/tenants"},
	{"GET", "/v1/tenants", AUTH_ADMIN, BODY_NONE, api_tenant_list, "/v1/tenants"},
	{"GET", "/v1/tenants/{}", AUTH_ADMIN, BODY_NONE, api_tenant_get, "/v1/tenants/{name}"},
	{"DELETE", "/v1/tenants/{}", AUTH_ADMIN, BODY_NONE, api_tenant_delete,
	 "/v1/tenants/{name}"},
	{"POST", "/v1/tenants/{}/keys", AUTH_ADMIN, BODY_JSON, api_tenant_rotate,
	 "/v1/tenants/{name}/keys"},
};
#define NROUTES ((int)(sizeof routes / sizeof routes[0]))

const char *api_route_label(int i)
{
	return i < NROUTES ? routes[i].metric : i == NROUTES ? "unmatched" : NULL;
}

/* Match url against pattern, filling up to 2 {} segments. */
static int match(const char *pattern, const char *url, char arg[2][128])
{
	int k = 0;

	while (*pattern && *url) {
		if (pattern[0] == '{' && pattern[1] == '}') {
			size_t n = strcspn(url, "/");
			if (n == 0 || n >= 128 || k >= 2)
				return 0;
			memcpy(arg[k], url, n);
			arg[k++][n] = '\0';
			url += n;
			pattern += 2;
			continue;
		}
		if (*pattern++ != *url++)
			return 0;
	}
	return *pattern == '\0' && *url == '\0';
}

/* The key from "Authorization: Bearer K" or "X-Api-Key: K". */
static const char *presented_key(struct api_req *r)
{
	const char *h = api_header(r, MHD_HTTP_HEADER_AUTHORIZATION);

	if (h && !strncasecmp(h, "Bearer ", 7)) {
		h += 7;
		while (*h == ' ')
			h++;
		return h;
	}
	return api_header(r, "X-Api-Key");
}

static enum MHD_Result authenticate(struct api_req *r)
{
	const char *key = presented_key(r);
	struct db *db;
	struct err e;
	int rc;

	if (!key || !*key)
		return api_problem(r, PROB_UNAUTHORIZED, NULL, "no API key in the request");
	db = db_pool_get(r->srv->pool);
	err_clear(&e);
	if (r->route->auth == AUTH_ADMIN) {
		rc = db_admin_auth(db, key, &e);
		if (rc == ERR_NOTFOUND && db_tenant_auth(db, key, &r->tenant, &e) == 0) {
			db_pool_put(r->srv->pool, db);
			return api_problem(r, PROB_FORBIDDEN, NULL,
					   "this route needs the admin key, not a tenant key");
		}
	} else {
		rc = db_tenant_auth(db, key, &r->tenant, &e);
	}
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_UNAUTHORIZED, NULL, "the API key is not valid");
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "cannot check the key: %s", e.msg);
	return MHD_YES;
}

static int has_body(struct MHD_Connection *conn)
{
	const char *cl = MHD_lookup_connection_value(conn, MHD_HEADER_KIND,
						     MHD_HTTP_HEADER_CONTENT_LENGTH);
	const char *te = MHD_lookup_connection_value(conn, MHD_HEADER_KIND,
						     MHD_HTTP_HEADER_TRANSFER_ENCODING);

	return te != NULL || (cl && strtoull(cl, NULL, 10) > 0);
}

/* Route, authenticate, check body headers.  Returns with r->status set
 * when a response was queued. */
static enum MHD_Result start_request(struct api_req *r)
{
	if (atomic_load(&r->srv->stopping) && strcmp(r->url, "/livez") != 0)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "the service is shutting down");
	const struct route *path_hit = NULL;
	char allow[64] = "";
	enum MHD_Result ret;
	char args[2][128];

	for (int i = 0; i < NROUTES; i++) {
		if (!match(routes[i].pattern, r->url, args))
			continue;
		path_hit = &routes[i];
		if (!strcmp(routes[i].method, r->method) ||
		    (r->head && !strcmp(routes[i].method, "GET"))) {
			r->route = &routes[i];
			r->route_index = i;
			memcpy(r->arg, args, sizeof args);
			break;
		}
		if (strlen(allow) + strlen(routes[i].method) + 8 < sizeof allow) {
			if (allow[0])
				strcat(allow, ", ");
			strcat(allow, routes[i].method);
			if (!strcmp(routes[i].method, "GET"))
				strcat(allow, ", HEAD");
		}
	}
	if (!r->route) {
		r->route_index = NROUTES;
		if (path_hit && !strcmp(r->method, "OPTIONS") && r->srv->cfg.cors_origin)
			return api_cors_preflight(r, allow);
		if (path_hit) {
			unsigned st;
			struct MHD_Response *resp = api_problem_response(
				PROB_METHOD_NOT_ALLOWED, r->url, NULL,
				"this route does not answer that method", &st);
			if (resp)
				MHD_add_response_header(resp, MHD_HTTP_HEADER_ALLOW, allow);
			return api_queue(r, st, resp);
		}
		return api_problem(r, PROB_NOT_FOUND, NULL, "no route %s %s", r->method, r->url);
	}
	if (r->route->auth != AUTH_NONE) {
		ret = authenticate(r);
		if (r->status || ret != MHD_YES)
			return ret;
	}
	if (r->route->body == BODY_JSON) {
		const char *ct = api_header(r, MHD_HTTP_HEADER_CONTENT_TYPE);
		const char *cl = api_header(r, MHD_HTTP_HEADER_CONTENT_LENGTH);
		if (ct && strncasecmp(ct, "application/json", 16) != 0)
			return api_problem(r, PROB_UNSUPPORTED_MEDIA, NULL,
					   "send the body as application/json, not %s", ct);
		if (cl && strtoull(cl, NULL, 10) > r->srv->cfg.json_max_bytes)
			return api_problem(r, PROB_TOO_LARGE, NULL,
					   "JSON bodies are limited to %zu bytes",
					   r->srv->cfg.json_max_bytes);
	} else if (r->route->body == BODY_UPLOAD) {
		return api_upload_begin(r);
	}
	return MHD_YES;
}

/* Slow bodies (a slowloris on the body): once the body has taken longer
 * than the grace, its average rate must reach the minimum, else the
 * connection is closed (libmicrohttpd cannot answer mid-body).  Checked
 * whenever data arrives; a body that stops altogether meets
 * --conn-timeout-s. */
static int body_too_slow(const struct api_req *r)
{
	const struct api_config *c = &r->srv->cfg;
	int64_t ms = db_now_ms() - r->started_ms;

	return c->min_body_bps > 0 && ms > (int64_t)c->body_grace_s * 1000 &&
	       r->body_bytes * 1000 < c->min_body_bps * ms;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url,
				  const char *method, const char *version,
				  const char *upload_data, size_t *upload_size, void **req_cls)
{
	struct api_server *s = cls;
	struct api_req *r = *req_cls;
	enum MHD_Result ret;

	(void)version;
	if (!r) {
		api_gate_request_begins(s, conn);
		r = calloc(1, sizeof *r);
		if (!r)
			return MHD_NO;
		r->srv = s;
		r->conn = conn;
		r->url = url;
		r->method = method;
		r->head = !strcmp(method, "HEAD");
		r->started_ms = db_now_ms();
		buf_init(&r->body);
		*req_cls = r;
		/* Answering on this first call makes libmicrohttpd close the
		 * connection afterwards (it stops reading the request), so only
		 * requests with a body are checked now, where refusing early
		 * (401, 413, 415) is worth a new connection; the rest are
		 * routed on the next call and keep their connection alive. */
		if (!has_body(conn))
			return MHD_YES;
		r->started = 1;
		return start_request(r);
	}
	if (!r->started) {
		r->started = 1;
		ret = start_request(r);
		if (r->status || ret != MHD_YES || !r->route)
			return ret;
	}
	if (r->status) {
		*upload_size = 0; /* already answered at the headers (early 413...) */
		return MHD_YES;
	}
	if (*upload_size) {
		size_t n = *upload_size;
		*upload_size = 0;
		r->body_bytes += (int64_t)n;
		if (body_too_slow(r)) {
			log_msg(LOG_INFO, "http", "%s %s: body slower than %lld bytes/s; closed",
				r->method, r->url, (long long)s->cfg.min_body_bps);
			return MHD_NO;
		}
		if (r->rejected) {
			r->discarded += n;
			return r->discarded > API_DISCARD_MAX ? MHD_NO : MHD_YES;
		}
		if (r->route->body == BODY_UPLOAD) {
			api_upload_feed(r, upload_data, n); /* rejects on failure */
			return MHD_YES;
		}
		if (r->body.len + n > s->cfg.json_max_bytes) {
			api_reject(r, PROB_TOO_LARGE, "JSON bodies are limited to %zu bytes",
				   s->cfg.json_max_bytes);
			return MHD_YES;
		}
		if (buf_append(&r->body, upload_data, n) != 0)
			return MHD_NO;
		return MHD_YES;
	}
	if (r->rejected)
		return api_problem(r, r->reject_p, r->reject_field, "%s", r->reject_detail);
	if (r->pending) {
		struct MHD_Response *resp = r->pending;
		r->pending = NULL;
		return api_queue(r, r->pending_status, resp);
	}
	if (r->suspended || !r->route)
		return MHD_YES;
	return r->route->fn(r);
}

static int status_index(unsigned status)
{
	static const unsigned codes[HTTP_CODES - 1] = {200, 201, 202, 204, 206, 304, 400,
							401, 403, 404, 405, 413};
	for (int i = 0; i < HTTP_CODES - 1; i++)
		if (codes[i] == status)
			return i;
	return HTTP_CODES - 1; /* other */
}

static void on_completed(void *cls, struct MHD_Connection *conn, void **req_cls,
			 enum MHD_RequestTerminationCode toe)
{
	struct api_server *s = cls;
	struct api_req *r = *req_cls;

	(void)toe;
	api_gate_request_ends(s, conn);
	if (!r)
		return;
	if (r->status)
		atomic_fetch_add(&s->requests[r->route_index][status_index(r->status)], 1);
	if (r->pending)
		MHD_destroy_response(r->pending);
	if (r->work_free)
		r->work_free(r->work);
	api_upload_free(r->upload);
	buf_fini(&r->body);
	free(r);
	*req_cls = NULL;
}

static void mhd_log(void *cls, const char *fmt, va_list ap)
{
	char msg[512];

	(void)cls;
	vsnprintf(msg, sizeof msg, fmt, ap);
	msg[strcspn(msg, "\n")] = '\0';
	log_msg(LOG_WARN, "http", "%s", msg);
}

/* Allow many sockets: 1,000 concurrent clients need more than the usual
 * soft limit of 1,024 descriptors. */
static void raise_fd_limit(void)
{
	struct rlimit rl;

	if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
		rl.rlim_cur = rl.rlim_max;
		setrlimit(RLIMIT_NOFILE, &rl);
	}
}

static enum MHD_Result accept_policy(void *cls, const struct sockaddr *addr, socklen_t len)
{
	struct api_server *s = cls;

	(void)addr;
	(void)len;
	return atomic_load(&s->quiesced) ? MHD_NO : MHD_YES;
}

int api_server_start(const struct api_config *c, struct api_server **out, struct err *e)
{
	struct api_server *s = calloc(1, sizeof *s);
	struct sockaddr_storage ss;
	int rc;

	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory starting the server");
	s->cfg = *c;
	pthread_mutex_init(&s->wait_mu, NULL);
	pthread_mutex_init(&s->an_mu, NULL);
	pthread_mutex_init(&s->seen_mu, NULL);
	pthread_cond_init(&s->an_cv, NULL);
	pthread_mutex_init(&s->cm_mu, NULL);
	pthread_cond_init(&s->cm_cv, NULL);
	memset(&ss, 0, sizeof ss);
	if (strchr(c->host, ':')) {
		struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)&ss;
		a6->sin6_family = AF_INET6;
		a6->sin6_port = htons((uint16_t)c->port);
		if (inet_pton(AF_INET6, c->host, &a6->sin6_addr) != 1) {
			rc = ERR_FIELD(e, "listen", "not an IPv6 address: %s", c->host);
			goto fail;
		}
	} else {
		struct sockaddr_in *a4 = (struct sockaddr_in *)&ss;
		a4->sin_family = AF_INET;
		a4->sin_port = htons((uint16_t)c->port);
		if (inet_pton(AF_INET, c->host, &a4->sin_addr) != 1) {
			rc = ERR_FIELD(e, "listen", "not an IPv4 address: %s", c->host);
			goto fail;
		}
	}
	/* One connection per MHD thread, the analysis pool and the committer. */
	if ((rc = db_pool_new(c->db_url, c->threads + 3, &s->pool, e)))
		goto fail;
	if ((rc = api_analyze_start(s, e)) || (rc = api_committer_start(s, e)))
		goto fail;
	if ((rc = api_notify_start(s, e)))
		goto fail;
	raise_fd_limit();
	if ((rc = api_gate_start(s, &ss, e))) {
		char why[sizeof e->msg];
		snprintf(why, sizeof why, "%s", e->msg);
		rc = ERR_SET(e, ERR_IO, "cannot listen on %s:%d: %s", c->host, c->port, why);
		goto fail_notify;
	}
	/* No listen socket: the gate (gate.c) accepts, waits for whole
	 * heads and hands connections over; it keeps the connection and
	 * per-address limits itself (MHD's limit only backs it up). */
	s->mhd = MHD_start_daemon(
		MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME |
			MHD_USE_ERROR_LOG | MHD_USE_NO_LISTEN_SOCKET | MHD_USE_ITC |
			(ss.ss_family == AF_INET6 ? MHD_USE_IPv6 : 0),
		0, accept_policy, s, on_request, s,
		MHD_OPTION_EXTERNAL_LOGGER, mhd_log, s,
		MHD_OPTION_THREAD_POOL_SIZE, (unsigned int)c->threads,
		MHD_OPTION_CONNECTION_TIMEOUT, (unsigned int)c->conn_timeout_s,
		MHD_OPTION_CONNECTION_LIMIT, (unsigned int)c->max_connections + 64u,
		MHD_OPTION_CONNECTION_MEMORY_LIMIT, c->conn_memory_bytes,
		MHD_OPTION_NOTIFY_COMPLETED, on_completed, s,
		MHD_OPTION_NOTIFY_CONNECTION, api_gate_notify, s,
		MHD_OPTION_END);
	if (!s->mhd) {
		rc = ERR_SET(e, ERR_IO, "cannot start libmicrohttpd: %s", strerror(errno));
		goto fail_notify;
	}
	if ((rc = api_gate_run(s, e))) {
		MHD_stop_daemon(s->mhd);
		goto fail_notify;
	}
	*out = s;
	return 0;
fail_notify:
	api_notify_stop(s);
	api_gate_free(s);
fail:
	api_committer_stop(s);
	api_analyze_stop(s);
	db_pool_free(s->pool);
	free(s);
	return rc;
}

int api_server_port(const struct api_server *s)
{
	return s->port;
}

void api_server_set_workers_alive(struct api_server *s, int n)
{
	atomic_store(&s->workers_alive, n);
}

/* Draining refuses new connections here, not with MHD_quiesce_daemon():
 * with epoll and a thread pool, libmicrohttpd 0.9.75 races the worker that
 * drops the listen socket from its epoll set itself and aborts ("Failed
 * to remove listen FD from epoll set", seen once in CI). */
void api_server_quiesce(struct api_server *s)
{
	if (s)
		atomic_store(&s->quiesced, 1);
}

void api_server_stop(struct api_server *s)
{
	if (!s)
		return;
	api_notify_stop(s);
	api_analyze_stop(s);
	api_committer_stop(s);
	api_gate_stop(s);
	MHD_stop_daemon(s->mhd);
	api_gate_free(s);
	db_pool_free(s->pool);
	pthread_mutex_destroy(&s->wait_mu);
	pthread_mutex_destroy(&s->an_mu);
	pthread_mutex_destroy(&s->seen_mu);
	pthread_cond_destroy(&s->an_cv);
	pthread_mutex_destroy(&s->cm_mu);
	pthread_cond_destroy(&s->cm_cv);
	free(s);
}
