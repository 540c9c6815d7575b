/* health.c - /livez, /readyz and /metrics (Prometheus text format 0.0.4).
 * Labels are bounded: routes, status codes and job states, never tenants
 * or ids, so the series count stays constant.
 */
#include "api/api_internal.h"
#include "api/gate.h"
#include "db/queue.h"
#include "db/store.h"
#include "engine/core/err.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum MHD_Result api_livez(struct api_req *r)
{
	return api_json(r, MHD_HTTP_OK, json_pack("{s:s}", "status", "ok"));
}

enum MHD_Result api_readyz(struct api_req *r)
{
	struct db *db = db_pool_get(r->srv->pool);
	int64_t free_b = store_free_bytes(r->srv->cfg.store_dir);
	const char *backend = db_backend(db); /* static string */
	struct err e;
	int rc;

	err_clear(&e);
	rc = db_check_writable(db, &e);
	db_pool_put(r->srv->pool, db);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "database not writable: %s", e.msg);
	/* The store (uploads, artifacts) may be another machine's file
	 * system: a write that reaches the disk proves it is there. */
	if (store_check(r->srv->cfg.store_dir, &e))
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	if (free_b >= 0 && free_b < r->srv->cfg.min_free_bytes)
		return api_problem(r, PROB_UNAVAILABLE, NULL,
				   "only %lld bytes free in the store (need %lld)",
				   (long long)free_b, (long long)r->srv->cfg.min_free_bytes);
	return api_json(r, MHD_HTTP_OK,
			json_pack("{s:s, s:s, s:I, s:i}", "status", "ready", "database", backend,
				  "disk_free_bytes", (json_int_t)free_b, "workers_alive",
				  atomic_load(&r->srv->workers_alive)));
}

struct text {
	char *p;
	size_t len, cap;
	int oom;
};

