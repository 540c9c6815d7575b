/* file_bin.c - the binary lattice format: header codec, writers, full reader.
 *
 * Layout in binfmt.h and docs/lattice.md 5.1.  Writers: in-core (sorts an
 * arbitrary lattice, O(n log n)) and streaming (validates a producer that
 * is already sorted, O(1) memory).  The streaming reader for slicing is
 * in stream.c.
 */
#include "engine/lattice/binfmt.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

void latbin_header_encode(unsigned char *b, const struct lattice_file_header *h)
{
	memset(b, 0, LATBIN_HEADER_BYTES);
	memcpy(b, LATBIN_MAGIC, 8);
	latbin_put_u32(b + 8, LATBIN_VERSION);
	latbin_put_u32(b + 12, LATBIN_HEADER_BYTES);
	latbin_put_u64(b + 16, h->nnodes);
	latbin_put_u64(b + 24, h->nedges);
	latbin_put_f64(b + 32, h->support_mm);
	latbin_put_f64(b + 40, h->radius_quantum_mm);
	latbin_put_f64(b + 48, h->max_radius_mm);
	latbin_put_f64(b + 56, h->bbox.lo.x);
	latbin_put_f64(b + 64, h->bbox.lo.y);
	latbin_put_f64(b + 72, h->bbox.lo.z);
	latbin_put_f64(b + 80, h->bbox.hi.x);
	latbin_put_f64(b + 88, h->bbox.hi.y);
	latbin_put_f64(b + 96, h->bbox.hi.z);
	latbin_put_u32(b + 104, 0);                 /* flags */
	latbin_put_u32(b + 108, LATBIN_NODE_BYTES); /* record sizes, for readers */
	latbin_put_u32(b + 112, LATBIN_EDGE_BYTES);
}

int latbin_header_decode(const unsigned char *b, uint64_t file_size,
			 struct lattice_file_header *h, struct err *e)
{
	uint64_t need;

	if (memcmp(b, LATBIN_MAGIC, 8) != 0)
		return ERR_PLACE(e, ERR_PARSE, 0, 0, -1, "not a binary lattice file (bad magic)");
	if (latbin_get_u32(b + 8) != LATBIN_VERSION)
		return ERR_PLACE(e, ERR_PARSE, 8, 0, -1, "unsupported lattice format version %u",
				 (unsigned)latbin_get_u32(b + 8));
	if (latbin_get_u32(b + 12) != LATBIN_HEADER_BYTES ||
	    latbin_get_u32(b + 108) != LATBIN_NODE_BYTES ||
	    latbin_get_u32(b + 112) != LATBIN_EDGE_BYTES)
		return ERR_PLACE(e, ERR_PARSE, 12, 0, -1, "unexpected header or record size");
	if (latbin_get_u32(b + 104) != 0)
		return ERR_PLACE(e, ERR_PARSE, 104, 0, -1, "unknown flags 0x%x",
				 (unsigned)latbin_get_u32(b + 104));
	h->nnodes = latbin_get_u64(b + 16);
	h->nedges = latbin_get_u64(b + 24);
	h->support_mm = latbin_get_f64(b + 32);
	h->radius_quantum_mm = latbin_get_f64(b + 40);
	h->max_radius_mm = latbin_get_f64(b + 48);
	h->bbox.lo = v3(latbin_get_f64(b + 56), latbin_get_f64(b + 64), latbin_get_f64(b + 72));
	h->bbox.hi = v3(latbin_get_f64(b + 80), latbin_get_f64(b + 88), latbin_get_f64(b + 96));
	if (h->nnodes > LATTICE_MAX_NODES || h->nedges > LATTICE_MAX_EDGES)
		return ERR_PLACE(e, ERR_PARSE, 16, 0, -1,
				 "node/edge count %llu/%llu exceeds the limits %u/%u",
				 (unsigned long long)h->nnodes, (unsigned long long)h->nedges,
				 LATTICE_MAX_NODES, LATTICE_MAX_EDGES);
	need = LATBIN_HEADER_BYTES + h->nnodes * LATBIN_NODE_BYTES + h->nedges * LATBIN_EDGE_BYTES;
	if (need != file_size)
		return ERR_PLACE(e, ERR_PARSE, 16, 0, -1,
				 "header promises %llu nodes and %llu edges (%llu bytes) but the "
				 "file has %llu bytes",
				 (unsigned long long)h->nnodes, (unsigned long long)h->nedges,
				 (unsigned long long)need, (unsigned long long)file_size);
	if (!isfinite(h->support_mm) || h->support_mm < 0)
		return ERR_PLACE(e, ERR_PARSE, 32, 0, -1, "support_mm must be finite and >= 0");
	if (!isfinite(h->radius_quantum_mm) || !(h->radius_quantum_mm > 0) ||
	    !isfinite(h->max_radius_mm) || h->max_radius_mm < 0 ||
	    h->max_radius_mm > h->radius_quantum_mm * LATBIN_QMAX * (1 + 1e-9))
		return ERR_PLACE(e, ERR_PARSE, 40, 0, -1,
				 "radius quantum %g / max radius %g mm are inconsistent",
				 h->radius_quantum_mm, h->max_radius_mm);
	if (h->support_mm > 0 && h->max_radius_mm >= h->support_mm)
		return ERR_PLACE(e, ERR_PARSE, 48, 0, -1,
				 "max radius %g mm is not below the support %g mm",
				 h->max_radius_mm, h->support_mm);
	if (h->nnodes > 0 && !(isfinite(h->bbox.lo.x) && isfinite(h->bbox.lo.y) &&
			       isfinite(h->bbox.lo.z) && isfinite(h->bbox.hi.x) &&
			       isfinite(h->bbox.hi.y) && isfinite(h->bbox.hi.z)))
		return ERR_PLACE(e, ERR_PARSE, 56, 0, -1, "bounding box is not finite");
	return 0;
}

