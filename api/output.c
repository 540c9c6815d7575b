/* output.c - GET /v1/jobs/{id}/output: the finished artifact.
 *
 * A whole download is a chunked stream read with pread() in 256 KiB
 * blocks (memory per connection is one block, whatever the file size);
 * a single "Range: bytes=a-b" gets 206 served from the file descriptor.
 * ETag is the artifact's SHA-256; Repr-Digest (RFC 9530) carries it too.
 * The file's size is checked against the database before anything is
 * sent, and a whole download is hashed as it streams: a file altered on
 * disk ends the stream without its last chunk, so the client sees an
 * error instead of a complete, wrong file.  A part cannot be checked on
 * its own, so a Range is served only from a file this process has seen
 * whole and right (srv->seen, by device, inode, size, mtime and ctime,
 * filled by whole downloads and by these checks); any other is hashed
 * whole first, on a pool thread with the connection parked, and a
 * mismatch answers 500 instead of 206.
 */
#include "api/api_internal.h"
#include "api/log.h"
#include "db/queue.h"
#include "db/store.h"
#include "engine/engine.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <nettle/base64.h>
#include <nettle/sha2.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define OUTPUT_BLOCK (256u * 1024u)

/* ---- files known whole: srv->seen ---- */

static int64_t ns_of(const struct timespec *t)
{
	return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec;
}

static struct api_seen seen_key(const struct stat *st)
{
	struct api_seen k = {(uint64_t)st->st_dev, (uint64_t)st->st_ino, (int64_t)st->st_size,
			     ns_of(&st->st_mtim), ns_of(&st->st_ctim), 1};
	return k;
}

static struct api_seen *seen_slot(struct api_server *s, const struct api_seen *k)
{
	return &s->seen[(k->ino * 0x9e3779b97f4a7c15ull ^ k->dev) % API_SEEN_SLOTS];
}

static int seen_has(struct api_server *s, const struct stat *st)
{
	struct api_seen k = seen_key(st), *v;
	int hit;

	pthread_mutex_lock(&s->seen_mu);
	v = seen_slot(s, &k);
	hit = v->used && v->dev == k.dev && v->ino == k.ino && v->size == k.size &&
	      v->mtime_ns == k.mtime_ns && v->ctime_ns == k.ctime_ns;
	pthread_mutex_unlock(&s->seen_mu);
	return hit;
}

static void seen_add(struct api_server *s, const struct stat *st)
{
	struct api_seen k = seen_key(st);

	pthread_mutex_lock(&s->seen_mu);
	*seen_slot(s, &k) = k;
	pthread_mutex_unlock(&s->seen_mu);
}

/* ---- whole downloads ---- */

struct dl {
	struct api_server *srv;
	int fd;
	struct stat st;              /* as opened (for srv->seen) */
	uint64_t size;
	uint64_t hashed;             /* bytes fed to sha so far (reads are in order) */
	struct sha256_ctx sha;
	char expect_sha[65];         /* recorded digest, hex */
	char job_id[DB_ID_MAX];
};

static ssize_t dl_read(void *cls, uint64_t pos, char *buf, size_t max)
{
	struct dl *d = cls;
	ssize_t n;

	if (pos >= d->size)
		return MHD_CONTENT_READER_END_OF_STREAM;
	if (max > d->size - pos)
		max = (size_t)(d->size - pos);
	do
		n = pread(d->fd, buf, max, (off_t)pos);
	while (n < 0 && errno == EINTR);
	if (n <= 0)
		return MHD_CONTENT_READER_END_WITH_ERROR; /* truncated underneath us */
	if (pos == d->hashed) {
		sha256_update(&d->sha, (size_t)n, (const uint8_t *)buf);
		d->hashed += (uint64_t)n;
		if (d->hashed == d->size) {
			uint8_t digest[SHA256_DIGEST_SIZE];
			char hex[65];
			sha256_digest(&d->sha, sizeof digest, digest);
			db_sha256_hex(digest, hex);
			if (strcmp(hex, d->expect_sha) != 0) {
				log_msg(LOG_ERROR, "output",
					"job %s: artifact digest %s differs from the recorded %s; "
					"download aborted (run infilld fsck)",
					d->job_id, hex, d->expect_sha);
				return MHD_CONTENT_READER_END_WITH_ERROR;
			}
			seen_add(d->srv, &d->st);
		}
	}
	atomic_fetch_add(&d->srv->bytes_out, n);
	return n;
}

