/* stream.c - streaming a binary lattice file as z-sorted struts (strut.h).
 *
 * Two cursors walk the file: one over the edge section, one over the node
 * section.  Edges come sorted by their lower node a (and a < b), nodes by
 * z, so every edge needs only nodes with index in [a, b]: a ring buffer
 * holds the nodes from the current edge's a up to the largest b seen.  Its
 * size is the number of nodes within one strut length in z (a slab), not
 * the file's node count.  Memory: two 1 MiB read buffers plus the window.
 */
#include "engine/lattice/binfmt.h"
#include "engine/lattice/strut.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sys/stat.h>
#include <unistd.h>

/* A window wider than this many nodes means one strut spans most of a
 * huge file: refuse instead of holding the file in memory. */
#define STREAM_MAX_WINDOW (1u << 26)

struct lattice_stream {
	int fd;
	struct lattice_file_header h;
	struct latbin_cursor nodes, edges;
	uint64_t nodes_read; /* nodes taken from the node cursor */
	uint64_t edges_read;
	float last_z;
	uint32_t last_a;
	float *win;  /* ring of nodes [base, base + count), 3 floats each */
	size_t cap;  /* power of two */
	uint64_t base, count;
	size_t peak;
};

int lattice_stream_open(const char *path, struct lattice_file_header *hdr,
			struct lattice_stream **out, struct err *e)
{
	struct lattice_stream *st;
	unsigned char hb[LATBIN_HEADER_BYTES];
	struct stat sb;
	int rc;

	st = mem_calloc(1, sizeof *st);
	if (!st)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	st->fd = open(path, O_RDONLY | O_CLOEXEC);
	if (st->fd < 0) {
		rc = ERR_SET(e, ERR_IO, "cannot open %s: %s", path, strerror(errno));
		goto fail;
	}
	if (fstat(st->fd, &sb) != 0 || !S_ISREG(sb.st_mode)) {
		rc = ERR_SET(e, ERR_IO, "%s is not a regular file", path);
		goto fail;
	}
	if ((uint64_t)sb.st_size < LATBIN_HEADER_BYTES ||
	    pread(st->fd, hb, sizeof hb, 0) != (ssize_t)sizeof hb) {
		rc = ERR_PLACE(e, ERR_PARSE, 0, 0, -1, "file too short for a lattice header");
		goto fail;
	}
	if ((rc = latbin_header_decode(hb, (uint64_t)sb.st_size, &st->h, e)) != 0)
		goto fail;
	if (latbin_cursor_init(&st->nodes, st->fd, LATBIN_HEADER_BYTES, 1u << 20) ||
	    latbin_cursor_init(&st->edges, st->fd,
			       LATBIN_HEADER_BYTES + st->h.nnodes * LATBIN_NODE_BYTES, 1u << 20)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto fail;
	}
	st->cap = 1024;
	st->win = mem_alloc(st->cap * 3 * sizeof(float));
	if (!st->win) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto fail;
	}
	st->last_z = -INFINITY;
	if (hdr)
		*hdr = st->h;
	*out = st;
	return 0;
fail:
	lattice_stream_free(st);
	err_prefix(e, "reading %s", path);
	return rc;
}

void lattice_stream_free(struct lattice_stream *st)
{
	if (!st)
		return;
	latbin_cursor_fini(&st->nodes);
	latbin_cursor_fini(&st->edges);
	if (st->fd >= 0)
		close(st->fd);
	mem_free(st->win);
	mem_free(st);
}

size_t lattice_stream_window_peak(const struct lattice_stream *st)
{
	return st->peak;
}

/* Double the ring, keeping [base, base + count) at their slots mod cap. */
static int grow_window(struct lattice_stream *st, struct err *e)
{
	size_t ncap = st->cap * 2;
	float *nw;

	if (ncap > STREAM_MAX_WINDOW)
		return ERR_SET(e, ERR_LIMIT,
			       "a strut spans more than %u nodes in z order; the file cannot be "
			       "streamed",
			       STREAM_MAX_WINDOW);
	nw = mem_alloc(ncap * 3 * sizeof(float));
	if (!nw)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the node window");
	for (uint64_t i = st->base; i < st->base + st->count; i++)
		memcpy(nw + 3 * (i & (ncap - 1)), st->win + 3 * (i & (st->cap - 1)),
		       3 * sizeof(float));
	mem_free(st->win);
	st->win = nw;
	st->cap = ncap;
	return 0;
}

