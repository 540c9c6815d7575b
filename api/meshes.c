/* meshes.c - /v1/meshes: streamed uploads (raw body or multipart), with
 * SHA-256, size limits enforced before and while reading, sandboxed
 * analysis (analyze.c), publication by temp + fsync + rename; list, get,
 * delete.
 */
#define _GNU_SOURCE /* pipe2, strcasestr */
#include "api/api_internal.h"
#include "api/log.h"
#include "api/multipart.h"
#include "api/upload.h"
#include "db/meshes.h"
#include "db/store.h"
#include "engine/core/err.h"

#include <errno.h>
#include <fcntl.h>
#include <nettle/base64.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

struct upload {
	int fd;
	struct sink out;           /* writes to fd */
	char tmp[STORE_PATH_MAX];
	char format[8];
	char name[128];
	char expect_sha[65];       /* lower-case hex, "" = not given */
	int64_t bytes, limit;      /* body bytes so far (multipart framing too) */
	int64_t file_bytes;        /* of those, the mesh's: what is stored and charged */
	struct sha256_ctx sha;
	int multipart;
	struct multipart mp;
	int in_file;               /* multipart: inside the "file" part */
	int files;                 /* "file" parts seen */
	int bad_name;              /* the file part's filename is not valid text */
	char field[16];            /* multipart: current small field */
	char value[80];
	size_t vlen;
	char mesh_id[DB_ID_MAX];
	char sha_hex[65];
};

static const char *const formats[] = {"stl", "obj", "off", "ply", NULL};

static int format_valid(const char *f)
{
	for (int i = 0; formats[i]; i++)
		if (!strcasecmp(f, formats[i]))
			return 1;
	return 0;
}

static void set_format(struct upload *u, const char *f)
{
	snprintf(u->format, sizeof u->format, "%s", f);
	for (char *p = u->format; *p; p++)
		*p = (char)(*p >= 'A' && *p <= 'Z' ? *p + 32 : *p);
}

/* The format from a file name's extension, or NULL. */
static const char *format_of_name(const char *name)
{
	const char *dot = strrchr(name, '.');

	return dot && format_valid(dot + 1) ? dot + 1 : NULL;
}

void api_upload_discard(struct upload *u)
{
	if (u->fd >= 0)
		close(u->fd);
	u->fd = -1;
	if (u->tmp[0])
		unlink(u->tmp);
	u->tmp[0] = '\0';
}

void api_upload_free(struct upload *u)
{
	if (!u)
		return;
	api_upload_discard(u);
	free(u);
}

/* Accept "sha256" hex (query, form field, X-Checksum-Sha256) or an RFC 9530
 * Content-Digest "sha-256=:<base64>:". 0 ok, -1 malformed. */
static int parse_expected(struct upload *u, const char *hex, const char *digest)
{
	if (hex) {
		if (strlen(hex) != 64 || strspn(hex, "0123456789abcdefABCDEF") != 64)
			return -1;
		for (int i = 0; i < 64; i++)
			u->expect_sha[i] = (char)(hex[i] >= 'A' && hex[i] <= 'F' ? hex[i] + 32 : hex[i]);
		u->expect_sha[64] = '\0';
		return 0;
	}
	if (digest) {
		const char *p = strcasestr(digest, "sha-256=:");
		struct base64_decode_ctx b;
		uint8_t raw[48];
		size_t n = sizeof raw;
		const char *end;
		if (!p)
			return 0; /* other algorithms: ignored */
		p += 9;
		end = strchr(p, ':');
		if (!end)
			return -1;
		base64_decode_init(&b);
		if (!base64_decode_update(&b, &n, raw, (size_t)(end - p), p) ||
		    !base64_decode_final(&b) || n != 32)
			return -1;
		db_sha256_hex(raw, u->expect_sha);
	}
	return 0;
}

