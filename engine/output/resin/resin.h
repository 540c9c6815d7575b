/* resin.h - what engine/output/resin/ offers the rest of the engine:
 * reading layers back from a resin archive and the streaming zip writer;
 * one section per file below.  The archive's text records are internal
 * (resin_int.h). */
#ifndef INFILLD_OUTPUT_RESIN_H
#define INFILLD_OUTPUT_RESIN_H

#include <stddef.h>
#include <stdint.h>
#include <time.h>

#include "engine/core/sink.h"

/* ---- sl1_read.c: reading one layer image back out of a written
 * SL1/SL1S archive or PNG-stack zip (the layer preview of
 * out_layer_png(), engine/output/preview.c).  Not included outside
 * engine/output/.  Layout of the archives: docs/formats.md.
 */
struct err;

/* Append layer k's PNG (0 = first printed layer), byte for byte as the
 * archive at path stores it, to png, and set *count to the number of
 * layer images in the archive.  sl1_layout: 1 for SL1/SL1S names
 * ("<jobDir>NNNNN.png", NNNNN = k), 0 for the zip stack ("<k+1>.png").
 * Entries under thumbnail/ or in folders are not layers.  Returns 0,
 * ERR_NOTFOUND when no layer k exists (*count is still set), ERR_IO /
 * ERR_PARSE for an unreadable archive, ERR_LIMIT for an entry over
 * SL1_READ_ENTRY_MAX bytes, ERR_NOMEM.  On failure png->len is unchanged.
 * Reads only the archive's directory and the one entry. */
#define SL1_READ_ENTRY_MAX (64u << 20)
int sl1_read_layer(const char *path, int sl1_layout, int k, struct buf *png, int *count,
		   struct err *e);

/* ---- zipstream.c: a streaming zip archive on a struct sink.
 *
 * libarchive's zip writer behind a sink: entries are stored (the PNGs in
 * them are already deflated), each followed by a data descriptor (the
 * CRC is computed while streaming), and Zip64 records appear when an
 * entry, the entry count or the archive outgrows the classic limits.
 * Memory: one 64 KiB output block plus the central directory (about 100
 * bytes per entry), whatever the entry sizes.  Not included outside
 * engine/output/.
 */
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
