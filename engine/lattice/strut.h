/* strut.h - z-sorted strut streams: the slicer's input.
 *
 * The streaming slicer (slicer.h) consumes struts in non-decreasing order
 * of their lower z.  Two producers: a binary lattice file, streamed with
 * a sliding window of nodes (memory bounded by the nodes of one strut
 * length of height, never the whole file), and the external sorter, which
 * takes struts in any order, sorts runs of at most budget_bytes in memory
 * and spills them to one unlinked temporary file, then merges the runs.
 * Design: docs/lattice.md section 6.
 */
#ifndef INFILLD_LATTICE_STRUT_H
#define INFILLD_LATTICE_STRUT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/lattice/lattice.h"

struct err;

/* One strut, self-contained (28 bytes); a[2] <= b[2] (a is the lower end). */
struct lattice_strut {
	float a[3], b[3]; /* mm */
	float radius_mm;
};

/* Pull interface: next() returns 1 with *s filled, 0 at the end, or a
 * negative err_code.  Struts come in non-decreasing a[2]. */
struct lattice_source {
	int (*next)(void *ctx, struct lattice_strut *s, struct err *e);
	void *ctx;
};

/* Orient (lower end first) and convert to float. */
void lattice_strut_make(struct lattice_strut *s, struct vec3 p, struct vec3 q, double radius_mm);

/* ---- external sorter ---- */
struct lattice_sorter;

/* budget_bytes: memory for one run (>= 1 MiB is sensible; smaller values
 * are raised to 64 records so tests can force many runs).  tmp_dir: where
 * the spill file goes (NULL = $TMPDIR or /tmp).  Caller frees. */
int lattice_sorter_new(size_t budget_bytes, const char *tmp_dir, struct lattice_sorter **out,
		       struct err *e);
void lattice_sorter_free(struct lattice_sorter *s);
int lattice_sorter_add(struct lattice_sorter *s, const struct lattice_strut *st, struct err *e);
/* All struts of an in-memory lattice. */
int lattice_sorter_add_lattice(struct lattice_sorter *s, const struct lattice *q, struct err *e);
/* End input; afterwards the sorter is a source (lattice_sorter_source). */
int lattice_sorter_finish(struct lattice_sorter *s, struct err *e);
struct lattice_source lattice_sorter_source(struct lattice_sorter *s);
/* Runs spilled to disk (0 = the whole input fit in memory). */
size_t lattice_sorter_runs(const struct lattice_sorter *s);
uint64_t lattice_sorter_count(const struct lattice_sorter *s);

/* ---- binary file stream ---- */
struct lattice_stream;

/* Open a binary lattice file for streaming; validates the header against
 * the file size.  *hdr (may be NULL) receives the header.  Order and index
 * violations in the body are reported when reached (ERR_PARSE with the
 * byte offset and edge/node index).  Caller frees. */
int lattice_stream_open(const char *path, struct lattice_file_header *hdr,
			struct lattice_stream **out, struct err *e);
void lattice_stream_free(struct lattice_stream *st);
struct lattice_source lattice_stream_source(struct lattice_stream *st);
/* Largest node window held so far (nodes), for memory reports. */
size_t lattice_stream_window_peak(const struct lattice_stream *st);

#endif
