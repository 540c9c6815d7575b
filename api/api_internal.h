/* api_internal.h - what the files of api/ share: the server, the
 * per-request state, routing, responses and problem types.  Nothing
 * outside api/ includes it.
 */
#ifndef INFILLD_API_INTERNAL_H
#define INFILLD_API_INTERNAL_H

#include <jansson.h>
#include <microhttpd.h>
#include <pthread.h>
#include <stdatomic.h>

#include "api/api.h"
#include "db/db.h"
#include "db/tenants.h"
#include "engine/core/sink.h"

struct api_req;
struct upload;

/* Stable problem types (problem.c): "type" is "/problems/<slug>". */
enum problem {
	PROB_BAD_REQUEST, PROB_MALFORMED_JSON, PROB_UNAUTHORIZED, PROB_FORBIDDEN,
	PROB_NOT_FOUND, PROB_METHOD_NOT_ALLOWED, PROB_CONFLICT, PROB_NOT_READY, PROB_GONE,
	PROB_TOO_LARGE, PROB_UNSUPPORTED_MEDIA, PROB_RANGE, PROB_INVALID_PARAM,
	PROB_CHECKSUM, PROB_INVALID_MESH, PROB_IDEMPOTENCY, PROB_QUOTA, PROB_INTERNAL,
	PROB_UNAVAILABLE, PROB_TIMEOUT, PROB_HEAD_TOO_LARGE, PROB_NOT_IMPLEMENTED, PROB_COUNT
};

enum route_auth { AUTH_NONE, AUTH_TENANT, AUTH_ADMIN };
enum route_body { BODY_NONE, BODY_JSON, BODY_UPLOAD };

typedef enum MHD_Result (*api_handler)(struct api_req *r);

struct route {
	const char *method;   /* "GET", ... ("GET" also answers HEAD) */
	const char *pattern;  /* "/v1/jobs/{}" - {} is one path segment */
	enum route_auth auth;
	enum route_body body;
	api_handler fn;
	const char *metric;   /* label for /metrics */
};

#define ROUTE_COUNT_MAX 32
#define HTTP_CODES 13 /* counted status codes, see health.c */

/* A connection parked with MHD_suspend_connection() until woken. */
struct api_waiter {
	struct MHD_Connection *conn;
	struct api_waiter *next;
	int64_t job_seq;          /* the stream's job */
	double parked_s;          /* CLOCK_MONOTONIC seconds */
};

#define API_NOTIFY_RING 256
#define API_KEEPALIVE_S 15     /* an idle SSE stream sends a comment this often */

struct analyze_task;
struct submit_task;
struct api_gate;
struct job_new;
struct job_row;

/* An artifact file whose whole SHA-256 this process has checked against
 * the database (output.c), by identity: a write, truncation or rename
 * onto it changes ctime, so a changed file is checked again. */
#define API_SEEN_SLOTS 1024
struct api_seen {
	uint64_t dev, ino;
	int64_t size, mtime_ns, ctime_ns;
	int used;
};

struct api_server {
	struct api_config cfg;
	struct MHD_Daemon *mhd;
	struct db_pool *pool;
	int port;
	atomic_int workers_alive;
	atomic_llong requests[ROUTE_COUNT_MAX + 1][HTTP_CODES];
	atomic_llong bytes_out;
	atomic_int open_streams;
	struct api_gate *gate;           /* accept loop and head gate (gate.c) */
	atomic_llong gate_answers[3];    /* the gate's own 408, 503, other (400/431/501) */
	atomic_llong gate_keepalive_closed; /* kept-alive connections past the head deadline */

	/* Parked SSE streams and the notifier that resumes them (notify.c). */
	pthread_mutex_t wait_mu;
	struct api_waiter *waiting;
	uint64_t notify_gen, notify_all_gen;      /* under wait_mu */
	int64_t notify_ring[API_NOTIFY_RING];     /* job seq of notification gen % ring */
	struct db *notify_db;                     /* the notifier's own connection */
	pthread_t notifier;
	atomic_int stopping;
	atomic_int quiesced; /* draining: new connections are closed at accept */

	/* Artifacts checked whole (output.c), direct-mapped by inode. */
	pthread_mutex_t seen_mu;
	struct api_seen seen[API_SEEN_SLOTS];

	/* Mesh analysis and other file work: a small pool (analyze.c). */
	pthread_mutex_t an_mu;
	pthread_cond_t an_cv;
	struct analyze_task *an_head, *an_tail;
	pthread_t an_threads[2];
	int an_started;