static void dl_free(void *cls)
{
	struct dl *d = cls;

	close(d->fd);
	free(d);
}

/* Parse "bytes=a-b", "bytes=a-", "bytes=-n" against size.  1 = range
 * set, 0 = no usable Range (serve all), -1 = unsatisfiable. */
static int parse_range(const char *h, uint64_t size, uint64_t *from, uint64_t *to)
{
	char *end;
	unsigned long long a, b;

	if (!h || strncmp(h, "bytes=", 6) != 0 || strchr(h, ','))
		return 0; /* multiple ranges: serve the whole file (allowed) */
	h += 6;
	if (*h == '-') {
		b = strtoull(h + 1, &end, 10);
		if (*end || end == h + 1)
			return 0;
		if (b == 0 || size == 0)
			return -1;
		*from = b >= size ? 0 : size - b;
		*to = size - 1;
		return 1;
	}
	a = strtoull(h, &end, 10);
	if (end == h || *end != '-')
		return 0;
	h = end + 1;
	if (*h) {
		b = strtoull(h, &end, 10);
		if (*end || b < a)
			return 0;
	} else {
		b = size ? size - 1 : 0;
	}
	if (a >= size)
		return -1;
	*from = a;
	*to = b >= size ? size - 1 : b;
	return 1;
}

/* RFC 6266: filename= the sanitised ASCII name (store_output_name), and
 * filename*= the mesh's own name, UTF-8 percent-encoded (RFC 8187), each
 * with the output's extension. */
static void content_disposition(const struct job_row *j, const char *ext, char *buf, size_t len)
{
	static const char attr[] = "!#$&+-.^_`|~";
	char ascii[STORE_OUTPUT_NAME_MAX];
	const char *name = j->mesh_name[0] ? j->mesh_name : ascii;
	const char *dot = strrchr(name, '.');
	size_t stem = dot && dot != name ? (size_t)(dot - name) : strlen(name), n;

	store_output_name(j->mesh_name, j->id, ascii, sizeof ascii);
	n = (size_t)snprintf(buf, len, "attachment; filename=\"%s%s\"; filename*=UTF-8''", ascii,
			     ext);
	for (size_t i = 0; i < stem && n + 4 < len; i++) {
		unsigned char c = (unsigned char)name[i];
		if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
		    (c && strchr(attr, c)))
			buf[n++] = (char)c;
		else
			n += (size_t)snprintf(buf + n, len - n, "%%%02X", c);
	}
	snprintf(buf + n, len - n, "%s", ext);
}

static int etag_match(const char *inm, const char *etag)
{
	return inm && (strstr(inm, etag) != NULL || !strcmp(inm, "*"));
}

/* What every 200 or 206 of one artifact carries. */
struct out_headers {
	const char *mime;
	char etag[72], digest[64], disp[768], length[32];
};

static void out_headers_add(struct MHD_Response *resp, const struct out_headers *h)
{
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, h->mime);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_DISPOSITION, h->disp);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, h->etag);
	MHD_add_response_header(resp, "Repr-Digest", h->digest);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_ACCEPT_RANGES, "bytes");
	MHD_add_response_header(resp, "X-Artifact-Length", h->length);
}

/* 206 for bytes from..to of fd (owned: the response closes it, or this
 * does when no response can be made); NULL when out of memory. */
