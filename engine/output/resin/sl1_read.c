/* sl1_read.c - sl1_read_layer(): one layer PNG of a written resin archive,
 * read back with libarchive's seekable zip reader (it walks the central
 * directory, so finding layer k and counting the layers costs one pass
 * over the entry headers, not over the data).  Layer names are those
 * sl1.c writes: "<jobDir>%05d.png" (SL1, SL1S), "%d.png" from 1 (zip).
 */
#include "engine/output/resin/resin.h"

#include <archive.h>
#include <archive_entry.h>
#include <string.h>

#include "engine/core/err.h"

/* The layer index an entry name stands for, or -1 when it is no layer:
 * a root-level *.png whose name ends in 5 digits (SL1; the jobDir before
 * them may end in digits too) or is all digits (zip, counted from 1). */
static long layer_index(const char *name, int sl1_layout)
{
	size_t n = strlen(name), d = 0;
	long v = 0;

	if (n < 5 || strcmp(name + n - 4, ".png") != 0 || strchr(name, '/'))
		return -1;
	n -= 4;
	while (d < n && d < 9 && name[n - d - 1] >= '0' && name[n - d - 1] <= '9')
		d++;
	if (sl1_layout) {
		if (d < 5)
			return -1;
		d = 5;
	} else if (d != n || d == 0) {
		return -1;
	}
	for (size_t i = n - d; i < n; i++)
		v = v * 10 + (name[i] - '0');
	return sl1_layout ? v : v - 1;
}

int sl1_read_layer(const char *path, int sl1_layout, int k, struct buf *png, int *count,
		   struct err *e)
{
	struct archive *a = archive_read_new();
	struct archive_entry *ent;
	size_t len0 = png->len;
	int rc = 0, r, n = 0, found = 0;

	if (!a)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening %s", path);
	archive_read_support_format_zip_seekable(a);
	if (archive_read_open_filename(a, path, 1 << 16) != ARCHIVE_OK) {
		rc = ERR_SET(e, ERR_IO, "cannot open %s: %s", path, archive_error_string(a));
		goto out;
	}
	while ((r = archive_read_next_header(a, &ent)) == ARCHIVE_OK) {
		const char *name = archive_entry_pathname(ent);
		la_int64_t size = archive_entry_size(ent);
		long idx;

		if (!name || archive_entry_filetype(ent) != AE_IFREG ||
		    (idx = layer_index(name, sl1_layout)) < 0)
			continue;
		n++;
		if (idx != k || found)
			continue;
		if (size <= 0 || (unsigned long long)size > SL1_READ_ENTRY_MAX) {
			rc = ERR_SET(e, ERR_LIMIT, "layer %s has %lld bytes (at most %u)", name,
				     (long long)size, SL1_READ_ENTRY_MAX);
			goto out;
		}
		for (;;) {
			char chunk[16384];
			la_ssize_t got = archive_read_data(a, chunk, sizeof chunk);
			if (got < 0) {
				rc = ERR_SET(e, ERR_PARSE, "reading %s in %s: %s", name, path,
					     archive_error_string(a));
				goto out;
			}
			if (got == 0)
				break;
			if (png->len - len0 + (size_t)got > (size_t)size) {
				rc = ERR_SET(e, ERR_PARSE, "%s in %s is longer than its header says",
					     name, path);
				goto out;
			}
			if ((rc = buf_append(png, chunk, (size_t)got))) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory reading %s", name);
				goto out;
			}
		}
		if (png->len - len0 != (size_t)size) {
			rc = ERR_SET(e, ERR_PARSE, "%s in %s is truncated", name, path);
			goto out;
		}
		found = 1;
	}
	if (r != ARCHIVE_EOF) {
		rc = ERR_SET(e, ERR_PARSE, "%s: %s", path, archive_error_string(a));
		goto out;
	}
	*count = n;
	if (!found)
		rc = ERR_SET(e, ERR_NOTFOUND, "no layer %d: the archive has %d layers (0..%d)", k, n,
			     n - 1);
out:
	archive_read_free(a);
	if (rc)
		png->len = len0;
	return rc;
}