static int write_all(struct upload *u, const void *p, size_t len)
{
	struct err e;

	sha256_update(&u->sha, len, (const uint8_t *)p);
	u->file_bytes += (int64_t)len;
	return sink_write(&u->out, p, len, &e) ? -1 : 0;
}

/* Mesh names are stored and shown in JSON: UTF-8 text that fits. */
static int name_valid(const char *name)
{
	return api_text_valid(name) && strlen(name) < sizeof ((struct upload *)0)->name;
}

static int mp_begin(void *ctx, const char *name, const char *filename)
{
	struct upload *u = ctx;

	u->in_file = !strcmp(name, "file");
	u->vlen = 0;
	snprintf(u->field, sizeof u->field, "%s", u->in_file ? "" : name);
	if (u->in_file) {
		if (u->files++)
			return -1; /* one mesh per upload */
		if (filename[0]) {
			const char *base = strrchr(filename, '/');
			base = base ? base + 1 : filename;
			if (!name_valid(base)) {
				u->bad_name = 1;
				return -1;
			}
			snprintf(u->name, sizeof u->name, "%s", base);
			if (!u->format[0] && format_of_name(u->name))
				set_format(u, format_of_name(u->name));
		}
	}
	return 0;
}

static int mp_data(void *ctx, const void *p, size_t len)
{
	struct upload *u = ctx;

	if (u->in_file)
		return write_all(u, p, len);
	if (u->vlen + len >= sizeof u->value)
		return -1; /* small fields only */
	memcpy(u->value + u->vlen, p, len);
	u->vlen += len;
	u->value[u->vlen] = '\0';
	if (!strcmp(u->field, "sha256") && u->vlen == 64)
		parse_expected(u, u->value, NULL);
	else if (!strcmp(u->field, "format") && format_valid(u->value))
		set_format(u, u->value);
	return 0;
}

enum MHD_Result api_upload_begin(struct api_req *r)
{
	const char *ct = api_header(r, MHD_HTTP_HEADER_CONTENT_TYPE);
	const char *cl = api_header(r, MHD_HTTP_HEADER_CONTENT_LENGTH);
	const char *qf = api_query(r, "format");
	const char *name = api_query(r, "name");
	struct upload *u;
	char tmpname[64], rnd[DB_ID_MAX];
	struct err e;