uint16_t latbin_quantise(double radius_mm, double quantum_mm)
{
	double q = floor(radius_mm / quantum_mm + 0.5);

	if (q < 1)
		q = 1;
	if (q > LATBIN_QMAX)
		q = LATBIN_QMAX;
	return (uint16_t)q;
}

int latbin_cursor_init(struct latbin_cursor *c, int fd, uint64_t off, size_t cap)
{
	c->fd = fd;
	c->off = off;
	c->len = c->pos = 0;
	c->cap = cap;
	c->mem = NULL;
	c->mem_len = 0;
	c->buf = mem_alloc(cap);
	return c->buf ? 0 : ERR_NOMEM;
}

void latbin_cursor_init_mem(struct latbin_cursor *c, const void *data, uint64_t len,
			    uint64_t off)
{
	memset(c, 0, sizeof *c);
	c->fd = -1;
	c->mem = data;
	c->mem_len = len;
	c->off = off;
}

void latbin_cursor_fini(struct latbin_cursor *c)
{
	mem_free(c->buf);
	c->buf = NULL;
}

const unsigned char *latbin_cursor_take(struct latbin_cursor *c, size_t n, struct err *e)
{
	const unsigned char *p;

	if (c->mem) {
		if (c->mem_len - c->off < n) {
			ERR_PLACE(e, ERR_PARSE, (long long)c->mem_len, 0, -1,
				  "unexpected end of file");
			return NULL;
		}
		p = c->mem + c->off;
		c->off += n;
		return p;
	}
	if (c->len - c->pos < n) {
		size_t keep = c->len - c->pos;
		ssize_t got;

		memmove(c->buf, c->buf + c->pos, keep);
		c->off += c->pos;
		c->pos = 0;
		c->len = keep;
		while (c->len < n) {
			got = pread(c->fd, c->buf + c->len, c->cap - c->len, (off_t)(c->off + c->len));
			if (got < 0 && errno == EINTR)
				continue;
			if (got < 0) {
				ERR_SET(e, ERR_IO, "read failed: %s", strerror(errno));
				return NULL;
			}
			if (got == 0) {
				ERR_PLACE(e, ERR_PARSE, (long long)(c->off + c->len), 0, -1,
					  "unexpected end of file");
				return NULL;
			}
			c->len += (size_t)got;
		}
	}
	p = c->buf + c->pos;
	c->pos += n;
	return p;
}

/* ---- buffered output ---- */
struct outbuf {
	int fd;
	unsigned char *buf;
	size_t len, cap;
	uint64_t written;
};

