/* read_off.c - OFF reader (Object File Format, ASCII).
 *
 * Header keyword [ST][C][N]OFF, then "nv nf [ne]" on the same line or
 * a later one; '#' comments and blank lines anywhere between records.
 * One vertex per line (the first 3 numbers; colour/normal/texture values
 * after them are ignored), one face per line: "k i0 .. ik-1 [colour]"
 * with 0-based indices; polygons are triangulated (polygon.c).  4OFF,
 * nOFF and binary OFF are refused as unsupported.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* Skip whitespace and '#' comments up to the next record. */
static void skip_to_record(struct mesh_text *t)
{
	for (;;) {
		mesh_text_skip_ws(t);
		if (t->p < t->end && *t->p == '#')
			mesh_text_next_line(t);
		else
			return;
	}
}

#define OFF_PLACE(e, t, item, ...)                                                     \
	ERR_PLACE((e), ERR_PARSE, (long long)((t)->p - (t)->base), (t)->line, (item), \
		  __VA_ARGS__)

static int read_count(struct mesh_text *t, long long *v, const char *what, struct err *e)
{
	char found[32];

	skip_to_record(t);
	if (mesh_text_int(t, v) || !mesh_text_delim(t)) {
		mesh_text_excerpt(t, found, sizeof found);
		return OFF_PLACE(e, t, -1, "OFF header: expected the %s count, found '%s'", what,
				 t->p < t->end ? found : "the end of the file");
	}
	if (*v < 0)
		return OFF_PLACE(e, t, -1, "OFF header: negative %s count %lld", what, *v);
	return 0;
}

int mesh_read_off(const unsigned char *d, size_t len, struct mesh *m,
		  struct mesh_read_info *info, struct err *e)
{
	struct mesh_text t;
	struct mesh_faces faces;
	uint32_t *idx = NULL;
	size_t icap = 0, i, n;
	long long nv, nf, ne;
	const char *w;
	char found[32];
	int rc = 0;

