/* lattice.h - lattice graphs (nodes, struts with radii) and their files.
 *
 * A lattice Q = (V, E) is a weighted graph: node positions (mm) and edges
 * (struts) each with a radius.  The solid is the convolution surface of
 * kernel.h with support R = support_mm; a strut's weight is derived from
 * its radius through lattice_weight_for_radius(), so a file never stores
 * weights and the isovalue C only scales them (the shape does not depend
 * on C).  File formats (binary, streamable; text) are specified in
 * docs/lattice.md section 5.
 */
#ifndef INFILLD_LATTICE_H
#define INFILLD_LATTICE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;
struct sink;

struct lattice_edge {
	uint32_t a, b;   /* node indices, a != b */
	float radius_mm; /* realised radius of an isolated long strut, > 0 */
};

struct lattice {
	struct vec3 *node; /* owned */
	size_t nnodes, node_cap;
	struct lattice_edge *edge; /* owned */
	size_t nedges, edge_cap;
	double support_mm; /* kernel support R; 0 = derive from radii (factor x max) */
};

/* Hard caps applied by readers (and generation) before allocating. */
#define LATTICE_MAX_NODES 2000000000u
#define LATTICE_MAX_EDGES 4000000000u
/* In-memory loads (text files, lattice_read) stop earlier than the
 * streamable binary format, which has no size limit beyond these caps. */
#define LATTICE_MAX_INCORE_EDGES 200000000u

/* Empty lattice; caller frees with lattice_free() (NULL-safe). */
struct lattice *lattice_new(void);
void lattice_free(struct lattice *q);
void lattice_clear(struct lattice *q);
/* Append; 0 or ERR_NOMEM / ERR_LIMIT. */
int lattice_add_node(struct lattice *q, struct vec3 p);
/* Append a strut between existing nodes a != b; ERR_PARAM on bad input. */
int lattice_add_edge(struct lattice *q, uint32_t a, uint32_t b, double radius_mm);
int lattice_reserve(struct lattice *q, size_t nnodes, size_t nedges);

/* Bounding box of the nodes (empty box when there are none). */
struct box3 lattice_bbox(const struct lattice *q);
double lattice_max_radius(const struct lattice *q);
double lattice_total_length(const struct lattice *q);
/* Support R actually used: support_mm if > 0, else factor * max radius. */
double lattice_support(const struct lattice *q, double factor);

/* ---- files ---- */

enum lattice_file_kind {
	LATTICE_FILE_NONE = 0, /* not a lattice file */
	LATTICE_FILE_BINARY,
	LATTICE_FILE_TEXT
};

/* Kind of the file at path by its first bytes (never by name).  Unreadable
 * files are LATTICE_FILE_NONE. */
enum lattice_file_kind lattice_file_probe(const char *path);
/* Same from a buffer holding at least the file's first 64 bytes (or all
 * of it when shorter). */
enum lattice_file_kind lattice_file_probe_buffer(const void *data, size_t len);

/* Write q to path in the binary format: nodes sorted by z, edges sorted by
 * their lower node; coordinates become float32 and radii 16-bit
 * quantised (docs/lattice.md 5.1).  O(n log n) in memory. */
int lattice_write_binary(const struct lattice *q, const char *path, struct err *e);

/* Write q as text (node and edge order kept, full precision). */
int lattice_write_text(const struct lattice *q, struct sink *s, struct err *e);

/* Read a binary or text lattice file completely into memory (at most
 * LATTICE_MAX_INCORE_EDGES struts).  Every count is checked against the
 * file size before allocation; errors name the byte offset or line and
 * the node/edge index.  Caller frees *out. */
int lattice_read(const char *path, struct lattice **out, struct err *e);
int lattice_read_buffer(const void *data, size_t len, struct lattice **out, struct err *e);

/* Header of a binary file, as stored. */
struct lattice_file_header {
	uint64_t nnodes, nedges;
	double support_mm;
	double radius_quantum_mm; /* radius = q * quantum */
	double max_radius_mm;
	struct box3 bbox;         /* of the nodes, mm */
};

/* Streaming writer of the binary format for producers that already emit
 * nodes in non-decreasing z and then edges in non-decreasing lower node
 * (a < b, z(a) <= z(b)); counts are fixed up at close.  Order violations
 * are ERR_PARAM (the file is then unusable).  max_radius_mm fixes the
 * radius quantum; larger radii are refused.  Memory O(1). */
struct lattice_writer;
int lattice_writer_open(const char *path, double support_mm, double max_radius_mm,
			struct lattice_writer **out, struct err *e);
int lattice_writer_node(struct lattice_writer *w, struct vec3 p, struct err *e);
/* First edge call ends the node section. */
int lattice_writer_edge(struct lattice_writer *w, uint32_t a, uint32_t b, double radius_mm,
			struct err *e);
/* Flush, write the header; 0 or an error.  Frees w in every case. */
int lattice_writer_close(struct lattice_writer *w, struct err *e);
/* Abandon (error paths): frees w, removes nothing. NULL-safe. */
void lattice_writer_abort(struct lattice_writer *w);

#endif