static int out_flush(struct outbuf *o, struct err *e)
{
	size_t done = 0;

	while (done < o->len) {
		ssize_t n = write(o->fd, o->buf + done, o->len - done);
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0)
			return ERR_SET(e, ERR_IO, "write failed: %s", strerror(errno));
		done += (size_t)n;
	}
	o->written += o->len;
	o->len = 0;
	return 0;
}

static int out_put(struct outbuf *o, const unsigned char *p, size_t n, struct err *e)
{
	int rc;

	if (o->cap - o->len < n && (rc = out_flush(o, e)) != 0)
		return rc;
	memcpy(o->buf + o->len, p, n);
	o->len += n;
	return 0;
}

static int out_open(struct outbuf *o, const char *path, struct err *e)
{
	o->len = 0;
	o->written = 0;
	o->cap = 1u << 20;
	o->buf = mem_alloc(o->cap);
	if (!o->buf)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	o->fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (o->fd < 0) {
		mem_free(o->buf);
		o->buf = NULL;
		return ERR_SET(e, ERR_IO, "cannot create %s: %s", path, strerror(errno));
	}
	return 0;
}

static void out_close(struct outbuf *o)
{
	if (o->fd >= 0)
		close(o->fd);
	o->fd = -1;
	mem_free(o->buf);
	o->buf = NULL;
}

static int out_header(struct outbuf *o, const struct lattice_file_header *h, struct err *e)
{
	unsigned char hb[LATBIN_HEADER_BYTES];

	latbin_header_encode(hb, h);
	if (pwrite(o->fd, hb, sizeof hb, 0) != (ssize_t)sizeof hb)
		return ERR_SET(e, ERR_IO, "write failed: %s", strerror(errno));
	return 0;
}

static void encode_node(unsigned char *b, struct vec3 p)
{
	latbin_put_f32(b, (float)p.x);
	latbin_put_f32(b + 4, (float)p.y);
	latbin_put_f32(b + 8, (float)p.z);
}

static void encode_edge(unsigned char *b, uint32_t a, uint32_t c, uint16_t q)
{
	latbin_put_u32(b, a);
	latbin_put_u32(b + 4, c);
	latbin_put_u16(b + 8, q);
}

static int check_coords(struct vec3 p)
{
	return isfinite((float)p.x) && isfinite((float)p.y) && isfinite((float)p.z);
}

/* ---- in-core writer ---- */
struct zkey {
	double z;
	uint32_t idx;
};
struct ekey {
	uint64_t key; /* lo << 32 | hi in the new numbering */
	float r;
};

static int cmp_zkey(const void *pa, const void *pb)
{
	const struct zkey *a = pa, *b = pb;
	if (a->z != b->z)
		return a->z < b->z ? -1 : 1;
	return a->idx < b->idx ? -1 : a->idx > b->idx;
}

static int cmp_ekey(const void *pa, const void *pb)
{
	const struct ekey *a = pa, *b = pb;
	return a->key < b->key ? -1 : a->key > b->key;
}

