/* gate.c - the accept loop and the "head gate" in front of libmicrohttpd.
 *
 * MHD runs without a listen socket (MHD_USE_NO_LISTEN_SOCKET).  One gate
 * thread accepts, keeps each new connection in its own epoll set and
 * peeks (MSG_PEEK) until the request head is complete, then hands the
 * socket to MHD (MHD_add_connection).  A head not complete within
 * --head-timeout-s gets 408, a head past GATE_HEAD_MAX 431, broken
 * message framing (RFC 9112 section 6.3) 400 or 501, a full server 503
 * with Retry-After; each then closes.  So MHD's slots are only taken by
 * clients that sent a whole head: slow headers (slowloris) wait here,
 * where a connection costs a descriptor and ~100 bytes.  Once MHD holds
 * a connection, its next request on the same connection (keep-alive) has
 * the same deadline: from the end of one request to the whole head of
 * the next, else the gate shuts the socket down (held_expire()).  Design:
 * docs/service.md "HTTP hardening".
 */
#define _GNU_SOURCE /* accept4, strcasestr */
#include "api/api_internal.h"
#include "api/gate.h"
#include "api/log.h"
#include "db/db.h"
#include "engine/core/err.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#define GATE_HEAD_MAX (32u * 1024u) /* bytes of request line + fields */
#define GATE_LINGER_MS 2000         /* read and discard after an answer */
#define GATE_RESERVE 16             /* extra MHD slots for probes (/livez, /readyz) */
#define GATE_RETRY_AFTER_S 2
#define GATE_BUCKETS 1024

enum gate_state { GATE_HEAD, GATE_LINGER };

/* A connection the gate holds: waiting for its head, or lingering after
 * an answer so the client reads it before the close (no RST). */
struct gate_conn {
	int fd;
	enum gate_state state;
	int64_t deadline_ms;
	size_t scanned; /* bytes of the head already searched for its end */
	struct sockaddr_storage addr;
	socklen_t addrlen;
	struct gate_conn *prev, *next; /* in its state's list, oldest first */
};

struct gate_list {
	struct gate_conn *head, *tail;
	int n;
};

/* A connection MHD holds (its socket_context).  Between two requests it
 * waits in the gate's kept list, oldest first: a kept-alive client must
 * send its next whole head within head_timeout_ms of the last response,
 * as a new one must of its accept, however steadily the head trickles
 * (MHD's --conn-timeout-s only measures silence).  fd stays open until
 * MHD's close notification, which unlinks the entry under the gate's
 * mutex first, so held_expire() never shuts down a reused descriptor. */
struct gate_held {
	int fd;
	int kept;              /* 1 while in the kept list */
	int64_t idle_since_ms; /* db_now_ms() when its last request ended */
	struct gate_held *prev, *next;
};

struct gate_held_list {
	struct gate_held *head, *tail;
};

/* Live MHD connections of one client address. */
struct gate_ip {
	unsigned char key[17]; /* family byte + address */
	int n;
	struct gate_ip *next;
};

struct api_gate {
	struct api_server *srv;
	int listen_fd, ep, wake_fd;
	int capacity;       /* connections the gate holds at once */
	int head_timeout_ms;
	pthread_t thread;
	int started;
	struct gate_list pending, linger;
	/* MHD's connections, counted at hand-over, released on close. */
	pthread_mutex_t mu;
	int live;
	struct gate_held_list kept; /* idle between requests, oldest first */
	struct gate_ip *ips[GATE_BUCKETS];
	char peek[GATE_HEAD_MAX + 1];
};

static int listen_tag, wake_tag; /* epoll data.ptr of the two fixed fds */

static void list_push(struct gate_list *l, struct gate_conn *c)
{
	c->next = NULL;
	c->prev = l->tail;
	if (l->tail)
		l->tail->next = c;
	else
		l->head = c;
	l->tail = c;
	l->n++;
}

static void list_unlink(struct gate_list *l, struct gate_conn *c)
{
	if (c->prev)
		c->prev->next = c->next;
	else
		l->head = c->next;
	if (c->next)
		c->next->prev = c->prev;
	else
		l->tail = c->prev;
	l->n--;
}