	if (!ct)
		return api_problem(r, PROB_UNSUPPORTED_MEDIA, NULL, "Content-Type is missing");
	if (qf && !format_valid(qf))
		return api_problem(r, PROB_INVALID_PARAM, "format",
				   "format must be one of stl, obj, off, ply");
	if (name && !name_valid(name))
		return api_problem(r, PROB_INVALID_PARAM, "name",
				   "name must be UTF-8 text without control characters, under %zu bytes",
				   sizeof u->name);
	if (cl && strtoll(cl, NULL, 10) > r->tenant.max_upload_bytes)
		return api_problem(r, PROB_TOO_LARGE, NULL,
				   "the upload is %s bytes; this tenant's limit is %lld bytes", cl,
				   (long long)r->tenant.max_upload_bytes);
	if (r->tenant.quota_bytes &&
	    r->tenant.used_bytes + (cl ? strtoll(cl, NULL, 10) : 0) > r->tenant.quota_bytes)
		return api_problem(r, PROB_QUOTA, NULL,
				   "the upload would take the tenant past its storage quota of %lld bytes "
				   "(%lld in use)",
				   (long long)r->tenant.quota_bytes, (long long)r->tenant.used_bytes);
	if (!(u = calloc(1, sizeof *u)))
		return MHD_NO;
	u->fd = -1;
	u->limit = r->tenant.max_upload_bytes;
	sha256_init(&u->sha);
	snprintf(u->name, sizeof u->name, "%s", name && *name ? name : "upload");
	if (qf)
		set_format(u, qf);
	if (!strncasecmp(ct, "multipart/form-data", 19)) {
		struct multipart_cb cb = {mp_begin, mp_data, u};
		if (multipart_init(&u->mp, ct, &cb)) {
			free(u);
			return api_problem(r, PROB_BAD_REQUEST, NULL,
					   "multipart/form-data needs a valid boundary parameter");
		}
		u->multipart = 1;
	} else if (!strncasecmp(ct, "model/stl", 9) || !strncasecmp(ct, "model/x.stl", 11) ||
		   !strncasecmp(ct, "application/sla", 15)) {
		if (!qf)
			set_format(u, "stl");
	} else if (!strncasecmp(ct, "model/obj", 9)) {
		if (!qf)
			set_format(u, "obj");
	} else if (!strncasecmp(ct, "application/octet-stream", 24)) {
		if (!u->format[0] && format_of_name(u->name))
			set_format(u, format_of_name(u->name));
		if (!u->format[0]) {
			free(u);
			return api_problem(r, PROB_INVALID_PARAM, "format",
					   "application/octet-stream uploads need ?format=stl|obj|off|ply");
		}
	} else {
		free(u);
		return api_problem(r, PROB_UNSUPPORTED_MEDIA, NULL,
				   "cannot upload %s: use model/stl, model/obj, "
				   "application/octet-stream with ?format=, or multipart/form-data",
				   ct);
	}
	if (parse_expected(u, api_query(r, "sha256") ? api_query(r, "sha256")
						     : api_header(r, "X-Checksum-Sha256"),
			   api_header(r, "Content-Digest"))) {
		free(u);
		return api_problem(r, PROB_BAD_REQUEST, "sha256",
				   "the checksum must be 64 hex digits (or Content-Digest sha-256)");
	}
	err_clear(&e);
	db_make_id("m_", rnd, &e);
	snprintf(tmpname, sizeof tmpname, "up-%s", rnd + 2);
	store_tmp_path(r->srv->cfg.store_dir, tmpname, u->tmp, sizeof u->tmp);
	u->fd = open(u->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0640);
	if (u->fd < 0) {
		log_msg(LOG_ERROR, "upload", "cannot create %s: %s", u->tmp, strerror(errno));
		u->tmp[0] = '\0';
		free(u);
		return api_problem(r, PROB_UNAVAILABLE, NULL, "cannot store the upload");
	}
	sink_init_fd(&u->out, u->fd);
	r->upload = u;
	return MHD_YES;
}

int api_upload_feed(struct api_req *r, const char *data, size_t len)
{
	struct upload *u = r->upload;

	u->bytes += (int64_t)len;
	if (r->tenant.quota_bytes && r->tenant.used_bytes + u->bytes > r->tenant.quota_bytes) {
		/* Chunked bodies have no length to refuse up front. */
		api_reject(r, PROB_QUOTA,
			   "the upload would take the tenant past its storage quota of %lld bytes "
			   "(%lld in use)",
			   (long long)r->tenant.quota_bytes, (long long)r->tenant.used_bytes);
		return -1;
	}
	if (u->bytes > u->limit) {
		/* Chunked or lying Content-Length: stop at the limit. */
		api_reject(r, PROB_TOO_LARGE, "the upload exceeds this tenant's limit of %lld bytes",
			   (long long)u->limit);
		return -1;
	}
	if (u->multipart) {
		if (multipart_feed(&u->mp, data, len)) {
			if (u->bad_name) {
				api_reject(r, PROB_INVALID_PARAM,
					   "the file name must be UTF-8 text without control characters, "
					   "under %zu bytes", sizeof u->name);
				api_reject_field(r, "name");
			} else {
				api_reject(r, PROB_BAD_REQUEST, "malformed multipart body: %s",
					   u->mp.error);
			}
			return -1;
		}
		return 0;
	}
	if (write_all(u, data, len)) {
		api_reject(r, PROB_UNAVAILABLE, "cannot store the upload");
		return -1;
	}
	return 0;
}

