/* write.c - mesh writers: STL (binary, ASCII), OBJ, OFF, PLY (ASCII, binary LE).
 *
 * Output goes through a 16 KiB staging buffer to the caller's sink.  Text
 * formats print each coordinate in the shortest of %.15g/%.16g/%.17g that
 * reads back to the same double (checked with the readers' own parser),
 * so text round trips are exact.  Binary PLY stores doubles (exact);
 * binary STL stores float32 by definition.  Numbers use '.' (the C
 * locale; engine code never changes LC_NUMERIC).
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"

struct wbuf {
	struct sink *s;
	struct err *e;
	int rc;
	size_t n;
	char buf[16384];
};

/* A staging buffer bound to s (heap: 16 KiB is too much for some stacks). */
static struct wbuf *wbuf_new(struct sink *s, struct err *e, const char *what)
{
	struct wbuf *w = mem_alloc(sizeof *w);

	if (!w) {
		ERR_SET(e, ERR_NOMEM, "out of memory writing %s", what);
		return NULL;
	}
	w->s = s;
	w->e = e;
	w->rc = 0;
	w->n = 0;
	return w;
}

static void w_flush(struct wbuf *w)
{
	if (w->rc == 0 && w->n)
		w->rc = sink_write(w->s, w->buf, w->n, w->e);
	w->n = 0;
}

static void w_bytes(struct wbuf *w, const void *p, size_t n)
{
	if (w->n + n > sizeof w->buf)
		w_flush(w);
	if (n > sizeof w->buf) {
		if (w->rc == 0)
			w->rc = sink_write(w->s, p, n, w->e);
		return;
	}
	memcpy(w->buf + w->n, p, n);
	w->n += n;
}

static void w_printf(struct wbuf *w, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 2, 3)))
#endif
	;
static void w_printf(struct wbuf *w, const char *fmt, ...)
{
	char line[256];
	va_list ap;
	int n;

	va_start(ap, fmt);
	n = vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	if (n > 0)
		w_bytes(w, line, (size_t)n < sizeof line ? (size_t)n : sizeof line - 1);
}

/* Shortest %.Ng (N = 15..17) that parses back to exactly v. */
static void w_num(struct wbuf *w, double v)
{
	char s[40];
	int prec, n = 0;

	for (prec = 15; prec <= 17; prec++) {
		struct mesh_text t;
		double back;
		n = snprintf(s, sizeof s, "%.*g", prec, v);
		mesh_text_init(&t, s, (size_t)n);
		if (mesh_text_number(&t, &back) == 0 && back == v)
			break;
	}
	w_bytes(w, s, (size_t)n);
}

static void w_vec(struct wbuf *w, const char *prefix, struct vec3 p)
{
	w_bytes(w, prefix, strlen(prefix));
	w_num(w, p.x);
	w_bytes(w, " ", 1);
	w_num(w, p.y);
	w_bytes(w, " ", 1);
	w_num(w, p.z);
	w_bytes(w, "\n", 1);
}

static int finish(struct wbuf *w)
{
	w_flush(w);
	return w->rc;
}

/* Every index in range?  Writers refuse a corrupt mesh rather than
 * producing a file the readers would reject. */
static int check_mesh(const struct mesh *m, struct err *e)
{
	size_t i;

	for (i = 0; i < 3 * m->nt; i++)
		if (m->tri[i] >= m->nv)
			return ERR_SET(e, ERR_INTERNAL,
				       "triangle %zu refers to vertex %u of %zu (corrupt mesh)", i / 3,
				       m->tri[i], m->nv);
	if (m->nv > UINT32_MAX || m->nt > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "mesh too large to write (%zu vertices, %zu triangles)",
			       m->nv, m->nt);
	return 0;
}

static struct vec3 tri_normal(const struct mesh *m, size_t t)
{
	struct vec3 a = m->v[m->tri[3 * t]], b = m->v[m->tri[3 * t + 1]],
		    c = m->v[m->tri[3 * t + 2]];

