/* read_stl.c - STL reader, binary and ASCII, told apart by content.
 *
 * Binary when the size is exactly 84 + 50 n with n the header's count
 * (even if the header starts with "solid"); ASCII when the file starts
 * with the word "solid" and has no NUL byte in its first KiB; otherwise
 * it is judged as a binary file and the size mismatch is the error.
 * Facets share bitwise-identical corners (dedup.c) instead of tripling
 * the vertex count; normals are ignored (recomputed from the vertex
 * order).  Quirks and errors: docs/mesh.md.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define STL_HEADER 84
#define STL_RECORD 50

/* Printable copy of [s, s+n) into the name buffer, trimmed. */
static void copy_name(char *dst, size_t cap, const char *s, size_t n)
{
	size_t i, k = 0;

	while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == 0))
		n--;
	while (n > 0 && (*s == ' ' || *s == '\t')) {
		s++;
		n--;
	}
	for (i = 0; i < n && k + 1 < cap; i++) {
		unsigned char c = (unsigned char)s[i];
		if (c == 0)
			break;
		dst[k++] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
	}
	dst[k] = '\0';
}

static int nonfinite_f32(const unsigned char *p)
{
	return (mesh_le32(p) & 0x7f800000u) == 0x7f800000u;
}

static int read_binary(const unsigned char *d, size_t len, struct mesh *m,
		       struct mesh_read_info *info, struct err *e)
{
	size_t nt = mesh_le32(d + 80), i;
	const unsigned char *r;
	struct mesh_dedup dd;
	int rc;

	info->binary = 1;
	copy_name(info->name, sizeof info->name, (const char *)d, 80);
	if (len >= 5 && memcmp(d, "solid", 5) == 0)
		mesh_warn(info, "binary STL header starts with \"solid\" (the ASCII STL keyword)");
	if (nt > MESH_MAX_TRIANGLES)
		return ERR_PLACE(e, ERR_LIMIT, 80, 0, -1,
				 "binary STL declares %zu triangles, more than the limit of %u", nt,
				 MESH_MAX_TRIANGLES);
	/* Closed meshes have about nt / 2 distinct corners; more grow. */
	if (mesh_reserve(m, nt / 2 + 16, nt))
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu STL triangles", nt);
	mesh_dedup_init(&dd);
	for (i = 0, r = d + STL_HEADER; i < nt; i++, r += STL_RECORD) {
		int k, c;
		if (nonfinite_f32(r) || nonfinite_f32(r + 4) || nonfinite_f32(r + 8))
			mesh_warn(info, "facet %zu: normal is NaN or infinite (ignored)", i);
		if (i + 8 < nt) /* corners 8 facets ahead: start their table lookups */
			for (k = 0; k < 3; k++) {
				const unsigned char *q = r + 8 * STL_RECORD + 12 + 12 * k;
				mesh_dedup_prefetch(&dd, v3(mesh_lef32(q), mesh_lef32(q + 4),
							    mesh_lef32(q + 8)));
			}
		for (k = 0; k < 3; k++) {
			const unsigned char *q = r + 12 + 12 * k;
			for (c = 0; c < 3; c++)
				if (nonfinite_f32(q + 4 * c)) {
					rc = ERR_PLACE(e, ERR_PARSE, (long long)(q + 4 * c - d), 0,
						       (long long)i, "facet %zu vertex %d: coordinate is %s",
						       i, k,
						       isnan(mesh_lef32(q + 4 * c)) ? "NaN" : "infinite");
					goto out;
				}
			if (mesh_dedup_add(&dd, m,
					   v3(mesh_lef32(q), mesh_lef32(q + 4), mesh_lef32(q + 8)),
					   &m->tri[3 * i + (size_t)k])) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu STL triangles", nt);
				goto out;
			}
		}
	}
	m->nt = nt;
	rc = 0;
out:
	mesh_dedup_fini(&dd);
	return rc;
}

/* Parser state for ASCII STL. */
struct stl_ascii {
	struct mesh_text t;
	struct mesh *m;
	struct mesh_read_info *info;
	struct err *e;
	size_t facet;
	struct mesh_dedup dd;
	uint32_t corner[3];
};