static struct gate_list *list_of(struct api_gate *g, struct gate_conn *c)
{
	return c->state == GATE_HEAD ? &g->pending : &g->linger;
}

static void conn_close(struct api_gate *g, struct gate_conn *c)
{
	list_unlink(list_of(g, c), c);
	close(c->fd); /* also leaves the epoll set */
	free(c);
}

/* ---- per-address accounting of MHD's connections ---- */

static int ip_key(const struct sockaddr *sa, unsigned char key[17])
{
	memset(key, 0, 17);
	if (sa->sa_family == AF_INET) {
		key[0] = 4;
		memcpy(key + 1, &((const struct sockaddr_in *)sa)->sin_addr, 4);
		return 0;
	}
	if (sa->sa_family == AF_INET6) {
		key[0] = 6;
		memcpy(key + 1, &((const struct sockaddr_in6 *)sa)->sin6_addr, 16);
		return 0;
	}
	return -1;
}

static struct gate_ip **ip_slot(struct api_gate *g, const unsigned char key[17])
{
	unsigned h = 2166136261u; /* FNV-1a */
	struct gate_ip **p;

	for (int i = 0; i < 17; i++)
		h = (h ^ key[i]) * 16777619u;
	for (p = &g->ips[h % GATE_BUCKETS]; *p; p = &(*p)->next)
		if (!memcmp((*p)->key, key, 17))
			break;
	return p;
}

/* Take a slot for a client at sa: 0, or the problem to answer (under
 * the per-address or total limit; probes may use GATE_RESERVE more). */
static int slot_take(struct api_gate *g, const struct sockaddr *sa, int probe, char *why,
		     size_t why_len)
{
	const struct api_config *c = &g->srv->cfg;
	unsigned char key[17];
	struct gate_ip **p, *ip;
	int rc = 0;

	pthread_mutex_lock(&g->mu);
	if (g->live >= c->max_connections + (probe ? GATE_RESERVE : 0)) {
		snprintf(why, why_len, "the server is at its limit of %d connections; retry later",
			 c->max_connections);
		rc = -1;
		goto out;
	}
	if (ip_key(sa, key) == 0) {
		p = ip_slot(g, key);
		if (*p && (*p)->n >= c->per_ip_connections && !probe) {
			snprintf(why, why_len,
				 "this address has %d open connections, the limit; retry later",
				 (*p)->n);
			rc = -1;
			goto out;
		}
		if (!*p) {
			if (!(ip = calloc(1, sizeof *ip))) {
				snprintf(why, why_len, "out of memory");
				rc = -1;
				goto out;
			}
			memcpy(ip->key, key, 17);
			*p = ip;
		}
		(*p)->n++;
	}
	g->live++;
out:
	pthread_mutex_unlock(&g->mu);
	return rc;
}

static void slot_release(struct api_gate *g, const struct sockaddr *sa)
{
	unsigned char key[17];
	struct gate_ip **p;

	pthread_mutex_lock(&g->mu);
	if (g->live > 0)
		g->live--;
	if (sa && ip_key(sa, key) == 0 && *(p = ip_slot(g, key))) {
		if (--(*p)->n <= 0) {
			struct gate_ip *dead = *p;
			*p = dead->next;
			free(dead);
		}
	}
	pthread_mutex_unlock(&g->mu);
}

int api_gate_live(struct api_gate *g)
{
	int n;

	pthread_mutex_lock(&g->mu);
	n = g->live;
	pthread_mutex_unlock(&g->mu);
	return n;
}

/* ---- connections MHD holds: the keep-alive head deadline ---- */

/* Stands in for a connection whose gate_held could not be allocated: its
 * slot is still released, it just has no keep-alive deadline. */
static struct gate_held untracked;

static void kept_unlink(struct api_gate *g, struct gate_held *h)
{
	if (!h->kept)
		return;
	if (h->prev)
		h->prev->next = h->next;
	else
		g->kept.head = h->next;
	if (h->next)
		h->next->prev = h->prev;
	else
		g->kept.tail = h->prev;
	h->prev = h->next = NULL;
	h->kept = 0;
}