/* Body complete: check, then analyse on the pool (connection parked). */
enum MHD_Result api_mesh_upload(struct api_req *r)
{
	struct upload *u = r->upload;
	unsigned char digest[SHA256_DIGEST_SIZE];
	char final_tmp[STORE_PATH_MAX];
	struct err e;

	if (u->multipart) {
		if (multipart_finish(&u->mp))
			return api_problem(r, PROB_BAD_REQUEST, NULL, "malformed multipart body: %s",
					   u->mp.error);
		if (!u->files)
			return api_problem(r, PROB_BAD_REQUEST, "file",
					   "the multipart body has no part named 'file'");
		if (!u->format[0])
			return api_problem(r, PROB_INVALID_PARAM, "format",
					   "cannot tell the mesh format: name the file *.stl/.obj/.off/.ply "
					   "or pass ?format=");
	}
	sha256_digest(&u->sha, SHA256_DIGEST_SIZE, digest);
	db_sha256_hex(digest, u->sha_hex);
	if (u->expect_sha[0] && strcmp(u->expect_sha, u->sha_hex) != 0)
		return api_problem(r, PROB_CHECKSUM, "sha256",
				   "received %lld bytes with SHA-256 %s, expected %s",
				   (long long)u->file_bytes, u->sha_hex, u->expect_sha);
	close(u->fd);
	u->fd = -1;
	/* Readers pick binary/ASCII by content and use the extension as a
	 * hint: give the temp file one. */
	err_clear(&e);
	if (db_make_id("m_", u->mesh_id, &e) ||
	    snprintf(final_tmp, sizeof final_tmp, "%s.%s", u->tmp, u->format) >= (int)sizeof final_tmp ||
	    rename(u->tmp, final_tmp) != 0)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "cannot store the upload");
	snprintf(u->tmp, sizeof u->tmp, "%s", final_tmp);
	if (api_analyze_submit(r))
		return MHD_NO;
	return MHD_YES;
}

/* The last line of the child's stderr without the "infilld: " prefix. */
static const char *child_error(struct buf *err)
{
	char *s = (char *)err->data, *line, *nl;

	if (!s || !*s)
		return "the mesh reader stopped without a message";
	while ((nl = strrchr(s, '\n')) && nl[1] == '\0')
		*nl = '\0';
	line = strrchr(s, '\n');
	line = line ? line + 1 : s;
	if (!strncmp(line, "infilld: ", 9))
		line += 9;
	return line;
}