static void put(struct text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(struct text *t, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (t->oom)
		return;
	for (;;) {
		va_start(ap, fmt);
		n = vsnprintf(t->p + t->len, t->cap - t->len, fmt, ap);
		va_end(ap);
		if (n >= 0 && (size_t)n < t->cap - t->len) {
			t->len += (size_t)n;
			return;
		}
		{
			size_t cap = t->cap * 2 + (size_t)n + 256;
			char *np = realloc(t->p, cap);
			if (!np) {
				t->oom = 1;
				return;
			}
			t->p = np;
			t->cap = cap;
		}
	}
}

static const unsigned status_codes[HTTP_CODES - 1] = {200, 201, 202, 204, 206, 304,
						       400, 401, 403, 404, 405, 413};

enum MHD_Result api_metrics(struct api_req *r)
{
	struct api_server *s = r->srv;
	struct db *db = db_pool_get(s->pool);
	int64_t counts[JOB_STATE_COUNT];
	struct queue_durations d;
	struct text t = {malloc(8192), 0, 8192, 0};
	struct MHD_Response *resp;
	struct err e;
	int rc;

	rc = queue_counts(db, counts, &e);
	if (!rc)
		rc = queue_durations(db, &d, &e);
	db_pool_put(s->pool, db);
	if (rc || !t.p) {
		free(t.p);
		return api_problem(r, PROB_UNAVAILABLE, NULL, "cannot read the queue: %s", e.msg);
	}
	put(&t, "# HELP infilld_jobs Jobs by state.\n# TYPE infilld_jobs gauge\n");
	for (int i = 0; i < JOB_STATE_COUNT; i++)
		put(&t, "infilld_jobs{state=\"%s\"} %lld\n", queue_state_name(i), (long long)counts[i]);
	put(&t, "# HELP infilld_queue_depth Jobs waiting to run.\n# TYPE infilld_queue_depth gauge\n"
		"infilld_queue_depth %lld\n", (long long)counts[JOB_QUEUED]);
	put(&t, "# HELP infilld_job_duration_seconds Run time of finished jobs.\n"
		"# TYPE infilld_job_duration_seconds histogram\n");
	for (int k = 0; k < 3; k++) {
		const char *st = queue_state_name(JOB_SUCCEEDED + k);
		for (int i = 0; i < QUEUE_DURATION_BUCKETS; i++)
			put(&t, "infilld_job_duration_seconds_bucket{state=\"%s\",le=\"%g\"} %lld\n", st,
			    queue_duration_le[i], (long long)d.bucket[k][i]);
		put(&t, "infilld_job_duration_seconds_bucket{state=\"%s\",le=\"+Inf\"} %lld\n", st,
		    (long long)d.count[k]);
		put(&t, "infilld_job_duration_seconds_sum{state=\"%s\"} %.3f\n", st, d.sum_s[k]);
		put(&t, "infilld_job_duration_seconds_count{state=\"%s\"} %lld\n", st,
		    (long long)d.count[k]);
	}
	put(&t, "# HELP infilld_http_requests_total HTTP requests answered.\n"
		"# TYPE infilld_http_requests_total counter\n");
	for (int i = 0; i <= ROUTE_COUNT_MAX; i++) {
		const char *label = api_route_label(i);
		if (!label)
			continue;
		for (int c = 0; c < HTTP_CODES; c++) {
			long long v = atomic_load(&s->requests[i][c]);
			char code[8];
			if (!v)
				continue;
			if (c < HTTP_CODES - 1)
				snprintf(code, sizeof code, "%u", status_codes[c]);
			else
				snprintf(code, sizeof code, "other");
			put(&t, "infilld_http_requests_total{route=\"%s\",code=\"%s\"} %lld\n", label,
			    code, v);
		}
	}
	put(&t, "# HELP infilld_http_output_bytes_total Artifact bytes sent.\n"
		"# TYPE infilld_http_output_bytes_total counter\ninfilld_http_output_bytes_total %lld\n",
	    (long long)atomic_load(&s->bytes_out));
	put(&t, "# HELP infilld_sse_streams Open event streams.\n# TYPE infilld_sse_streams gauge\n"
		"infilld_sse_streams %d\n", atomic_load(&s->open_streams));
	put(&t, "# HELP infilld_http_gate_answers_total Connections the head gate answered and "
		"closed itself.\n# TYPE infilld_http_gate_answers_total counter\n"
		"infilld_http_gate_answers_total{code=\"408\"} %lld\n"
		"infilld_http_gate_answers_total{code=\"503\"} %lld\n"
		"infilld_http_gate_answers_total{code=\"other\"} %lld\n"
		"# HELP infilld_http_keepalive_closed_total Kept-alive connections closed for not "
		"sending their next request head within the head deadline.\n"
		"# TYPE infilld_http_keepalive_closed_total counter\n"
		"infilld_http_keepalive_closed_total %lld\n"
		"# HELP infilld_http_connections Connections libmicrohttpd holds.\n"
		"# TYPE infilld_http_connections gauge\ninfilld_http_connections %d\n",
	    (long long)atomic_load(&s->gate_answers[0]), (long long)atomic_load(&s->gate_answers[1]),
	    (long long)atomic_load(&s->gate_answers[2]),
	    (long long)atomic_load(&s->gate_keepalive_closed), s->gate ? api_gate_live(s->gate) : 0);
	put(&t, "# HELP infilld_workers Worker processes.\n# TYPE infilld_workers gauge\n"
		"infilld_workers{kind=\"configured\"} %d\ninfilld_workers{kind=\"alive\"} %d\n",
	    s->cfg.workers, atomic_load(&s->workers_alive));
	if (t.oom) {
		free(t.p);
		return MHD_NO;
	}
	resp = MHD_create_response_from_buffer_with_free_callback(t.len, t.p, free);
	if (!resp) {
		free(t.p);
		return MHD_NO;
	}
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE,
				"text/plain; version=0.0.4; charset=utf-8");
	return api_queue(r, MHD_HTTP_OK, resp);
}