/* Read one more node into the window (at index base + count). */
static int load_node(struct lattice_stream *st, struct err *e)
{
	uint64_t at = latbin_cursor_tell(&st->nodes);
	const unsigned char *p;
	float *w;
	int rc;

	if (st->count == st->cap && (rc = grow_window(st, e)) != 0)
		return rc;
	if (!(p = latbin_cursor_take(&st->nodes, LATBIN_NODE_BYTES, e)))
		return e ? e->code : ERR_PARSE;
	w = st->win + 3 * ((st->base + st->count) & (st->cap - 1));
	w[0] = latbin_get_f32(p);
	w[1] = latbin_get_f32(p + 4);
	w[2] = latbin_get_f32(p + 8);
	if (!isfinite(w[0]) || !isfinite(w[1]) || !isfinite(w[2]))
		return ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)st->nodes_read,
				 "node %llu: non-finite coordinate",
				 (unsigned long long)st->nodes_read);
	if (w[2] < st->last_z)
		return ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)st->nodes_read,
				 "node %llu: z %g below the previous node's %g (nodes must be "
				 "sorted by z)",
				 (unsigned long long)st->nodes_read, (double)w[2],
				 (double)st->last_z);
	st->last_z = w[2];
	st->nodes_read++;
	st->count++;
	if (st->count > st->peak)
		st->peak = (size_t)st->count;
	return 0;
}

static int stream_next(void *ctx, struct lattice_strut *s, struct err *e)
{
	struct lattice_stream *st = ctx;
	const unsigned char *p;
	uint64_t at, i = st->edges_read;
	uint32_t a, b;
	uint16_t r;
	const float *pa, *pb;
	int rc;

	if (i >= st->h.nedges)
		return 0;
	at = latbin_cursor_tell(&st->edges);
	if (!(p = latbin_cursor_take(&st->edges, LATBIN_EDGE_BYTES, e)))
		return e ? e->code : ERR_PARSE;
	a = latbin_get_u32(p);
	b = latbin_get_u32(p + 4);
	r = latbin_get_u16(p + 8);
	if (!(a < b) || b >= st->h.nnodes || latbin_radius(&st->h, r, &s->radius_mm) != 0)
		return ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				 "edge %llu: nodes %u, %u / radius code %u invalid (need a < b < "
				 "%llu, 0 < radius <= the header's largest, below the support)",
				 (unsigned long long)i, a, b, r, (unsigned long long)st->h.nnodes);
	if (a < st->last_a)
		return ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				 "edge %llu: lower node %u after %u (edges must be sorted)",
				 (unsigned long long)i, a, st->last_a);
	st->last_a = a;
	/* Slide the window: nodes below a are never needed again. */
	if (a > st->base) {
		uint64_t drop = a - st->base;
		if (drop >= st->count) {
			/* Skip nodes no edge references, still checking their
			 * order (invariant: nodes_read == base + count). */
			st->base += st->count;
			st->count = 0;
			while (st->nodes_read < a) {
				if ((rc = load_node(st, e)) != 0)
					return rc;
				st->base++;
				st->count--;
			}
		} else {
			st->base = a;
			st->count -= drop;
		}
	}
	while (st->base + st->count <= b)
		if ((rc = load_node(st, e)) != 0)
			return rc;
	pa = st->win + 3 * (a & (st->cap - 1));
	pb = st->win + 3 * (b & (st->cap - 1));
	memcpy(s->a, pa, sizeof s->a);
	memcpy(s->b, pb, sizeof s->b);
	st->edges_read++;
	return 1;
}

struct lattice_source lattice_stream_source(struct lattice_stream *st)
{
	struct lattice_source src = {stream_next, st};
	return src;
}