static struct gate_held *held_of(struct MHD_Connection *conn)
{
	const union MHD_ConnectionInfo *ci =
		MHD_get_connection_info(conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);

	return ci ? ci->socket_context : NULL;
}

void api_gate_request_begins(struct api_server *s, struct MHD_Connection *conn)
{
	struct gate_held *h = s->gate ? held_of(conn) : NULL;

	if (!h || h == &untracked)
		return;
	pthread_mutex_lock(&s->gate->mu);
	kept_unlink(s->gate, h);
	pthread_mutex_unlock(&s->gate->mu);
}

void api_gate_request_ends(struct api_server *s, struct MHD_Connection *conn)
{
	struct api_gate *g = s->gate;
	struct gate_held *h = g ? held_of(conn) : NULL;

	if (!h || h == &untracked)
		return;
	pthread_mutex_lock(&g->mu);
	if (!h->kept) {
		h->idle_since_ms = db_now_ms();
		h->kept = 1;
		h->next = NULL;
		h->prev = g->kept.tail;
		if (g->kept.tail)
			g->kept.tail->next = h;
		else
			g->kept.head = h;
		g->kept.tail = h;
	}
	pthread_mutex_unlock(&g->mu);
}

/* Shut down the kept connections whose next head is overdue (MHD then
 * reads the end of the stream and closes them); returns the earliest
 * deadline still pending, or -1. */
static int64_t held_expire(struct api_gate *g, int64_t now)
{
	int64_t next = -1;

	pthread_mutex_lock(&g->mu);
	while (g->kept.head && g->kept.head->idle_since_ms + g->head_timeout_ms <= now) {
		struct gate_held *h = g->kept.head;
		kept_unlink(g, h);
		shutdown(h->fd, SHUT_RDWR);
		atomic_fetch_add(&g->srv->gate_keepalive_closed, 1);
	}
	if (g->kept.head)
		next = g->kept.head->idle_since_ms + g->head_timeout_ms;
	pthread_mutex_unlock(&g->mu);
	return next;
}

/* MHD_OPTION_NOTIFY_CONNECTION: a connection the gate handed over starts
 * or ends.  socket_context marks those MHD started, so one that failed
 * before starting is not released twice. */
void api_gate_notify(void *cls, struct MHD_Connection *conn, void **socket_context,
		     enum MHD_ConnectionNotificationCode toe)
{
	struct api_server *s = cls;
	const union MHD_ConnectionInfo *ci;
	struct gate_held *h;

	if (toe == MHD_CONNECTION_NOTIFY_STARTED) {
		ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
		h = ci ? calloc(1, sizeof *h) : NULL;
		if (h)
			h->fd = ci->connect_fd;
		*socket_context = h ? h : &untracked;
		return;
	}
	if (!(h = *socket_context))
		return;
	*socket_context = NULL;
	if (h != &untracked) {
		pthread_mutex_lock(&s->gate->mu);
		kept_unlink(s->gate, h);
		pthread_mutex_unlock(&s->gate->mu);
		free(h);
	}
	ci = MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
	slot_release(s->gate, ci ? ci->client_addr : NULL);
}

/* ---- answers the gate sends itself ---- */

static const char *reason(unsigned status)
{
	switch (status) {
	case 400: return "Bad Request";
	case 408: return "Request Timeout";
	case 431: return "Request Header Fields Too Large";
	case 501: return "Not Implemented";
	default: return "Service Unavailable";
	}
}

/* Send problem p with detail, then linger until the client closes (or
 * GATE_LINGER_MS), so the answer is read before the socket goes away. */