	/* Group commit of submissions (committer.c). */
	pthread_mutex_t cm_mu;
	pthread_cond_t cm_cv;
	struct submit_task *cm_head, *cm_tail;
	pthread_t cm_thread;
	int cm_started, cm_stop;
};

struct api_req {
	struct api_server *srv;
	struct MHD_Connection *conn;
	const struct route *route;
	int route_index;
	const char *method;
	const char *url;
	char arg[2][128];           /* path parameters ({} segments) */
	int head;                   /* HEAD request */
	int started;                /* routed and authenticated */
	struct tenant tenant;       /* AUTH_TENANT routes */
	unsigned status;            /* what was queued (metrics) */
	struct buf body;            /* BODY_JSON */
	struct upload *upload;      /* BODY_UPLOAD */
	struct MHD_Response *pending;   /* prepared while suspended */
	unsigned pending_status;
	int suspended;
	/* A body refused while it streams: libmicrohttpd 0.9.75 cannot queue a
	 * response mid-body, so the rest is discarded (up to API_DISCARD_MAX,
	 * then the connection is closed) and the problem sent at its end. */
	int rejected;
	enum problem reject_p;
	char reject_field[16];
	char reject_detail[256];
	size_t discarded;
	int64_t started_ms;         /* head complete (first call), for the body rate */
	int64_t body_bytes;         /* received so far */
	void *work;                 /* a handler's state across a park; */
	void (*work_free)(void *);  /* freed with the request when set */
};

#define API_DISCARD_MAX (16u << 20)

/* Refuse the request body with problem p once it has ended (see above);
 * field (may be NULL) is the problem's "field". */
void api_reject(struct api_req *r, enum problem p, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 3, 4)))
#endif
	;
void api_reject_field(struct api_req *r, const char *field);

/* Metrics label of route i (server.c): its pattern, "unmatched" for
 * i == number of routes, NULL past that. */
const char *api_route_label(int i);

/* ---- responses (http.c) ---- */
enum MHD_Result api_queue(struct api_req *r, unsigned status, struct MHD_Response *resp);
/* JSON body (reference stolen; NULL -> 500). */
enum MHD_Result api_json(struct api_req *r, unsigned status, json_t *body);
/* Same, as a response object with no status queued yet. */
struct MHD_Response *api_json_response(json_t *body);
/* The same with another JSON media type (exactly one Content-Type). */
struct MHD_Response *api_json_response_as(json_t *body, const char *content_type);
/* RFC 9457 problem+json.  field may be NULL; detail is printf-style. */
enum MHD_Result api_problem(struct api_req *r, enum problem p, const char *field,
			    const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 4, 5)))
#endif
	;
struct MHD_Response *api_problem_response(enum problem p, const char *instance,
					  const char *field, const char *detail,
					  unsigned *status);
/* The same with more members (reference stolen; NULL = none). */
struct MHD_Response *api_problem_response_members(enum problem p, const char *instance,
						  const char *field, const char *detail,
						  json_t *members, unsigned *status);
/* The members a problem of kind p carries for request r (new reference,
 * NULL = none): quota refusals say where the tenant stands, as of
 * r->tenant. */
json_t *api_problem_members(const struct api_req *r, enum problem p);
/* Problem for an engine/db error record: maps err codes to types. */
enum MHD_Result api_problem_err(struct api_req *r, const struct err *e);
unsigned problem_status(enum problem p);
const char *problem_slug(enum problem p);
const char *problem_title(enum problem p);
int problem_find(const char *slug);

/* RFC 3339 UTC with milliseconds; buf >= 32 bytes. */
const char *api_time(int64_t ms, char *buf, size_t len);
/* Header / query values (NULL when absent). */
const char *api_header(struct api_req *r, const char *name);
const char *api_query(struct api_req *r, const char *name);

/* 1 when s is UTF-8 (shortest forms, no surrogates) without control
 * characters: fit for names stored and shown in JSON. */
int api_text_valid(const char *s);

/* Park the request's connection until api_wake(). */
void api_park(struct api_req *r);
/* Resume a parked connection from any thread. */
void api_wake(struct api_server *s, struct MHD_Connection *conn);
/* SSE streams (notify.c): park a streaming response's connection from
 * its content reader until job job_seq changes after generation seen_gen
 * (read with api_notify_gen() before reading the job's events), or a
 * keep-alive is due. */
uint64_t api_notify_gen(struct api_server *s);
void api_park_stream(struct api_server *s, struct MHD_Connection *conn, int64_t job_seq,
		     uint64_t seen_gen);