void api_upload_complete(struct api_req *r)
{
	struct upload *u = r->upload;
	struct api_server *s = r->srv;
	struct analyze_result res;
	struct mesh_rec m;
	char final_path[STORE_PATH_MAX], loc[96];
	json_error_t jerr;
	json_t *analysis = NULL;
	struct err e;
	struct db *db;
	enum problem p = PROB_INTERNAL;
	char detail[700] = "";
	int rc;

	err_clear(&e);
	if (u->file_bytes == 0) {
		p = PROB_INVALID_MESH;
		snprintf(detail, sizeof detail, "the upload is empty");
		goto fail;
	}
	if (api_analyze_run(&s->cfg, u->tmp, &res) != 0) {
		p = PROB_UNAVAILABLE;
		snprintf(detail, sizeof detail, "cannot start the mesh analysis");
		goto fail;
	}
	if (res.timed_out || res.signal || res.exit_code != 0) {
		p = PROB_INVALID_MESH;
		if (res.timed_out)
			snprintf(detail, sizeof detail, "reading the mesh took longer than %d s",
				 s->cfg.analyze_timeout_s);
		else if (res.signal)
			snprintf(detail, sizeof detail,
				 "reading the mesh crashed the reader (signal %d); the upload is refused",
				 res.signal);
		else
			snprintf(detail, sizeof detail, "%s", child_error(&res.err));
		api_analyze_result_fini(&res);
		goto fail;
	}
	analysis = json_loads((const char *)res.out.data, 0, &jerr);
	api_analyze_result_fini(&res);
	if (!analysis) {
		snprintf(detail, sizeof detail, "the mesh analysis printed no JSON");
		goto fail;
	}
	memset(&m, 0, sizeof m);
	snprintf(m.id, sizeof m.id, "%s", u->mesh_id);
	m.tenant_id = r->tenant.id;
	snprintf(m.name, sizeof m.name, "%s", u->name);
	snprintf(m.format, sizeof m.format, "%s", u->format);
	m.size_bytes = u->file_bytes;
	snprintf(m.sha256, sizeof m.sha256, "%s", u->sha_hex);
	m.analysis = json_dumps(analysis, JSON_COMPACT);
	m.created_ms = db_now_ms();
	json_decref(analysis);
	store_mesh_path(s->cfg.store_dir, r->tenant.id, m.id, m.format, final_path,
			sizeof final_path);
	if (!m.analysis || store_publish(u->tmp, final_path, &e)) {
		free(m.analysis);
		snprintf(detail, sizeof detail, "cannot store the mesh");
		log_msg(LOG_ERROR, "upload", "%s", e.msg);
		p = PROB_UNAVAILABLE;
		goto fail;
	}
	u->tmp[0] = '\0'; /* published: nothing to clean up */
	db = db_pool_get(s->pool);
	/* The quota is checked and charged here, in the transaction that
	 * records the mesh; the checks before and while reading the body only
	 * refuse early, from the usage as of the request's start. */
	if ((rc = db_mesh_add(db, &m, &e))) {
		struct tenant now;
		struct err e2;
		if (rc == ERR_LIMIT && db_tenant_get_id(db, r->tenant.id, &now, &e2) == 0)
			r->tenant = now; /* the refusal shows the usage that refused it */
		db_pool_put(s->pool, db);
		unlink(final_path);
		free(m.analysis);
		if (rc == ERR_LIMIT) {
			p = PROB_QUOTA;
			snprintf(detail, sizeof detail,
				 "the upload (%lld bytes) would take the tenant past its storage "
				 "quota of %lld bytes (%lld in use)",
				 (long long)m.size_bytes, (long long)r->tenant.quota_bytes,
				 (long long)r->tenant.used_bytes);
			goto fail;
		}
		log_msg(LOG_ERROR, "upload", "recording mesh: %s", e.msg);
		p = PROB_UNAVAILABLE;
		snprintf(detail, sizeof detail, "cannot record the mesh");
		goto fail;
	}
	db_pool_put(s->pool, db);
	r->pending = api_json_response(api_mesh_json(&m));
	free(m.analysis);
	if (r->pending) {
		snprintf(loc, sizeof loc, "/v1/meshes/%s", m.id);
		MHD_add_response_header(r->pending, MHD_HTTP_HEADER_LOCATION, loc);
	}
	r->pending_status = MHD_HTTP_CREATED;
	if (!r->pending) /* never leave the client without an answer */
		r->pending = api_problem_response(PROB_INTERNAL, r->url, NULL,
						  "the mesh is stored but its record could not be shown",
						  &r->pending_status);
	return;
fail:
	/* The reader names the temporary file; the client knows its own name. */
	store_redact(detail, sizeof detail, s->cfg.store_dir, u->tmp, u->name);
	r->pending = api_problem_response_members(p, r->url, NULL, detail,
						  api_problem_members(r, p), &r->pending_status);
}

json_t *api_mesh_json(const struct mesh_rec *m)
{
	char t[32], self[80];
	json_t *o, *a = m->analysis ? json_loads(m->analysis, 0, NULL) : NULL;

	snprintf(self, sizeof self, "/v1/meshes/%s", m->id);
	o = json_pack("{s:s, s:s, s:s, s:I, s:s, s:s, s:o, s:{s:s}}", "id", m->id, "name", m->name,
		      "format", m->format, "size_bytes", (json_int_t)m->size_bytes, "sha256",
		      m->sha256, "created_at", api_time(m->created_ms, t, sizeof t), "analysis",
		      a ? a : json_object(), "links", "self", self);
	return o;
}