static struct MHD_Response *range_response(struct api_server *s, int fd, const struct stat *st,
					   uint64_t from, uint64_t to,
					   const struct out_headers *h)
{
	struct MHD_Response *resp = MHD_create_response_from_fd_at_offset64(to - from + 1, fd, from);
	char cr[80];

	if (!resp) {
		close(fd);
		return NULL;
	}
	snprintf(cr, sizeof cr, "bytes %" PRIu64 "-%" PRIu64 "/%lld", from, to,
		 (long long)st->st_size);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_RANGE, cr);
	out_headers_add(resp, h);
	atomic_fetch_add(&s->bytes_out, (long long)(to - from + 1));
	return resp;
}

/* A Range of a file not yet known whole: checked on a pool thread. */
struct range_check {
	int fd; /* -1 once handed to a response */
	struct stat st;
	uint64_t from, to;
	char expect_sha[65], job_id[DB_ID_MAX];
	struct out_headers h;
};

static void range_check_free(void *p)
{
	struct range_check *c = p;

	if (c->fd >= 0)
		close(c->fd);
	free(c);
}

static void range_check_run(struct api_req *r)
{
	struct range_check *c = r->work;
	int64_t bytes = -1;
	char hex[65];

	if (store_fd_sha256(c->fd, &bytes, hex) == 0 && bytes == (int64_t)c->st.st_size &&
	    !strcmp(hex, c->expect_sha)) {
		seen_add(r->srv, &c->st);
		r->pending = range_response(r->srv, c->fd, &c->st, c->from, c->to, &c->h);
		c->fd = -1;
		r->pending_status = MHD_HTTP_PARTIAL_CONTENT;
		if (r->pending)
			return;
	} else {
		log_msg(LOG_ERROR, "output",
			"job %s: artifact holds %lld bytes with SHA-256 %s, the database %s; "
			"range refused (run infilld fsck)",
			c->job_id, (long long)bytes, bytes < 0 ? "(unreadable)" : hex,
			c->expect_sha);
	}
	r->pending = api_problem_response(PROB_INTERNAL, r->url, NULL,
					  "the stored output of this job is damaged; it cannot "
					  "be served", &r->pending_status);
}

enum MHD_Result api_job_output(struct api_req *r)
{
	char path[STORE_PATH_MAX], b64[48], expect_sha[65];
	struct out_headers h;
	struct job_row j;
	struct MHD_Response *resp;
	enum MHD_Result ret;
	enum out_format f;
	struct stat st;
	struct err e;
	uint64_t from, to;
	int fd, rg;

