/* zipstream.c - streaming zip archives through libarchive (see
 * resin.h).  libarchive calls zip_write_cb() with its output blocks;
 * the callback forwards them to the sink and keeps the sink's error
 * record, which is what callers get back instead of libarchive's text.
 */
#include "engine/output/resin/resin.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"

#include <archive.h>
#include <archive_entry.h>
#include <errno.h>
#include <string.h>

#define ZIP_BLOCK_BYTES (64 * 1024)

struct out_zip {
	struct archive *a;
	struct archive_entry *ent; /* reused for every entry */
	struct sink *s;
	time_t mtime;
	uint64_t entries;
	int failed;      /* first failure (negative err_code), 0 if none */
	struct err ferr; /* its record */
	int abandoned;   /* freed before close: write nothing more */
	int closed;
};

static la_ssize_t zip_write_cb(struct archive *a, void *ctx, const void *buf, size_t len)
{
	struct out_zip *z = ctx;
	int rc;

	if (z->abandoned) {
		archive_set_error(a, ECANCELED, "archive abandoned");
		return -1;
	}
	if (z->failed) {
		archive_set_error(a, EIO, "%s", z->ferr.msg);
		return -1;
	}
	rc = sink_write(z->s, buf, len, &z->ferr);
	if (rc) {
		z->failed = rc;
		archive_set_error(a, EIO, "%s", z->ferr.msg);
		return -1;
	}
	return (la_ssize_t)len;
}

/* Record and return a failure of libarchive call `what`. */
static int zip_fail(struct out_zip *z, const char *what, struct err *e)
{
	if (!z->failed) {
		int code = archive_errno(z->a) == ENOMEM ? ERR_NOMEM : ERR_IO;
		const char *msg = archive_error_string(z->a);
		z->failed = code;
		err_clear(&z->ferr);
		ERR_SET(&z->ferr, code, "zip %s: %s", what, msg ? msg : "libarchive failed");
	}
	if (e)
		*e = z->ferr;
	return z->failed;
}

int out_zip_new(struct sink *s, time_t mtime, struct out_zip **out, struct err *e)
{
	struct out_zip *z = mem_calloc(1, sizeof *z);
	int rc;

	if (!z)
		return ERR_SET(e, ERR_NOMEM, "out of memory starting a zip archive");
	z->s = s;
	z->mtime = mtime;
	z->a = archive_write_new();
	z->ent = archive_entry_new();
	if (!z->a || !z->ent) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory starting a zip archive");
		goto fail;
	}
	if (archive_write_set_format_zip(z->a) != ARCHIVE_OK ||
	    archive_write_zip_set_compression_store(z->a) != ARCHIVE_OK ||
	    archive_write_set_bytes_per_block(z->a, ZIP_BLOCK_BYTES) != ARCHIVE_OK ||
	    archive_write_set_bytes_in_last_block(z->a, 1) != ARCHIVE_OK) {
		rc = zip_fail(z, "setup", e);
		goto fail;
	}
	if (archive_write_open(z->a, z, NULL, zip_write_cb, NULL) != ARCHIVE_OK) {
		rc = zip_fail(z, "open", e);
		goto fail;
	}
	*out = z;
	return 0;
fail:
	z->abandoned = 1;
	out_zip_free(z);
	return rc;
}

int out_zip_add(struct out_zip *z, const char *name, const void *data, size_t len,
		struct err *e)
{
	la_ssize_t n;

	if (z->failed) {
		if (e)
			*e = z->ferr;
		return z->failed;
	}
	if (z->closed)
		return ERR_SET(e, ERR_INTERNAL, "zip entry %s added after close", name);
	archive_entry_clear(z->ent);
	archive_entry_set_pathname(z->ent, name);
	archive_entry_set_filetype(z->ent, AE_IFREG);
	archive_entry_set_perm(z->ent, 0644);
	archive_entry_set_size(z->ent, (la_int64_t)len);
	archive_entry_set_mtime(z->ent, z->mtime, 0);
	if (archive_write_header(z->a, z->ent) < ARCHIVE_WARN)
		return zip_fail(z, "header", e);
	n = len ? archive_write_data(z->a, data, len) : 0;
	if (n < 0 || (size_t)n != len)
		return zip_fail(z, "data", e);
	if (archive_write_finish_entry(z->a) < ARCHIVE_WARN)
		return zip_fail(z, "entry", e);
	z->entries++;
	return 0;
}

int out_zip_close(struct out_zip *z, struct err *e)
{
	if (z->failed) {
		if (e)
			*e = z->ferr;
		return z->failed;
	}
	if (z->closed)
		return 0;
	if (archive_write_close(z->a) != ARCHIVE_OK)
		return zip_fail(z, "close", e);
	z->closed = 1;
	return 0;
}

uint64_t out_zip_entries(const struct out_zip *z)
{
	return z->entries;
}

void out_zip_free(struct out_zip *z)
{
	if (!z)
		return;
	if (!z->closed)
		z->abandoned = 1;
	if (z->a)
		archive_write_free(z->a); /* closes: refused by zip_write_cb when abandoned */
	archive_entry_free(z->ent);
	mem_free(z);
}