static void answer(struct api_gate *g, struct gate_conn *c, enum problem p, const char *detail)
{
	char type[64], text[1536], retry[32] = "";
	unsigned status = problem_status(p);
	json_t *o;
	char *body;
	int n;

	snprintf(type, sizeof type, "/problems/%s", problem_slug(p));
	o = json_pack("{s:s, s:s, s:i, s:s}", "type", type, "title", problem_title(p), "status",
		      (int)status, "detail", detail);
	body = o ? json_dumps(o, JSON_COMPACT | JSON_ENSURE_ASCII) : NULL;
	json_decref(o);
	if (status == 503)
		snprintf(retry, sizeof retry, "Retry-After: %d\r\n", GATE_RETRY_AFTER_S);
	n = snprintf(text, sizeof text,
		     "HTTP/1.1 %u %s\r\nContent-Type: application/problem+json\r\n"
		     "Content-Length: %zu\r\nCache-Control: no-store\r\nConnection: close\r\n"
		     "%s\r\n%s",
		     status, reason(status), body ? strlen(body) : 0,
		     retry, body ? body : "");
	free(body);
	/* What the client sent so far is read away first: closing with
	 * unread data would reset the connection and lose the answer. */
	for (int k = 0; k < 32 && recv(c->fd, g->peek, sizeof g->peek, MSG_DONTWAIT) > 0; k++)
		; /* at most 1 MiB now; lingering reads the rest */
	if (n > 0 && (size_t)n < sizeof text)
		(void)!send(c->fd, text, (size_t)n, MSG_NOSIGNAL | MSG_DONTWAIT);
	shutdown(c->fd, SHUT_WR);
	list_unlink(&g->pending, c);
	c->state = GATE_LINGER;
	c->deadline_ms = db_now_ms() + GATE_LINGER_MS;
	list_push(&g->linger, c);
	atomic_fetch_add(&g->srv->gate_answers[status == 408 ? 0 : status == 503 ? 1 : 2], 1);
}

/* ---- the head: where it ends, and its framing ---- */

/* Offset just past the blank line ending the head in buf[0..n), or 0.
 * Leading empty lines are skipped (RFC 9112 section 2.2); from: where
 * the previous search stopped. */
static size_t head_end(const char *buf, size_t n, size_t from)
{
	size_t start = 0;

	while (start < n && (buf[start] == '\r' || buf[start] == '\n'))
		start++;
	from = from > start + 3 ? from - 3 : start;
	for (size_t i = from; i < n; i++) {
		if (buf[i] != '\n' || i == start)
			continue;
		if (i >= 1 && buf[i - 1] == '\n')
			return i + 1;
		if (i >= 2 && buf[i - 1] == '\r' && buf[i - 2] == '\n')
			return i + 1;
	}
	return 0;
}

/* Check the fields that frame the body (RFC 9112 sections 5 and 6.3).
 * 0 when MHD may have the request, else the problem to answer with
 * detail set; *probe set for GET /livez and /readyz. */