static int syntax(struct stl_ascii *s, const char *expected)
{
	char found[32];

	if (s->t.p >= s->t.end)
		return ERR_PLACE(s->e, ERR_PARSE, (long long)(s->t.p - s->t.base), s->t.line,
				 (long long)s->facet, "facet %zu: expected %s, found the end of the file",
				 s->facet, expected);
	mesh_text_excerpt(&s->t, found, sizeof found);
	return ERR_PLACE(s->e, ERR_PARSE, (long long)(s->t.p - s->t.base), s->t.line,
			 (long long)s->facet, "facet %zu: expected %s, found '%s'", s->facet, expected,
			 found);
}

/* Consume keyword kw (after any whitespace) or fail. */
static int expect(struct stl_ascii *s, const char *kw)
{
	const char *w;
	size_t n;

	mesh_text_skip_ws(&s->t);
	n = mesh_text_word(&s->t, &w);
	if (!mesh_text_word_is(w, n, kw))
		return syntax(s, kw);
	s->t.p += n;
	return 0;
}

/* "facet" already consumed: normal (tolerant), loop of exactly 3 vertices. */
static int read_facet(struct stl_ascii *s)
{
	struct mesh_text *t = &s->t;
	const char *w;
	size_t n;
	int k, c, rc;

	mesh_text_skip_blank(t);
	n = mesh_text_word(t, &w);
	if (mesh_text_word_is(w, n, "normal")) {
		t->p += n;
		for (c = 0; c < 3; c++) {
			double x;
			mesh_text_skip_blank(t);
			if (mesh_text_at_eol(t) || mesh_text_number(t, &x) || !mesh_text_delim(t))
				break;
			if (!isfinite(x) && c == 0)
				mesh_warn(s->info, "facet %zu: normal is NaN or infinite (ignored)",
					  s->facet);
		}
		if (c < 3)
			mesh_warn(s->info, "facet %zu: normal has %d of 3 coordinates (ignored)",
				  s->facet, c);
	} else {
		mesh_warn(s->info, "facet %zu: no normal (ignored)", s->facet);
	}
	if ((rc = expect(s, "outer")) || (rc = expect(s, "loop")))
		return rc;
	for (k = 0;; k++) {
		struct vec3 p;
		double xyz[3];
		mesh_text_skip_ws(t);
		n = mesh_text_word(t, &w);
		if (mesh_text_word_is(w, n, "endloop")) {
			t->p += n;
			break;
		}
		if (!mesh_text_word_is(w, n, "vertex"))
			return syntax(s, k < 3 ? "vertex" : "endloop");
		if (k == 3)
			return ERR_PLACE(s->e, ERR_PARSE, (long long)(t->p - t->base), t->line,
					 (long long)s->facet,
					 "facet %zu has more than 3 vertices (an STL facet is a "
					 "triangle)",
					 s->facet);
		t->p += n;
		for (c = 0; c < 3; c++) {
			mesh_text_skip_blank(t);
			if (mesh_text_number(t, &xyz[c]) || !mesh_text_delim(t))
				return syntax(s, "a vertex coordinate");
			if (!isfinite(xyz[c]))
				return ERR_PLACE(s->e, ERR_PARSE, (long long)(t->p - t->base),
						 t->line, (long long)s->facet,
						 "facet %zu vertex %d: coordinate is %s", s->facet, k,
						 isnan(xyz[c]) ? "NaN" : "infinite");
		}
		p = v3(xyz[0], xyz[1], xyz[2]);
		if (mesh_dedup_add(&s->dd, s->m, p, &s->corner[k]))
			return ERR_SET(s->e, ERR_NOMEM, "out of memory reading STL facet %zu",
				       s->facet);
	}
	if (k < 3)
		return ERR_PLACE(s->e, ERR_PARSE, (long long)(t->p - t->base), t->line,
				 (long long)s->facet,
				 "facet %zu has only %d vertices (an STL facet is a triangle)", s->facet,
				 k);
	if ((rc = expect(s, "endfacet")))
		return rc;
	if (s->m->nt >= MESH_MAX_TRIANGLES)
		return ERR_PLACE(s->e, ERR_LIMIT, (long long)(t->p - t->base), t->line,
				 (long long)s->facet, "more than the limit of %u triangles",
				 MESH_MAX_TRIANGLES);
	if (mesh_add_triangle(s->m, s->corner[0], s->corner[1], s->corner[2]))
		return ERR_SET(s->e, ERR_NOMEM, "out of memory reading STL facet %zu", s->facet);
	return 0;
}