	return v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

static void put_f32(unsigned char *p, double v)
{
	union {
		float f;
		uint32_t u;
	} c;
	c.f = (float)v;
	mesh_put_le32(p, c.u);
}

int mesh_write_stl(const struct mesh *m, int binary, struct sink *s, struct err *e)
{
	struct wbuf *w;
	size_t t;
	int rc, k;

	if ((rc = check_mesh(m, e)))
		return rc;
	for (t = 0; binary && t < m->nv; t++)
		if (fabs(m->v[t].x) > FLT_MAX || fabs(m->v[t].y) > FLT_MAX ||
		    fabs(m->v[t].z) > FLT_MAX)
			return ERR_SET(e, ERR_LIMIT, "vertex %zu does not fit binary STL's float32",
				       t);
	w = wbuf_new(s, e, "STL");
	if (!w)
		return ERR_NOMEM;
	if (binary) {
		unsigned char head[84] = "binary STL written by infilld";
		memset(head + 29, ' ', 80 - 29);
		mesh_put_le32(head + 80, (uint32_t)m->nt);
		w_bytes(w, head, sizeof head);
		for (t = 0; t < m->nt && w->rc == 0; t++) {
			unsigned char r[50];
			struct vec3 n = tri_normal(m, t);
			put_f32(r, n.x);
			put_f32(r + 4, n.y);
			put_f32(r + 8, n.z);
			for (k = 0; k < 3; k++) {
				struct vec3 p = m->v[m->tri[3 * t + (size_t)k]];
				put_f32(r + 12 + 12 * k, p.x);
				put_f32(r + 16 + 12 * k, p.y);
				put_f32(r + 20 + 12 * k, p.z);
			}
			r[48] = r[49] = 0;
			w_bytes(w, r, sizeof r);
		}
	} else {
		w_printf(w, "solid infilld\n");
		for (t = 0; t < m->nt && w->rc == 0; t++) {
			struct vec3 n = tri_normal(m, t);
			w_printf(w, "  facet normal %.9g %.9g %.9g\n    outer loop\n", n.x, n.y, n.z);
			for (k = 0; k < 3; k++)
				w_vec(w, "      vertex ", m->v[m->tri[3 * t + (size_t)k]]);
			w_printf(w, "    endloop\n  endfacet\n");
		}
		w_printf(w, "endsolid infilld\n");
	}
	rc = finish(w);
	mem_free(w);
	return rc;
}

/* Shared body of the OBJ and OFF text writers. */
static int write_text(const struct mesh *m, struct sink *s, struct err *e, int obj)
{
	struct wbuf *w;
	size_t i;
	int rc;

	if ((rc = check_mesh(m, e)))
		return rc;
	w = wbuf_new(s, e, obj ? "OBJ" : "OFF");
	if (!w)
		return ERR_NOMEM;
	if (obj)
		w_printf(w, "# written by infilld: %zu vertices, %zu triangles\n", m->nv, m->nt);
	else
		w_printf(w, "OFF\n%zu %zu 0\n", m->nv, m->nt);
	for (i = 0; i < m->nv && w->rc == 0; i++)
		w_vec(w, obj ? "v " : "", m->v[i]);
	for (i = 0; i < m->nt && w->rc == 0; i++) {
		const uint32_t *c = m->tri + 3 * i;
		if (obj)
			w_printf(w, "f %u %u %u\n", c[0] + 1, c[1] + 1, c[2] + 1);
		else
			w_printf(w, "3 %u %u %u\n", c[0], c[1], c[2]);
	}
	rc = finish(w);
	mem_free(w);
	return rc;
}

int mesh_write_obj(const struct mesh *m, struct sink *s, struct err *e)
{
	return write_text(m, s, e, 1);
}

int mesh_write_off(const struct mesh *m, struct sink *s, struct err *e)
{
	return write_text(m, s, e, 0);
}

static void put_f64(unsigned char *p, double v)
{
	union {
		double d;
		uint64_t u;
	} c;
	c.d = v;
	mesh_put_le32(p, (uint32_t)c.u);
	mesh_put_le32(p + 4, (uint32_t)(c.u >> 32));
}

int mesh_write_ply(const struct mesh *m, int binary, struct sink *s, struct err *e)
{
	struct wbuf *w;
	size_t i;
	int rc;

	if ((rc = check_mesh(m, e)))
		return rc;
	w = wbuf_new(s, e, "PLY");
	if (!w)
		return ERR_NOMEM;
	w_printf(w,
		 "ply\nformat %s 1.0\ncomment written by infilld\nelement vertex %zu\n"
		 "property double x\nproperty double y\nproperty double z\nelement face %zu\n"
		 "property list uchar uint vertex_indices\nend_header\n",
		 binary ? "binary_little_endian" : "ascii", m->nv, m->nt);
	for (i = 0; i < m->nv && w->rc == 0; i++) {
		if (binary) {
			unsigned char r[24];
			put_f64(r, m->v[i].x);
			put_f64(r + 8, m->v[i].y);
			put_f64(r + 16, m->v[i].z);
			w_bytes(w, r, sizeof r);
		} else {
			w_vec(w, "", m->v[i]);
		}
	}
	for (i = 0; i < m->nt && w->rc == 0; i++) {
		const uint32_t *c = m->tri + 3 * i;
		if (binary) {
			unsigned char r[13];
			r[0] = 3;
			mesh_put_le32(r + 1, c[0]);
			mesh_put_le32(r + 5, c[1]);
			mesh_put_le32(r + 9, c[2]);
			w_bytes(w, r, sizeof r);
		} else {
			w_printf(w, "3 %u %u %u\n", c[0], c[1], c[2]);
		}
	}
	rc = finish(w);
	mem_free(w);
	return rc;
}