static int head_check(const char *h, size_t len, int *probe, enum problem *p, char *detail,
		      size_t dlen)
{
	const char *end = h + len, *line = h;
	long long cl = -1;
	int te_chunked = 0, te_other = 0, te_seen = 0;
	char other[32] = "";

	while (line < end && (*line == '\r' || *line == '\n'))
		line++;
	*probe = (!strncmp(line, "GET /livez ", 11) || !strncmp(line, "GET /readyz ", 12));
	line = memchr(line, '\n', (size_t)(end - line));
	while (line && ++line < end) {
		const char *eol = memchr(line, '\n', (size_t)(end - line));
		const char *colon, *v, *ve;
		size_t nl;

		if (!eol)
			break;
		ve = eol > line && eol[-1] == '\r' ? eol - 1 : eol;
		if (ve == line)
			break; /* the blank line */
		*p = PROB_BAD_REQUEST;
		if (*line == ' ' || *line == '\t') {
			snprintf(detail, dlen, "obsolete line folding in the header fields");
			return -1;
		}
		colon = memchr(line, ':', (size_t)(ve - line));
		if (!colon || colon == line) {
			snprintf(detail, dlen, "a header line has no field name and colon");
			return -1;
		}
		if (colon[-1] == ' ' || colon[-1] == '\t') {
			snprintf(detail, dlen, "whitespace between a field name and its colon");
			return -1;
		}
		nl = (size_t)(colon - line);
		v = colon + 1;
		if (nl == 14 && !strncasecmp(line, "Content-Length", 14)) {
			/* One value, or a list of identical ones (RFC 9110 8.6). */
			while (v < ve) {
				char *e;
				long long x;
				while (v < ve && (*v == ' ' || *v == '\t' || *v == ','))
					v++;
				if (v == ve)
					break;
				if (*v < '0' || *v > '9') {
					snprintf(detail, dlen, "Content-Length is not a number");
					return -1;
				}
				x = strtoll(v, &e, 10);
				if (e > ve || (e < ve && *e != ' ' && *e != '\t' && *e != ',')) {
					snprintf(detail, dlen, "Content-Length is not a number");
					return -1;
				}
				if (cl >= 0 && x != cl) {
					snprintf(detail, dlen,
						 "conflicting Content-Length values (%lld and %lld)", cl, x);
					return -1;
				}
				cl = x;
				v = e;
			}
		} else if (nl == 17 && !strncasecmp(line, "Transfer-Encoding", 17)) {
			te_seen = 1;
			while (v < ve) {
				const char *t;
				size_t tl;
				while (v < ve && (*v == ' ' || *v == '\t' || *v == ','))
					v++;
				t = v;
				while (v < ve && *v != ',' && *v != ' ' && *v != '\t' && *v != ';')
					v++;
				tl = (size_t)(v - t);
				while (v < ve && *v != ',')
					v++; /* parameters */
				if (tl == 0)
					continue;
				if (tl == 7 && !strncasecmp(t, "chunked", 7)) {
					te_chunked++;
				} else {
					te_other++;
					if (!other[0])
						snprintf(other, sizeof other, "%.*s", (int)(tl < 24 ? tl : 24), t);
				}
			}
		}
		line = eol;
	}
	if (te_seen && cl >= 0) {
		*p = PROB_BAD_REQUEST;
		snprintf(detail, dlen, "Transfer-Encoding and Content-Length together");
		return -1;
	}
	if (te_other) {
		*p = PROB_NOT_IMPLEMENTED;
		snprintf(detail, dlen, "transfer coding '%s' is not supported; send chunked or a "
			 "Content-Length", other);
		return -1;
	}
	if (te_seen && te_chunked != 1) {
		*p = PROB_BAD_REQUEST;
		snprintf(detail, dlen, "Transfer-Encoding must name chunked exactly once");
		return -1;
	}
	return 0;
}

/* The head is complete: answer framing errors or a full server, else
 * hand the socket to MHD. */
static void hand_over(struct api_gate *g, struct gate_conn *c, size_t len)
{
	char detail[160];
	enum problem p;
	int probe;

	if (head_check(g->peek, len, &probe, &p, detail, sizeof detail)) {
		answer(g, c, p, detail);
		return;
	}
	if (atomic_load(&g->srv->quiesced)) {
		conn_close(g, c);
		return;
	}
	if (slot_take(g, (struct sockaddr *)&c->addr, probe, detail, sizeof detail)) {
		answer(g, c, PROB_UNAVAILABLE, detail);
		return;
	}
	epoll_ctl(g->ep, EPOLL_CTL_DEL, c->fd, NULL);
	list_unlink(&g->pending, c);
	/* MHD closes the socket itself when it refuses it; a refusal after
	 * it started the connection is released by api_gate_notify(). */
	if (MHD_add_connection(g->srv->mhd, c->fd, (struct sockaddr *)&c->addr, c->addrlen) !=
	    MHD_YES) {
		log_msg(LOG_WARN, "http", "libmicrohttpd refused a connection: %s", strerror(errno));
		slot_release(g, (struct sockaddr *)&c->addr);
	}
	free(c);
}

static void on_readable(struct api_gate *g, struct gate_conn *c, uint32_t events)
{
	ssize_t n;
	size_t end;

	if (c->state == GATE_LINGER) {
		while ((n = recv(c->fd, g->peek, sizeof g->peek, MSG_DONTWAIT)) > 0)
			;
		if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR))
			conn_close(g, c);
		return;
	}
	n = recv(c->fd, g->peek, GATE_HEAD_MAX, MSG_PEEK | MSG_DONTWAIT);
	if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
		conn_close(g, c); /* gone before sending a head */
		return;
	}
	if (n < 0)
		return;
	end = head_end(g->peek, (size_t)n, c->scanned);
	if (end) {
		hand_over(g, c, end);
		return;
	}
	c->scanned = (size_t)n;
	if (events & (EPOLLRDHUP | EPOLLHUP | EPOLLERR)) {
		conn_close(g, c); /* gone, or stopped sending, before the head ended */
		return;
	}
	if ((size_t)n >= GATE_HEAD_MAX) {
		char detail[96];
		snprintf(detail, sizeof detail, "the request line and header fields exceed %u bytes",
			 GATE_HEAD_MAX);
		answer(g, c, PROB_HEAD_TOO_LARGE, detail);
	}
}