int lattice_write_binary(const struct lattice *q, const char *path, struct err *e)
{
	struct zkey *zk = NULL;
	uint32_t *newidx = NULL;
	struct ekey *ek = NULL;
	struct outbuf o = {.fd = -1};
	struct lattice_file_header h;
	unsigned char rec[LATBIN_NODE_BYTES > LATBIN_EDGE_BYTES ? LATBIN_NODE_BYTES
								: LATBIN_EDGE_BYTES];
	int rc;

	if (q->nnodes > LATTICE_MAX_NODES || q->nedges > LATTICE_MAX_EDGES)
		return ERR_SET(e, ERR_LIMIT, "lattice too large for the binary format");
	h.nnodes = q->nnodes;
	h.nedges = q->nedges;
	h.support_mm = q->support_mm;
	h.max_radius_mm = lattice_max_radius(q);
	h.radius_quantum_mm = h.max_radius_mm > 0 ? h.max_radius_mm / LATBIN_QMAX : 1e-6;
	h.bbox = lattice_bbox(q);
	if (q->nnodes == 0)
		h.bbox.lo = h.bbox.hi = v3(0, 0, 0);
	if (h.support_mm > 0 && h.max_radius_mm >= h.support_mm)
		return ERR_SET(e, ERR_PARAM, "max radius %g mm is not below the support %g mm",
			       h.max_radius_mm, h.support_mm);

	zk = mem_alloc((q->nnodes ? q->nnodes : 1) * sizeof *zk);
	newidx = mem_alloc((q->nnodes ? q->nnodes : 1) * sizeof *newidx);
	ek = mem_alloc((q->nedges ? q->nedges : 1) * sizeof *ek);
	if (!zk || !newidx || !ek) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory sorting %zu nodes", q->nnodes);
		goto out;
	}
	for (size_t i = 0; i < q->nnodes; i++) {
		if (!check_coords(q->node[i])) {
			rc = ERR_PLACE(e, ERR_PARAM, -1, 0, (long long)i,
				       "node %zu has a non-finite coordinate", i);
			goto out;
		}
		/* sort by the stored (float) z so the file is non-decreasing */
		zk[i].z = (float)q->node[i].z;
		zk[i].idx = (uint32_t)i;
	}
	qsort(zk, q->nnodes, sizeof *zk, cmp_zkey);
	for (size_t i = 0; i < q->nnodes; i++)
		newidx[zk[i].idx] = (uint32_t)i;
	for (size_t i = 0; i < q->nedges; i++) {
		uint32_t a = newidx[q->edge[i].a], b = newidx[q->edge[i].b];
		if (a > b) {
			uint32_t t = a;
			a = b;
			b = t;
		}
		ek[i].key = ((uint64_t)a << 32) | b;
		ek[i].r = q->edge[i].radius_mm;
	}
	qsort(ek, q->nedges, sizeof *ek, cmp_ekey);

	if ((rc = out_open(&o, path, e)) != 0)
		goto out;
	memset(rec, 0, sizeof rec);
	{
		unsigned char hb[LATBIN_HEADER_BYTES];
		latbin_header_encode(hb, &h);
		if ((rc = out_put(&o, hb, sizeof hb, e)) != 0)
			goto out;
	}
	for (size_t i = 0; i < q->nnodes; i++) {
		encode_node(rec, q->node[zk[i].idx]);
		if ((rc = out_put(&o, rec, LATBIN_NODE_BYTES, e)) != 0)
			goto out;
	}
	for (size_t i = 0; i < q->nedges; i++) {
		encode_edge(rec, (uint32_t)(ek[i].key >> 32), (uint32_t)ek[i].key,
			    latbin_quantise(ek[i].r, h.radius_quantum_mm));
		if ((rc = out_put(&o, rec, LATBIN_EDGE_BYTES, e)) != 0)
			goto out;
	}
	rc = out_flush(&o, e);
out:
	out_close(&o);
	mem_free(zk);
	mem_free(newidx);
	mem_free(ek);
	if (rc)
		err_prefix(e, "writing %s", path);
	return rc;
}

/* ---- streaming writer ---- */
struct lattice_writer {
	struct outbuf o;
	struct lattice_file_header h;
	double last_z;
	uint32_t last_a;
	int in_edges;
	char path[512];
};

int lattice_writer_open(const char *path, double support_mm, double max_radius_mm,
			struct lattice_writer **out, struct err *e)
{
	struct lattice_writer *w;
	int rc;

	if (!(max_radius_mm > 0) || !isfinite(max_radius_mm) || !isfinite(support_mm) ||
	    support_mm < 0 || (support_mm > 0 && max_radius_mm >= support_mm))
		return ERR_SET(e, ERR_PARAM, "bad radius bound %g / support %g mm", max_radius_mm,
			       support_mm);
	w = mem_calloc(1, sizeof *w);
	if (!w)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	w->o.fd = -1;
	snprintf(w->path, sizeof w->path, "%s", path);
	w->h.support_mm = support_mm;
	w->h.max_radius_mm = 0;
	w->h.radius_quantum_mm = max_radius_mm / LATBIN_QMAX;
	w->h.bbox = box3_empty();
	w->last_z = -INFINITY;
	if ((rc = out_open(&w->o, path, e)) != 0) {
		mem_free(w);
		return rc;
	}
	{
		unsigned char hb[LATBIN_HEADER_BYTES] = {0};
		if ((rc = out_put(&w->o, hb, sizeof hb, e)) != 0) {
			lattice_writer_abort(w);
			return rc;
		}
	}
	*out = w;
	return 0;
}

