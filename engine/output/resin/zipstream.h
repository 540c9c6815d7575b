/* zipstream.h - internal: a streaming zip archive on a struct sink.
 *
 * libarchive's zip writer behind a sink: entries are stored (the PNGs in
 * them are already deflated), each followed by a data descriptor (the
 * CRC is computed while streaming), and Zip64 records appear when an
 * entry, the entry count or the archive outgrows the classic limits.
 * Memory: one 64 KiB output block plus the central directory (about 100
 * bytes per entry), whatever the entry sizes.  Not included outside
 * engine/output/.
 */
#ifndef INFILLD_ZIPSTREAM_H
#define INFILLD_ZIPSTREAM_H

#include <stddef.h>
#include <stdint.h>
#include <time.h>

struct err;
struct sink;
struct out_zip;

/* Start an archive on s (borrowed until out_zip_free).  mtime: the
 * timestamp of every entry.  Caller frees with out_zip_free(). */
int out_zip_new(struct sink *s, time_t mtime, struct out_zip **out, struct err *e);

/* Append the stored entry `name` holding len bytes of data.  A failure
 * (the sink's error, e.g. ERR_IO or ERR_LIMIT, or ERR_NOMEM) is final:
 * every later call returns it. */
int out_zip_add(struct out_zip *z, const char *name, const void *data, size_t len,
		struct err *e);

/* Write the central directory and end records. */
int out_zip_close(struct out_zip *z, struct err *e);

/* Entries added so far. */
uint64_t out_zip_entries(const struct out_zip *z);

/* Release.  An archive not closed is abandoned: nothing more reaches the
 * sink, so a cancelled job leaves a truncated, unreadable archive rather
 * than one that looks complete.  NULL-safe. */
void out_zip_free(struct out_zip *z);

#endif