int api_notify_start(struct api_server *s, struct err *e);
void api_notify_stop(struct api_server *s);

/* ---- handlers ---- */
enum MHD_Result api_livez(struct api_req *r);
enum MHD_Result api_readyz(struct api_req *r);
enum MHD_Result api_metrics(struct api_req *r);
enum MHD_Result api_problem_doc(struct api_req *r);
enum MHD_Result api_engines(struct api_req *r);
enum MHD_Result api_mesh_upload(struct api_req *r);
enum MHD_Result api_mesh_list(struct api_req *r);
enum MHD_Result api_mesh_get(struct api_req *r);
enum MHD_Result api_mesh_delete(struct api_req *r);
enum MHD_Result api_job_submit(struct api_req *r);
enum MHD_Result api_job_list(struct api_req *r);
enum MHD_Result api_job_get(struct api_req *r);
enum MHD_Result api_job_cancel(struct api_req *r);
enum MHD_Result api_job_events(struct api_req *r);
enum MHD_Result api_job_output(struct api_req *r);
enum MHD_Result api_tenant_create(struct api_req *r);
enum MHD_Result api_tenant_list(struct api_req *r);
enum MHD_Result api_tenant_get(struct api_req *r);
enum MHD_Result api_tenant_delete(struct api_req *r);
enum MHD_Result api_tenant_rotate(struct api_req *r);
enum MHD_Result api_job_layer(struct api_req *r);
enum MHD_Result api_web_index(struct api_req *r);
enum MHD_Result api_web_asset(struct api_req *r);

/* ---- the portal (web.c; the files of web/, embedded at build time) ---- */
struct api_web_file {
	const char *name;         /* "index.html", "app.js", "three.module.min.js" ... */
	const unsigned char *data;
	size_t len;
};
/* Generated by web/embed.sh into BUILD/gen/web_files.c. */
extern const struct api_web_file api_web_files[];
extern const size_t api_web_file_count;

/* ---- CORS (http.c; --cors-origin) ---- */
/* Answer an OPTIONS preflight for a routed path: 204 with the methods in
 * allow when the request's Origin is the configured one, else 204 without
 * CORS headers (the browser then refuses the call). */
enum MHD_Result api_cors_preflight(struct api_req *r, const char *allow);

/* Uploads (meshes.c): called by the server as the body streams in. */
enum MHD_Result api_upload_begin(struct api_req *r);
int api_upload_feed(struct api_req *r, const char *data, size_t len);
/* Close and remove the upload's temp file (idempotent; none once published).
 * api_queue calls it before queuing any refusal of an upload, so a client
 * that read the refusal finds nothing left (api_upload_free runs after). */
void api_upload_discard(struct upload *u);
void api_upload_free(struct upload *u);

/* Group commit (committer.c): queue jn (copied) and park r; the
 * committer answers it once the batch is on disk. */
int api_submit_enqueue(struct api_req *r, const struct job_new *jn);
int api_committer_start(struct api_server *s, struct err *e);
void api_committer_stop(struct api_server *s);
/* 202 response for a queued (or replayed) job (jobs.c). */
struct MHD_Response *api_submit_response(const struct job_row *j, int replayed);

/* Mesh analysis pool (analyze.c).  api_offload() parks r and runs fn(r)
 * on a pool thread; fn must set r->pending (and pending_status), then the
 * connection is resumed and the response queued. 0, or -1 (no memory). */
int api_offload(struct api_req *r, void (*fn)(struct api_req *));
int api_analyze_start(struct api_server *s, struct err *e);
void api_analyze_stop(struct api_server *s);

struct job_row;
/* Job JSON (jobs.c), shared with events. */
json_t *api_job_json(const struct job_row *j);
/* Load the tenant's job named by r->arg[0] (jobs.c); on failure a
 * problem is queued, *ret set, and -1 returned. */
int api_load_job(struct api_req *r, struct job_row *j, enum MHD_Result *ret);
/* The same for a job that must have succeeded: otherwise (-1, *ret set)
 * a 409 not-ready problem saying waiting_msg (queued or running, with
 * Retry-After) or failed_msg (failed, cancelled). */
int api_load_done_job(struct api_req *r, struct job_row *j, enum MHD_Result *ret,
		      const char *waiting_msg, const char *failed_msg);
/* JSON of a mesh record (meshes.c). */
struct mesh_rec;
json_t *api_mesh_json(const struct mesh_rec *m);

#endif
