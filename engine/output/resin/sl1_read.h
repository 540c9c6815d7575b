/* sl1_read.h - internal: reading one layer image back out of a written
 * SL1/SL1S archive or PNG-stack zip (the layer preview of
 * out_layer_png(), engine/output/preview.c).  Not included outside
 * engine/output/.  Layout of the archives: docs/formats.md.
 */
#ifndef INFILLD_SL1_READ_H
#define INFILLD_SL1_READ_H

#include "engine/core/sink.h"

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

#endif
