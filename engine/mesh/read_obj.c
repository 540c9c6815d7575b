/* read_obj.c - Wavefront OBJ reader (geometry only).
 *
 * Reads `v x y z [w] [r g b]` (first 3 numbers) and `f` records whose
 * corners are `i`, `i/t`, `i//n` or `i/t/n`; indices are 1-based, or
 * negative = relative to the vertices read so far.  Positive indices may
 * point forward (checked once the file is read).  `o` gives the name;
 * every other record (vt, vn, g, s, usemtl, mtllib, l, p, curves...) is
 * ignored.  Polygons are triangulated (polygon.c).
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define OBJ_PLACE(e, code, t, item, ...)                                              \
	ERR_PLACE((e), (code), (long long)((t)->p - (t)->base), (t)->line, (long long)(item), \
		  __VA_ARGS__)

struct obj_state {
	struct mesh_text t;
	struct mesh *m;
	struct mesh_faces faces;
	struct err *e;
	uint32_t *idx; /* corners of the current face, owned */
	size_t icap;
	size_t nface;
	long long max_forward;  /* largest 0-based index past the vertices known then */
	long forward_line;
	size_t forward_face;
};

static int read_vertex(struct obj_state *s)
{
	struct mesh_text *t = &s->t;
	double xyz[3];
	char found[32];
	int c;

	for (c = 0; c < 3; c++) {
		mesh_text_skip_blank(t);
		if (mesh_text_number(t, &xyz[c]) || !mesh_text_delim(t)) {
			mesh_text_excerpt(t, found, sizeof found);
			return OBJ_PLACE(s->e, ERR_PARSE, t, s->m->nv,
					 "vertex %zu: expected 3 coordinates, found '%s'", s->m->nv,
					 mesh_text_at_eol(t) ? "the end of the line" : found);
		}
		if (!isfinite(xyz[c]))
			return OBJ_PLACE(s->e, ERR_PARSE, t, s->m->nv,
					 "vertex %zu: coordinate is %s", s->m->nv,
					 isnan(xyz[c]) ? "NaN" : "infinite");
	}
	if (s->m->nv >= MESH_MAX_VERTICES)
		return OBJ_PLACE(s->e, ERR_LIMIT, t, s->m->nv,
				 "more than the limit of %u vertices", MESH_MAX_VERTICES);
	if (mesh_add_vertex(s->m, v3(xyz[0], xyz[1], xyz[2])))
		return ERR_SET(s->e, ERR_NOMEM, "out of memory for OBJ vertex %zu", s->m->nv);
	return 0;
}

static int read_face(struct obj_state *s)
{
	struct mesh_text *t = &s->t;
	size_t k = 0, nv = s->m->nv;
	char found[32];
	int rc;

	for (;;) {
		long long v;
		void *arr;
		mesh_text_skip_blank(t);
		if (mesh_text_at_eol(t) || *t->p == '#')
			break;
		if (mesh_text_int(t, &v) || !(mesh_text_delim(t) || *t->p == '/')) {
			mesh_text_excerpt(t, found, sizeof found);
			return OBJ_PLACE(s->e, ERR_PARSE, t, s->nface,
					 "face %zu: expected a vertex index, found '%s'", s->nface,
					 found);
		}
		while (!mesh_text_delim(t)) /* skip /texture/normal */
			t->p++;
		if (v == 0)
			return OBJ_PLACE(s->e, ERR_PARSE, t, s->nface,
					 "face %zu: vertex index 0 (OBJ indices start at 1)",
					 s->nface);
		if (v < 0) {
			if (-v > (long long)nv)
				return OBJ_PLACE(s->e, ERR_PARSE, t, s->nface,
						 "face %zu: relative index %lld reaches before the "
						 "first vertex (%zu read so far)",
						 s->nface, v, nv);
			v += (long long)nv;
		} else {
			v--;
			if (v >= (long long)nv && v > s->max_forward) {
				if (v >= MESH_MAX_VERTICES)
					return OBJ_PLACE(s->e, ERR_PARSE, t, s->nface,
							 "face %zu: vertex index %lld is beyond the "
							 "limit of %u vertices",
							 s->nface, v + 1, MESH_MAX_VERTICES);
				s->max_forward = v;
				s->forward_line = t->line;
				s->forward_face = s->nface;
			}
		}
		arr = s->idx;
		if (mem_grow(&arr, &s->icap, k + 1, sizeof *s->idx))
			return ERR_SET(s->e, ERR_NOMEM, "out of memory for OBJ face %zu", s->nface);
		s->idx = arr;
		s->idx[k++] = (uint32_t)v;
	}
	if (k < 3)
		return OBJ_PLACE(s->e, ERR_PARSE, t, s->nface,
				 "face %zu has %zu corners (need at least 3)", s->nface, k);
	if ((rc = mesh_faces_add(&s->faces, s->idx, k, s->e)))
		return rc == ERR_LIMIT ? OBJ_PLACE(s->e, ERR_LIMIT, t, s->nface,
						   "face %zu: more than the limit of %u triangles",
						   s->nface, MESH_MAX_TRIANGLES)
				       : rc;
	s->nface++;
	return 0;
}

