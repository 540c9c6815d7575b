/* output.c - GET /v1/jobs/{id}/output: the finished artifact.
 *
 * A whole download is a chunked stream read with pread() in 256 KiB
 * blocks (memory per connection is one block, whatever the file size);
 * a single "Range: bytes=a-b" gets 206 served from the file descriptor.
 * ETag is the artifact's SHA-256; Repr-Digest (RFC 9530) carries it too.
 * The file's size is checked against the database before anything is
 * sent, and a whole download is hashed as it streams: a file altered on
 * disk ends the stream without its last chunk, so the client sees an
 * error instead of a complete, wrong file.
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
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define OUTPUT_BLOCK (256u * 1024u)

struct dl {
	struct api_server *srv;
	int fd;
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

enum MHD_Result api_job_output(struct api_req *r)
{
	char path[STORE_PATH_MAX], etag[72], digest[64], disp[768], b64[48], expect_sha[65];
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
	snprintf(etag, sizeof etag, "\"%s\"", j.artifact_sha256);
	{
		uint8_t raw[32];
		for (int i = 0; i < 32; i++)
			sscanf(j.artifact_sha256 + 2 * i, "%2hhx", &raw[i]);
		base64_encode_raw((char *)b64, 32, raw);
		b64[BASE64_ENCODE_RAW_LENGTH(32)] = '\0';
		snprintf(digest, sizeof digest, "sha-256=:%s:", b64);
	}
	snprintf(expect_sha, sizeof expect_sha, "%s", j.artifact_sha256);
	if (out_format_parse(j.format, &f, &e) != 0)
		f = OUT_ZIP;
	content_disposition(&j, out_format_extension(f), disp, sizeof disp);
	queue_job_row_fini(&j);
	if (etag_match(api_header(r, MHD_HTTP_HEADER_IF_NONE_MATCH), etag)) {
		close(fd);
		resp = MHD_create_response_from_buffer(0, NULL, MHD_RESPMEM_PERSISTENT);
		if (resp)
			MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, etag);
		return api_queue(r, MHD_HTTP_NOT_MODIFIED, resp);
	}
	rg = parse_range(api_header(r, MHD_HTTP_HEADER_RANGE), (uint64_t)st.st_size, &from, &to);
	if (rg && api_header(r, MHD_HTTP_HEADER_IF_RANGE) &&
	    strcmp(api_header(r, MHD_HTTP_HEADER_IF_RANGE), etag) != 0)
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
	if (rg > 0) {
		char cr[80];
		resp = MHD_create_response_from_fd_at_offset64(to - from + 1, fd, from);
		snprintf(cr, sizeof cr, "bytes %" PRIu64 "-%" PRIu64 "/%lld", from, to,
			 (long long)st.st_size);
		if (resp)
			MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_RANGE, cr);
		else
			close(fd);
		atomic_fetch_add(&r->srv->bytes_out, (long long)(to - from + 1));
	} else {
		struct dl *d = calloc(1, sizeof *d);
		if (!d) {
			close(fd);
			return MHD_NO;
		}
		d->srv = r->srv;
		d->fd = fd;
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
	if (!resp)
		return MHD_NO;
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, out_format_mime(f));
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_DISPOSITION, disp);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_ETAG, etag);
	MHD_add_response_header(resp, "Repr-Digest", digest);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_ACCEPT_RANGES, "bytes");
	{
		char len[32];
		snprintf(len, sizeof len, "%lld", (long long)st.st_size);
		MHD_add_response_header(resp, "X-Artifact-Length", len);
	}
	return api_queue(r, rg > 0 ? MHD_HTTP_PARTIAL_CONTENT : MHD_HTTP_OK, resp);
}