/* Rest of a solid/endsolid line (the name), trimmed; moves to the next line. */
static void line_rest(struct mesh_text *t, const char **s, size_t *n)
{
	const char *nl;

	mesh_text_skip_blank(t);
	nl = memchr(t->p, '\n', (size_t)(t->end - t->p));
	*s = t->p;
	*n = (size_t)((nl ? nl : t->end) - t->p);
	mesh_text_next_line(t);
}

/* The grammar (the state is set up by read_ascii). */
static int parse_ascii(struct stl_ascii *s)
{
	const char *w, *name;
	size_t n, nn;
	int rc, ended = 0;

	if ((rc = expect(s, "solid")))
		return rc;
	line_rest(&s->t, &name, &nn);
	copy_name(s->info->name, sizeof s->info->name, name, nn);
	for (;;) {
		mesh_text_skip_ws(&s->t);
		if (s->t.p >= s->t.end)
			break;
		n = mesh_text_word(&s->t, &w);
		if (mesh_text_word_is(w, n, "facet")) {
			if (ended)
				return syntax(s, "solid or the end of the file");
			s->t.p += n;
			if ((rc = read_facet(s)))
				return rc;
			s->facet++;
		} else if (mesh_text_word_is(w, n, "endsolid") && !ended) {
			char end_name[sizeof s->info->name];
			s->t.p += n;
			line_rest(&s->t, &name, &nn);
			copy_name(end_name, sizeof end_name, name, nn);
			if (end_name[0] && strcmp(end_name, s->info->name) != 0)
				mesh_warn(s->info, "endsolid name '%s' differs from solid name '%s'",
					  end_name, s->info->name);
			ended = 1;
		} else if (mesh_text_word_is(w, n, "solid") && ended) {
			/* Several solids in one file: merged into one mesh. */
			s->t.p += n;
			line_rest(&s->t, &name, &nn);
			ended = 0;
		} else if (ended) {
			mesh_warn(s->info, "line %ld: %zu bytes of trailing data after endsolid ignored",
				  s->t.line, (size_t)(s->t.end - s->t.p));
			break;
		} else {
			return syntax(s, "facet or endsolid");
		}
	}
	if (!ended)
		mesh_warn(s->info, "missing endsolid at the end of the file");
	return 0;
}

static int read_ascii(const unsigned char *d, size_t len, struct mesh *m,
		      struct mesh_read_info *info, struct err *e)
{
	struct stl_ascii s;
	int rc;

	memset(&s, 0, sizeof s);
	mesh_text_init(&s.t, d, len);
	s.m = m;
	s.info = info;
	s.e = e;
	mesh_dedup_init(&s.dd);
	rc = parse_ascii(&s);
	mesh_dedup_fini(&s.dd);
	return rc;
}

int mesh_read_stl(const unsigned char *d, size_t len, struct mesh *m,
		  struct mesh_read_info *info, struct err *e)
{
	struct mesh_text t;
	const char *w;
	size_t n, probe = len < 1024 ? len : 1024;
	unsigned long long want;

	if (len >= STL_HEADER && (len - STL_HEADER) % STL_RECORD == 0 &&
	    (len - STL_HEADER) / STL_RECORD == mesh_le32(d + 80))
		return read_binary(d, len, m, info, e);
	mesh_text_init(&t, d, len);
	mesh_text_skip_ws(&t);
	n = mesh_text_word(&t, &w);
	if (mesh_text_word_is(w, n, "solid") && !memchr(d, 0, probe))
		return read_ascii(d, len, m, info, e);
	if (len < STL_HEADER)
		return ERR_PLACE(e, ERR_PARSE, 0, 0, -1,
				 "not an STL file: no \"solid\" keyword, and %zu bytes is shorter "
				 "than a binary STL header (84)",
				 len);
	want = STL_HEADER + (unsigned long long)mesh_le32(d + 80) * STL_RECORD;
	if (want > len)
		return ERR_PLACE(e, ERR_PARSE, 80, 0, -1,
				 "binary STL header declares %u triangles (%llu bytes) but the "
				 "file has %zu bytes (truncated, or a wrong triangle count)",
				 mesh_le32(d + 80), want, len);
	return ERR_PLACE(e, ERR_PARSE, (long long)want, 0, -1,
			 "binary STL has %llu bytes after its %u declared triangles (file "
			 "damaged, or a wrong triangle count)",
			 (unsigned long long)len - want, mesh_le32(d + 80));
}