static void on_accept(struct api_gate *g)
{
	for (int k = 0; k < 256; k++) {
		struct gate_conn *c;
		struct sockaddr_storage ss;
		socklen_t len = sizeof ss;
		struct epoll_event ev;
		int fd = accept4(g->listen_fd, (struct sockaddr *)&ss, &len,
				 SOCK_NONBLOCK | SOCK_CLOEXEC);

		if (fd < 0) {
			if (errno == EMFILE || errno == ENFILE)
				log_msg(LOG_WARN, "http", "accept: %s", strerror(errno));
			return;
		}
		if (atomic_load(&g->srv->quiesced)) {
			close(fd);
			continue;
		}
		/* Full: the oldest waiting head makes room (the slowest sender;
		 * a fresh client sends its head at once). */
		if (g->pending.n + g->linger.n >= g->capacity) {
			if (!g->linger.head && g->pending.head)
				answer(g, g->pending.head, PROB_TIMEOUT,
				       "the server is busy and this request head was the slowest");
			if (g->linger.head)
				conn_close(g, g->linger.head);
		}
		if (!(c = calloc(1, sizeof *c))) {
			close(fd);
			continue;
		}
		c->fd = fd;
		c->state = GATE_HEAD;
		c->deadline_ms = db_now_ms() + g->head_timeout_ms;
		memcpy(&c->addr, &ss, len);
		c->addrlen = len;
		list_push(&g->pending, c);
		/* Edge-triggered: peeking leaves the data queued, so level
		 * triggering would report it again at once; every new segment
		 * is a new edge. */
		ev.events = EPOLLIN | EPOLLRDHUP | EPOLLET;
		ev.data.ptr = c;
		if (epoll_ctl(g->ep, EPOLL_CTL_ADD, fd, &ev) != 0)
			conn_close(g, c);
	}
}

static void expire(struct api_gate *g, int64_t now)
{
	char detail[96];

	while (g->linger.head && g->linger.head->deadline_ms <= now)
		conn_close(g, g->linger.head);
	while (g->pending.head && g->pending.head->deadline_ms <= now) {
		snprintf(detail, sizeof detail, "the request head did not arrive within %d s",
			 g->head_timeout_ms / 1000);
		answer(g, g->pending.head, PROB_TIMEOUT, detail);
	}
}

static void *gate_main(void *arg)
{
	struct api_gate *g = arg;
	struct epoll_event evs[128];

	while (!atomic_load(&g->srv->stopping)) {
		int64_t now = db_now_ms(), next;
		int n, timeout;

		expire(g, now);
		next = held_expire(g, now);
		if (g->pending.head && (next < 0 || g->pending.head->deadline_ms < next))
			next = g->pending.head->deadline_ms;
		if (g->linger.head && (next < 0 || g->linger.head->deadline_ms < next))
			next = g->linger.head->deadline_ms;
		timeout = next < 0 ? 1000 : (int)(next - now < 0 ? 0 : next - now + 1);
		n = epoll_wait(g->ep, evs, 128, timeout);
		for (int i = 0; i < n; i++) {
			void *p = evs[i].data.ptr;
			if (p == &listen_tag)
				on_accept(g);
			else if (p != &wake_tag)
				on_readable(g, p, evs[i].events);
		}
	}
	return NULL;
}

/* The listen socket: bound, listening, non-blocking. */
static int open_listener(const struct sockaddr_storage *ss, int *fd_out, int *port_out,
			 struct err *e)
{
	socklen_t len = ss->ss_family == AF_INET6 ? sizeof(struct sockaddr_in6)
						  : sizeof(struct sockaddr_in);
	struct sockaddr_storage bound;
	int one = 1, fd = socket(ss->ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);