	if (api_load_done_job(r, &j, &ret, "the job is still running; follow its events",
			      "the job did not succeed, so it has no output"))
		return ret;
	if (!j.artifact[0]) {
		int damaged = j.artifact_damaged_ms != 0;
		queue_job_row_fini(&j);
		return api_problem(r, PROB_GONE, NULL,
				   damaged ? "the output of job %s was damaged on disk and is withdrawn; "
					     "submit the job again"
					   : "the output of job %s was deleted by retention",
				   r->arg[0]);
	}
	store_artifact_path(r->srv->cfg.store_dir, r->tenant.id, j.artifact, path, sizeof path);
	fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0 || fstat(fd, &st) != 0) {
		if (fd >= 0)
			close(fd);
		queue_job_row_fini(&j);
		return api_problem(r, PROB_GONE, NULL, "the output file of job %s is missing",
				   r->arg[0]);
	}
	if ((int64_t)st.st_size != j.artifact_bytes) {
		log_msg(LOG_ERROR, "output",
			"job %s: artifact %s has %lld bytes on disk, %lld recorded (run infilld fsck)",
			j.id, j.artifact, (long long)st.st_size, (long long)j.artifact_bytes);
		close(fd);
		queue_job_row_fini(&j);
		return api_problem(r, PROB_INTERNAL, NULL,
				   "the stored output of job %s is damaged; it cannot be served",
				   r->arg[0]);
	}
	snprintf(h.etag, sizeof h.etag, "\"%s\"", j.artifact_sha256);
	{
		uint8_t raw[32];
		for (int i = 0; i < 32; i++)
			sscanf(j.artifact_sha256 + 2 * i, "%2hhx", &raw[i]);
		base64_encode_raw((char *)b64, 32, raw);
		b64[BASE64_ENCODE_RAW_LENGTH(32)] = '\0';
		snprintf(h.digest, sizeof h.digest, "sha-256=:%s:", b64);
	}
	snprintf(expect_sha, sizeof expect_sha, "%s", j.artifact_sha256);
	if (out_format_parse(j.format, &f, &e) != 0)
		f = OUT_ZIP;
	content_disposition(&j, out_format_extension(f), h.disp, sizeof h.disp);
	h.mime = out_format_mime(f);
	snprintf(h.length, sizeof h.length, "%lld", (long long)st.st_size);
	queue_job_row_fini(&j);
	if (etag_match(api_header(r, MHD_HTTP_HEADER_IF_NONE_MATCH), h.etag)) {
		close(fd);
		resp = MHD_create_response_from_buffer(0, NULL, MHD_RESPMEM_PERSISTENT);
		if (resp)
			MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, h.etag);
		return api_queue(r, MHD_HTTP_NOT_MODIFIED, resp);
	}
	rg = parse_range(api_header(r, MHD_HTTP_HEADER_RANGE), (uint64_t)st.st_size, &from, &to);
	if (rg && api_header(r, MHD_HTTP_HEADER_IF_RANGE) &&
	    strcmp(api_header(r, MHD_HTTP_HEADER_IF_RANGE), h.etag) != 0)
		rg = 0; /* changed representation: send it all */
	if (rg < 0) {
		char cr[48];
		unsigned status;
		close(fd);
		resp = api_problem_response(PROB_RANGE, r->url, NULL,
					    "the range is outside the artifact", &status);
		snprintf(cr, sizeof cr, "bytes */%lld", (long long)st.st_size);
		if (resp)
			MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_RANGE, cr);
		return api_queue(r, status, resp);
	}
	if (rg > 0 && seen_has(r->srv, &st))
		return api_queue(r, MHD_HTTP_PARTIAL_CONTENT,
				 range_response(r->srv, fd, &st, from, to, &h));
	if (rg > 0) {
		struct range_check *c = calloc(1, sizeof *c);
		if (!c) {
			close(fd);
			return MHD_NO;
		}
		c->fd = fd;
		c->st = st;
		c->from = from;
		c->to = to;
		c->h = h;
		snprintf(c->expect_sha, sizeof c->expect_sha, "%s", expect_sha);
		snprintf(c->job_id, sizeof c->job_id, "%s", r->arg[0]);
		r->work = c;
		r->work_free = range_check_free;
		if (api_offload(r, range_check_run) != 0)
			return MHD_NO; /* c is freed with the request */
		return MHD_YES;
	}
	{
		struct dl *d = calloc(1, sizeof *d);
		if (!d) {
			close(fd);
			return MHD_NO;
		}
		d->srv = r->srv;
		d->fd = fd;
		d->st = st;
		d->size = (uint64_t)st.st_size;
		sha256_init(&d->sha);
		snprintf(d->expect_sha, sizeof d->expect_sha, "%s", expect_sha);
		snprintf(d->job_id, sizeof d->job_id, "%s", r->arg[0]);
		/* MHD_SIZE_UNKNOWN: chunked transfer encoding, constant memory. */
		resp = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, OUTPUT_BLOCK, dl_read, d,
							 dl_free);
		if (!resp) {
			dl_free(d);
			return MHD_NO;
		}
	}
	out_headers_add(resp, &h);
	return api_queue(r, MHD_HTTP_OK, resp);
}
