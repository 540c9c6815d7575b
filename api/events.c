/* events.c - GET /v1/jobs/{id}/events: Server-Sent Events.
 *
 * Each job_events row is one SSE event ("id: n", "event: state|progress",
 * "data: <job snapshot>"); Last-Event-ID (or ?after=) resumes after n.
 * The stream ends after the event that makes the job final.  When nothing
 * is new the content reader parks the connection and the notifier
 * (notify.c) resumes it when the job changes, on whichever machine, so no
 * thread waits; a comment line every 15 s keeps proxies from closing an
 * idle stream.
 */
#include "api/api_internal.h"
#include "db/queue.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct sse {
	struct api_server *srv;
	struct MHD_Connection *conn;
	int64_t job_seq;
	int64_t last_n;
	int final;         /* job finished: end after flushing */
	uint64_t seen_gen; /* notification generation before the last read */
	struct buf out;    /* formatted, not yet sent */
	size_t off;
	time_t last_write;
};

static void sse_free(void *cls)
{
	struct sse *s = cls;

	atomic_fetch_sub(&s->srv->open_streams, 1);
	buf_fini(&s->out);
	free(s);
}

/* Append new events to s->out; sets s->final when the job is over and
 * all its events are out. */
static int sse_fill(struct sse *s)
{
	struct db *db = db_pool_get(s->srv->pool);
	struct job_event *ev;
	struct job_row j;
	struct err e;
	int n, rc;

	s->seen_gen = api_notify_gen(s->srv);
	rc = queue_events(db, s->job_seq, s->last_n, 64, &ev, &n, &e);
	if (rc) {
		db_pool_put(s->srv->pool, db);
		return -1;
	}
	for (int i = 0; i < n; i++) {
		char head[96];
		int hl = snprintf(head, sizeof head, "id: %lld\nevent: %s\ndata: ", (long long)ev[i].n,
				  ev[i].type);
		if (buf_append(&s->out, head, (size_t)hl) || buf_append(&s->out, ev[i].data, strlen(ev[i].data)) ||
		    buf_append(&s->out, "\n\n", 2)) {
			rc = -1;
			break;
		}
		s->last_n = ev[i].n;
	}
	queue_events_free(ev, n);
	if (!rc && n == 0) {
		/* Nothing new: is the job over? (Its final event was sent.) */
		if (queue_get_seq(db, s->job_seq, &j, &e) != 0) {
			s->final = 1; /* removed with its tenant */
		} else {
			s->final = j.state >= JOB_SUCCEEDED && s->last_n >= j.event_seq;
			queue_job_row_fini(&j);
		}
	}
	db_pool_put(s->srv->pool, db);
	return rc;
}

static ssize_t sse_read(void *cls, uint64_t pos, char *buf, size_t max)
{
	struct sse *s = cls;
	size_t n;

	(void)pos;
	if (s->off == s->out.len) {
		buf_reset(&s->out);
		s->off = 0;
		if (s->final || atomic_load(&s->srv->stopping))
			return MHD_CONTENT_READER_END_OF_STREAM;
		if (sse_fill(s))
			return MHD_CONTENT_READER_END_WITH_ERROR;
		if (s->out.len == 0) {
			if (s->final)
				return MHD_CONTENT_READER_END_OF_STREAM;
			if (time(NULL) - s->last_write >= API_KEEPALIVE_S) {
				buf_append(&s->out, ": keepalive\n\n", 13);
			} else {
				api_park_stream(s->srv, s->conn, s->job_seq, s->seen_gen);
				return 0;
			}
		}
	}
	n = s->out.len - s->off;
	if (n > max)
		n = max;
	memcpy(buf, s->out.data + s->off, n);
	s->off += n;
	s->last_write = time(NULL);
	return (ssize_t)n;
}

enum MHD_Result api_job_events(struct api_req *r)
{
	const char *last = api_header(r, "Last-Event-ID");
	const char *after = api_query(r, "after");
	struct MHD_Response *resp;
	struct job_row j;
	enum MHD_Result ret;
	struct sse *s;

	if (api_load_job(r, &j, &ret))
		return ret;
	if (!(s = calloc(1, sizeof *s))) {
		queue_job_row_fini(&j);
		return MHD_NO;
	}
	s->srv = r->srv;
	s->conn = r->conn;
	s->job_seq = j.seq;
	queue_job_row_fini(&j);
	s->last_n = last ? atoll(last) : after ? atoll(after) : 0;
	if (s->last_n < 0)
		s->last_n = 0;
	s->last_write = time(NULL);
	buf_init(&s->out);
	buf_append(&s->out, "retry: 1000\n\n", 13);
	atomic_fetch_add(&r->srv->open_streams, 1);
	resp = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 16384, sse_read, s, sse_free);
	if (!resp) {
		sse_free(s);
		return MHD_NO;
	}
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/event-stream");
	MHD_add_response_header(resp, "X-Accel-Buffering", "no");
	return api_queue(r, MHD_HTTP_OK, resp);
}