	if (fd < 0)
		return ERR_SET(e, ERR_IO, "cannot create the listen socket: %s", strerror(errno));
	setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
	if (ss->ss_family == AF_INET6)
		setsockopt(fd, IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof one);
	if (bind(fd, (const struct sockaddr *)ss, len) != 0 || listen(fd, 1024) != 0) {
		int rc = ERR_SET(e, ERR_IO, "%s", strerror(errno));
		close(fd);
		return rc;
	}
	len = sizeof bound;
	getsockname(fd, (struct sockaddr *)&bound, &len);
	*port_out = ntohs(bound.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&bound)->sin6_port
						      : ((struct sockaddr_in *)&bound)->sin_port);
	*fd_out = fd;
	return 0;
}

int api_gate_start(struct api_server *s, const struct sockaddr_storage *ss, struct err *e)
{
	struct api_gate *g = calloc(1, sizeof *g);
	struct epoll_event ev;
	struct rlimit rl;
	int rc;

	if (!g)
		return ERR_SET(e, ERR_NOMEM, "out of memory starting the server");
	g->srv = s;
	g->listen_fd = g->ep = g->wake_fd = -1;
	g->head_timeout_ms = s->cfg.head_timeout_s * 1000;
	pthread_mutex_init(&g->mu, NULL);
	/* Large and separate from MHD's limit, within the descriptors left
	 * once MHD's connections and the reserve are open. */
	g->capacity = s->cfg.max_connections * 4 > 8192 ? s->cfg.max_connections * 4 : 8192;
	if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
		long room = (long)rl.rlim_cur - s->cfg.max_connections - GATE_RESERVE - 256;
		if (room < g->capacity)
			g->capacity = room > 64 ? (int)room : 64;
	}
	s->gate = g;
	if ((rc = open_listener(ss, &g->listen_fd, &s->port, e)))
		goto fail;
	g->ep = epoll_create1(EPOLL_CLOEXEC);
	g->wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (g->ep < 0 || g->wake_fd < 0) {
		rc = ERR_SET(e, ERR_IO, "epoll: %s", strerror(errno));
		goto fail;
	}
	ev.events = EPOLLIN;
	ev.data.ptr = &listen_tag;
	epoll_ctl(g->ep, EPOLL_CTL_ADD, g->listen_fd, &ev);
	ev.data.ptr = &wake_tag;
	epoll_ctl(g->ep, EPOLL_CTL_ADD, g->wake_fd, &ev);
	return 0;
fail:
	api_gate_free(s);
	return rc;
}

int api_gate_run(struct api_server *s, struct err *e)
{
	if (pthread_create(&s->gate->thread, NULL, gate_main, s->gate) != 0)
		return ERR_SET(e, ERR_IO, "cannot start the accept thread");
	s->gate->started = 1;
	return 0;
}

void api_gate_stop(struct api_server *s)
{
	struct api_gate *g = s->gate;

	if (!g)
		return;
	if (g->started) {
		uint64_t one = 1;
		(void)!write(g->wake_fd, &one, sizeof one);
		pthread_join(g->thread, NULL);
	}
	while (g->pending.head)
		conn_close(g, g->pending.head);
	while (g->linger.head)
		conn_close(g, g->linger.head);
	if (g->listen_fd >= 0)
		close(g->listen_fd);
	if (g->ep >= 0)
		close(g->ep);
	if (g->wake_fd >= 0)
		close(g->wake_fd);
	g->started = 0;
	g->listen_fd = g->ep = g->wake_fd = -1;
}

void api_gate_free(struct api_server *s)
{
	struct api_gate *g = s->gate;

	if (!g)
		return;
	api_gate_stop(s);
	for (int i = 0; i < GATE_BUCKETS; i++)
		while (g->ips[i]) {
			struct gate_ip *ip = g->ips[i];
			g->ips[i] = ip->next;
			free(ip);
		}
	pthread_mutex_destroy(&g->mu);
	free(g);
	s->gate = NULL;
}