int lattice_writer_node(struct lattice_writer *w, struct vec3 p, struct err *e)
{
	unsigned char rec[LATBIN_NODE_BYTES];
	float z = (float)p.z;

	if (w->in_edges)
		return ERR_SET(e, ERR_PARAM, "node after the edge section began");
	if (!check_coords(p))
		return ERR_SET(e, ERR_PARAM, "node %llu has a non-finite coordinate",
			       (unsigned long long)w->h.nnodes);
	if (z < w->last_z)
		return ERR_SET(e, ERR_PARAM, "node %llu: z %g below the previous node's %g",
			       (unsigned long long)w->h.nnodes, (double)z, w->last_z);
	if (w->h.nnodes >= LATTICE_MAX_NODES)
		return ERR_SET(e, ERR_LIMIT, "too many nodes");
	w->last_z = z;
	box3_add(&w->h.bbox, v3((float)p.x, (float)p.y, z));
	encode_node(rec, p);
	w->h.nnodes++;
	return out_put(&w->o, rec, sizeof rec, e);
}

int lattice_writer_edge(struct lattice_writer *w, uint32_t a, uint32_t b, double radius_mm,
			struct err *e)
{
	unsigned char rec[LATBIN_EDGE_BYTES];
	double qmax = w->h.radius_quantum_mm * LATBIN_QMAX;

	w->in_edges = 1;
	if (!(a < b) || b >= w->h.nnodes)
		return ERR_SET(e, ERR_PARAM, "edge %llu: indices %u, %u invalid (need a < b < %llu)",
			       (unsigned long long)w->h.nedges, a, b,
			       (unsigned long long)w->h.nnodes);
	if (a < w->last_a)
		return ERR_SET(e, ERR_PARAM, "edge %llu: lower node %u after %u (not sorted)",
			       (unsigned long long)w->h.nedges, a, w->last_a);
	if (!(radius_mm > 0) || radius_mm > qmax * (1 + 1e-9))
		return ERR_SET(e, ERR_PARAM, "edge %llu: radius %g mm outside (0, %g]",
			       (unsigned long long)w->h.nedges, radius_mm, qmax);
	if (w->h.nedges >= LATTICE_MAX_EDGES)
		return ERR_SET(e, ERR_LIMIT, "too many edges");
	w->last_a = a;
	w->h.max_radius_mm = fmax(w->h.max_radius_mm, radius_mm);
	encode_edge(rec, a, b, latbin_quantise(radius_mm, w->h.radius_quantum_mm));
	w->h.nedges++;
	return out_put(&w->o, rec, sizeof rec, e);
}

void lattice_writer_abort(struct lattice_writer *w)
{
	if (!w)
		return;
	out_close(&w->o);
	mem_free(w);
}

int lattice_writer_close(struct lattice_writer *w, struct err *e)
{
	int rc;

	if (w->h.nnodes == 0)
		w->h.bbox.lo = w->h.bbox.hi = v3(0, 0, 0);
	rc = out_flush(&w->o, e);
	if (!rc)
		rc = out_header(&w->o, &w->h, e);
	if (!rc && fsync(w->o.fd) != 0 && errno != EINVAL)
		rc = ERR_SET(e, ERR_IO, "fsync failed: %s", strerror(errno));
	if (rc)
		err_prefix(e, "writing %s", w->path);
	lattice_writer_abort(w);
	return rc;
}

/* ---- full reader ---- */

/* Read the body of a binary lattice (header already decoded) through c,
 * positioned after the header. */
static int read_body(struct latbin_cursor *c, const struct lattice_file_header *h,
		     struct lattice *q, struct err *e)
{
	const unsigned char *p;
	float last_z = -INFINITY;
	uint32_t last_a = 0;
	int rc;