int mesh_read_obj(const unsigned char *d, size_t len, struct mesh *m,
		  struct mesh_read_info *info, struct err *e)
{
	struct obj_state s;
	const char *w;
	size_t n;
	int rc = 0;

	memset(&s, 0, sizeof s);
	mesh_text_init(&s.t, d, len);
	mesh_faces_init(&s.faces, m);
	s.m = m;
	s.e = e;
	s.max_forward = -1;
	if (len >= 3 && memcmp(d, "\xef\xbb\xbf", 3) == 0) /* UTF-8 byte order mark */
		s.t.p += 3;
	while (s.t.p < s.t.end) {
		mesh_text_skip_blank(&s.t);
		n = mesh_text_word(&s.t, &w);
		if (n > 0 && ((unsigned char)w[0] < 0x20 || (unsigned char)w[0] >= 0x7f)) {
			rc = OBJ_PLACE(e, ERR_PARSE, &s.t, -1,
				       "not an OBJ record: binary byte 0x%02x at the start of a line",
				       (unsigned char)w[0]);
			goto out;
		}
		if (n == 1 && w[0] == 'v') {
			s.t.p += n;
			rc = read_vertex(&s);
		} else if (n == 1 && w[0] == 'f') {
			s.t.p += n;
			rc = read_face(&s);
		} else if (n == 1 && w[0] == 'o' && !info->name[0]) {
			const char *nl;
			size_t k;
			s.t.p += n;
			mesh_text_skip_blank(&s.t);
			nl = memchr(s.t.p, '\n', (size_t)(s.t.end - s.t.p));
			k = (size_t)((nl ? nl : s.t.end) - s.t.p);
			while (k > 0 && mesh_text_blank_char(s.t.p[k - 1]))
				k--;
			for (n = 0; n < k && n + 1 < sizeof info->name; n++) {
				unsigned char c = (unsigned char)s.t.p[n];
				info->name[n] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
			}
			info->name[n] = '\0';
		}
		if (rc)
			goto out;
		mesh_text_next_line(&s.t);
	}
	if (s.max_forward >= (long long)m->nv) {
		rc = ERR_PLACE(e, ERR_PARSE, -1, s.forward_line, (long long)s.forward_face,
			       "face %zu: vertex index %lld out of range (the file has %zu vertices)",
			       s.forward_face, s.max_forward + 1, m->nv);
		goto out;
	}
	rc = mesh_faces_finish(&s.faces, e);
	info->polygons_split = s.faces.polygons_split;
	if (s.faces.nonconvex_fanned)
		mesh_warn(info, "%zu non-convex polygons with more than %d corners fan-triangulated",
			  s.faces.nonconvex_fanned, MESH_EAR_MAX_CORNERS);
out:
	mem_free(s.idx);
	mesh_faces_fini(&s.faces);
	return rc;
}