enum MHD_Result api_mesh_get(struct api_req *r)
{
	struct mesh_rec m;
	struct err e;
	struct db *db;
	int rc;

	if (!db_id_valid("m_", r->arg[0]))
		return api_problem(r, PROB_NOT_FOUND, NULL, "no mesh '%s'", r->arg[0]);
	db = db_pool_get(r->srv->pool);
	rc = db_mesh_get(db, r->tenant.id, r->arg[0], &m, &e);
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no mesh '%s'", r->arg[0]);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	{
		json_t *j = api_mesh_json(&m);
		db_mesh_rec_fini(&m);
		return api_json(r, MHD_HTTP_OK, j);
	}
}

/* Cursor for meshes: "<created ms>.<id>". */
enum MHD_Result api_mesh_list(struct api_req *r)
{
	const char *lim = api_query(r, "limit"), *cur = api_query(r, "cursor");
	int limit = lim ? atoi(lim) : 50, n, more, rc;
	int64_t before_ms = 0;
	char before_id[DB_ID_MAX] = "";
	struct mesh_rec *v;
	struct err e;
	struct db *db;
	json_t *arr, *o;

	if (lim && (limit < 1 || limit > 1000 || strspn(lim, "0123456789") != strlen(lim)))
		return api_problem(r, PROB_INVALID_PARAM, "limit", "limit must be 1..1000");
	if (cur) {
		char *dot;
		before_ms = strtoll(cur, &dot, 10);
		if (*dot != '.' || before_ms <= 0 || !db_id_valid("m_", dot + 1))
			return api_problem(r, PROB_INVALID_PARAM, "cursor", "malformed cursor");
		snprintf(before_id, sizeof before_id, "%s", dot + 1);
	}
	db = db_pool_get(r->srv->pool);
	rc = db_mesh_list(db, r->tenant.id, before_ms, before_id, limit, &v, &n, &more, &e);
	db_pool_put(r->srv->pool, db);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	arr = json_array();
	for (int i = 0; i < n; i++)
		json_array_append_new(arr, api_mesh_json(&v[i]));
	o = json_pack("{s:o}", "meshes", arr);
	if (more && n > 0) {
		char c[64];
		snprintf(c, sizeof c, "%lld.%s", (long long)v[n - 1].created_ms, v[n - 1].id);
		json_object_set_new(o, "next_cursor", json_string(c));
	} else {
		json_object_set_new(o, "next_cursor", json_null());
	}
	db_mesh_recs_free(v, n);
	return api_json(r, MHD_HTTP_OK, o);
}

enum MHD_Result api_mesh_delete(struct api_req *r)
{
	struct mesh_rec m;
	char path[STORE_PATH_MAX];
	struct err e;
	struct db *db;
	int rc;

	if (!db_id_valid("m_", r->arg[0]))
		return api_problem(r, PROB_NOT_FOUND, NULL, "no mesh '%s'", r->arg[0]);
	db = db_pool_get(r->srv->pool);
	rc = db_mesh_delete(db, r->tenant.id, r->arg[0], &m, &e);
	db_pool_put(r->srv->pool, db);
	if (rc == ERR_NOTFOUND)
		return api_problem(r, PROB_NOT_FOUND, NULL, "no mesh '%s'", r->arg[0]);
	if (rc == ERR_LIMIT)
		return api_problem(r, PROB_CONFLICT, NULL, "%s", e.msg);
	if (rc)
		return api_problem(r, PROB_UNAVAILABLE, NULL, "%s", e.msg);
	store_mesh_path(r->srv->cfg.store_dir, r->tenant.id, m.id, m.format, path, sizeof path);
	unlink(path);
	db_mesh_rec_fini(&m);
	return api_queue(r, MHD_HTTP_NO_CONTENT,
			 MHD_create_response_from_buffer(0, NULL, MHD_RESPMEM_PERSISTENT));
}