	if ((rc = lattice_reserve(q, (size_t)h->nnodes, (size_t)h->nedges)) != 0)
		return ERR_SET(e, rc, "cannot hold %llu nodes and %llu edges in memory",
			       (unsigned long long)h->nnodes, (unsigned long long)h->nedges);
	for (uint64_t i = 0; i < h->nnodes; i++) {
		uint64_t at = latbin_cursor_tell(c);
		float x, y, z;

		if (!(p = latbin_cursor_take(c, LATBIN_NODE_BYTES, e))) {
			rc = e ? e->code : ERR_PARSE;
			goto out;
		}
		x = latbin_get_f32(p);
		y = latbin_get_f32(p + 4);
		z = latbin_get_f32(p + 8);
		if (!isfinite(x) || !isfinite(y) || !isfinite(z)) {
			rc = ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				       "node %llu: non-finite coordinate", (unsigned long long)i);
			goto out;
		}
		if (z < last_z) {
			rc = ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				       "node %llu: z %g below the previous node's %g (nodes must "
				       "be sorted by z)",
				       (unsigned long long)i, (double)z, (double)last_z);
			goto out;
		}
		last_z = z;
		q->node[q->nnodes++] = v3(x, y, z);
	}
	for (uint64_t i = 0; i < h->nedges; i++) {
		uint64_t at = latbin_cursor_tell(c);
		uint32_t a, b;
		uint16_t r;
		float rad;

		if (!(p = latbin_cursor_take(c, LATBIN_EDGE_BYTES, e))) {
			rc = e ? e->code : ERR_PARSE;
			goto out;
		}
		a = latbin_get_u32(p);
		b = latbin_get_u32(p + 4);
		r = latbin_get_u16(p + 8);
		if (!(a < b) || b >= h->nnodes || latbin_radius(h, r, &rad) != 0) {
			rc = ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				       "edge %llu: nodes %u, %u / radius code %u invalid "
				       "(need a < b < %llu, 0 < radius <= the header's largest, "
				       "below the support)",
				       (unsigned long long)i, a, b, r,
				       (unsigned long long)h->nnodes);
			goto out;
		}
		if (a < last_a) {
			rc = ERR_PLACE(e, ERR_PARSE, (long long)at, 0, (long long)i,
				       "edge %llu: lower node %u after %u (edges must be sorted)",
				       (unsigned long long)i, a, last_a);
			goto out;
		}
		last_a = a;
		q->edge[q->nedges].a = a;
		q->edge[q->nedges].b = b;
		q->edge[q->nedges].radius_mm = rad;
		q->nedges++;
	}
	rc = 0;
out:
	return rc;
}

/* Header through c (positioned at 0), then the body. */
static int read_all(struct latbin_cursor *c, uint64_t size, struct lattice **out,
		    struct err *e)
{
	const unsigned char *hb;
	struct lattice_file_header h;
	struct lattice *q;
	int rc;

	if (size < LATBIN_HEADER_BYTES || !(hb = latbin_cursor_take(c, LATBIN_HEADER_BYTES, e)))
		return ERR_PLACE(e, ERR_PARSE, 0, 0, -1, "file too short for a lattice header");
	if ((rc = latbin_header_decode(hb, size, &h, e)) != 0)
		return rc;
	if (h.nedges > LATTICE_MAX_INCORE_EDGES)
		return ERR_SET(e, ERR_LIMIT,
			       "%llu struts are too many to load in memory (limit %u); the "
			       "slicer streams such files instead",
			       (unsigned long long)h.nedges, LATTICE_MAX_INCORE_EDGES);
	q = lattice_new();
	if (!q)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	q->support_mm = h.support_mm;
	if ((rc = read_body(c, &h, q, e)) != 0) {
		lattice_free(q);
		return rc;
	}
	*out = q;
	return 0;
}

int latbin_read_fd(int fd, uint64_t size, struct lattice **out, struct err *e)
{
	struct latbin_cursor c;
	int rc;

	if (latbin_cursor_init(&c, fd, 0, 1u << 20))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	rc = read_all(&c, size, out, e);
	latbin_cursor_fini(&c);
	return rc;
}

int latbin_read_mem(const void *data, uint64_t size, struct lattice **out, struct err *e)
{
	struct latbin_cursor c;

	latbin_cursor_init_mem(&c, data, size, 0);
	return read_all(&c, size, out, e);
}