	mesh_faces_init(&faces, m);
	mesh_text_init(&t, d, len);
	skip_to_record(&t);
	n = mesh_text_word(&t, &w);
	if (n < 3 || memcmp(w + n - 3, "OFF", 3) != 0 || strspn(w, "STCN4n") < n - 3) {
		mesh_text_excerpt(&t, found, sizeof found);
		rc = OFF_PLACE(e, &t, -1, "not an OFF file: expected the OFF keyword, found '%s'",
			       found);
		goto out;
	}
	if (memchr(w, '4', n) || memchr(w, 'n', n)) {
		rc = ERR_PLACE(e, ERR_UNSUPPORTED, 0, 1, -1,
			       "%.*s (4D or n-dimensional OFF) is not supported", (int)n, w);
		goto out;
	}
	t.p += n;
	mesh_text_skip_blank(&t);
	n = mesh_text_word(&t, &w);
	if (mesh_text_word_is(w, n, "binary")) {
		rc = ERR_PLACE(e, ERR_UNSUPPORTED, 0, 1, -1, "binary OFF is not supported");
		goto out;
	}
	if ((rc = read_count(&t, &nv, "vertex", e)) || (rc = read_count(&t, &nf, "face", e)))
		goto out;
	mesh_text_skip_blank(&t);
	(void)mesh_text_int(&t, &ne); /* the edge count is informative only */
	/* Each vertex needs at least "0 0 0\n", each face "3 0 1 2\n". */
	if (nv > MESH_MAX_VERTICES) {
		rc = ERR_PLACE(e, ERR_LIMIT, 0, 0, -1,
			       "OFF declares %lld vertices, more than the limit of %u", nv,
			       MESH_MAX_VERTICES);
		goto out;
	}
	if ((unsigned long long)nv > (len + 1) / 6 || (unsigned long long)nf > (len + 1) / 8) {
		rc = ERR_PLACE(e, ERR_PARSE, 0, 0, -1,
			       "OFF declares %lld vertices and %lld faces, more than a %zu-byte "
			       "file can hold",
			       nv, nf, len);
		goto out;
	}
	if (mesh_reserve(m, (size_t)nv, (size_t)nf)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %lld OFF vertices", nv);
		goto out;
	}
	mesh_text_next_line(&t);
	for (i = 0; i < (size_t)nv; i++) {
		double xyz[3];
		int c;
		skip_to_record(&t);
		for (c = 0; c < 3; c++) {
			mesh_text_skip_blank(&t);
			if (mesh_text_number(&t, &xyz[c]) || !mesh_text_delim(&t)) {
				mesh_text_excerpt(&t, found, sizeof found);
				rc = OFF_PLACE(e, &t, (long long)i,
					       "vertex %zu: expected 3 coordinates, found '%s'", i,
					       mesh_text_at_eol(&t) ? "the end of the line" : found);
				goto out;
			}
			if (!isfinite(xyz[c])) {
				rc = OFF_PLACE(e, &t, (long long)i, "vertex %zu: coordinate is %s", i,
					       isnan(xyz[c]) ? "NaN" : "infinite");
				goto out;
			}
		}
		m->v[i] = v3(xyz[0], xyz[1], xyz[2]);
		mesh_text_next_line(&t);
	}
	m->nv = (size_t)nv;
	for (i = 0; i < (size_t)nf; i++) {
		long long k, v;
		size_t j;
		void *arr;
		skip_to_record(&t);
		if (mesh_text_int(&t, &k) || !mesh_text_delim(&t)) {
			mesh_text_excerpt(&t, found, sizeof found);
			rc = OFF_PLACE(e, &t, (long long)i,
				       "face %zu: expected the corner count, found '%s'", i,
				       t.p < t.end ? found : "the end of the file");
			goto out;
		}
		if (k < 3 || (unsigned long long)k * 2 > (size_t)(t.end - t.p)) {
			rc = OFF_PLACE(e, &t, (long long)i,
				       k < 3 ? "face %zu has %lld corners (need at least 3)"
					     : "face %zu declares %lld corners, more than the rest of "
					       "the file can hold",
				       i, k);
			goto out;
		}
		arr = idx;
		if (mem_grow(&arr, &icap, (size_t)k, sizeof *idx)) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory for a %lld-corner face", k);
			goto out;
		}
		idx = arr;
		for (j = 0; j < (size_t)k; j++) {
			mesh_text_skip_blank(&t);
			if (mesh_text_int(&t, &v) || !mesh_text_delim(&t)) {
				mesh_text_excerpt(&t, found, sizeof found);
				rc = OFF_PLACE(e, &t, (long long)i,
					       "face %zu: expected %lld vertex indices, found '%s'", i,
					       k, mesh_text_at_eol(&t) ? "the end of the line" : found);
				goto out;
			}
			if (v < 0 || v >= nv) {
				rc = OFF_PLACE(e, &t, (long long)i,
					       "face %zu: vertex index %lld out of range [0, %lld)", i,
					       v, nv);
				goto out;
			}
			idx[j] = (uint32_t)v;
		}
		if ((rc = mesh_faces_add(&faces, idx, (size_t)k, e))) {
			if (rc == ERR_LIMIT)
				rc = ERR_PLACE(e, ERR_LIMIT, (long long)(t.p - t.base), t.line,
					       (long long)i,
					       "face %zu: more than the limit of %u triangles", i,
					       MESH_MAX_TRIANGLES);
			goto out;
		}
		mesh_text_next_line(&t);
	}
	rc = mesh_faces_finish(&faces, e);
	info->polygons_split = faces.polygons_split;
	if (faces.nonconvex_fanned)
		mesh_warn(info, "%zu non-convex polygons with more than %d corners fan-triangulated",
			  faces.nonconvex_fanned, MESH_EAR_MAX_CORNERS);
out:
	mem_free(idx);
	mesh_faces_fini(&faces);
	return rc;
}
