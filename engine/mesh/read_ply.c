/* read_ply.c - PLY reader: ascii, binary_little_endian and binary_big_endian.
 *
 * The header declares elements (name, count) with scalar and list
 * properties.  From element "vertex" we take x, y, z (any numeric type, any
 * position); from element "face" the list "vertex_indices" (or
 * "vertex_index"); every other property and element is parsed and
 * skipped.  Before reading the body, each element's count times its
 * smallest possible instance size is checked against the bytes left, so
 * nothing is allocated that the file cannot fill.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define PLY_MAX_ELEMENTS 32
#define PLY_MAX_PROPS 64

enum ply_type { PLY_I8 = 1, PLY_U8, PLY_I16, PLY_U16, PLY_I32, PLY_U32, PLY_F32, PLY_F64 };
enum ply_role { ROLE_OTHER, ROLE_X, ROLE_Y, ROLE_Z, ROLE_INDICES };
enum ply_kind { KIND_OTHER, KIND_VERTEX, KIND_FACE };
enum ply_enc { ENC_ASCII, ENC_LE, ENC_BE };

struct ply_prop {
	unsigned char type, count_type; /* count_type != 0: a list */
	unsigned char role;
};

struct ply_elem {
	char name[32];
	unsigned long long count;
	int kind, nprops;
	struct ply_prop props[PLY_MAX_PROPS];
};

struct ply {
	const unsigned char *d;
	size_t len, pos; /* binary read position */
	struct mesh_text t;
	int enc;
	struct ply_elem el[PLY_MAX_ELEMENTS];
	int nel;
	struct mesh *m;
	struct mesh_faces faces;
	struct mesh_read_info *info;
	struct err *e;
	uint32_t *idx;
	size_t icap;
	long long max_index; /* largest face index seen */
	size_t max_index_face;
};

static const struct {
	const char *name;
	int type;
} ply_types[] = {{"char", PLY_I8},     {"int8", PLY_I8},    {"uchar", PLY_U8},  {"uint8", PLY_U8},
		 {"short", PLY_I16},   {"int16", PLY_I16},  {"ushort", PLY_U16}, {"uint16", PLY_U16},
		 {"int", PLY_I32},     {"int32", PLY_I32},  {"uint", PLY_U32},  {"uint32", PLY_U32},
		 {"float", PLY_F32},   {"float32", PLY_F32}, {"double", PLY_F64}, {"float64", PLY_F64}};

static const int type_size[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};

static int parse_type(const char *w, size_t n)
{
	size_t i;

	for (i = 0; i < sizeof ply_types / sizeof ply_types[0]; i++)
		if (strlen(ply_types[i].name) == n && memcmp(ply_types[i].name, w, n) == 0)
			return ply_types[i].type;
	return 0;
}

/* "<what> '<word>'" at the current header line (no quotes when n == 0). */
static int header_error(struct ply *p, const char *what, const char *w, size_t n)
{
	return ERR_PLACE(p->e, ERR_PARSE, (long long)(p->t.p - p->t.base), p->t.line, -1,
			 n ? "%s '%.*s'" : "%s", what, (int)(n < 32 ? n : 32), w);
}

/* Next word on the current line (after blanks); its length, 0 at eol. */
static size_t next_word(struct mesh_text *t, const char **w)
{
	size_t n;

	mesh_text_skip_blank(t);
	n = mesh_text_word(t, w);
	t->p += n;
	return n;
}

static int parse_header(struct ply *p)
{
	struct mesh_text *t = &p->t;
	struct ply_elem *cur = NULL;
	const char *w;
	size_t n;
	int have_format = 0;

	mesh_text_next_line(t); /* "ply" */
	for (;;) {
		if (t->p >= t->end)
			return ERR_PLACE(p->e, ERR_PARSE, (long long)(t->p - t->base), t->line, -1,
					 "PLY header has no end_header line");
		n = next_word(t, &w);
		if (n == 0 || mesh_text_word_is(w, n, "comment") ||
		    mesh_text_word_is(w, n, "obj_info")) {
			/* blank line or comment */
		} else if (mesh_text_word_is(w, n, "format")) {
			n = next_word(t, &w);
			if (n == 5 && !memcmp(w, "ascii", 5))
				p->enc = ENC_ASCII;
			else if (n == 20 && !memcmp(w, "binary_little_endian", 20))
				p->enc = ENC_LE;
			else if (n == 17 && !memcmp(w, "binary_big_endian", 17))
				p->enc = ENC_BE;
			else
				return header_error(p, "unknown PLY format", w, n);
			have_format = 1;
		} else if (mesh_text_word_is(w, n, "element")) {
			long long count;
			if (p->nel == PLY_MAX_ELEMENTS)
				return header_error(p, "more than 32 PLY elements, at", w, n);
			cur = &p->el[p->nel++];
			memset(cur, 0, sizeof *cur);
			n = next_word(t, &w);
			if (n == 0)
				return header_error(p, "PLY element without a name", "", 0);
			snprintf(cur->name, sizeof cur->name, "%.*s", (int)(n < 31 ? n : 31), w);
			cur->kind = (n == 6 && !memcmp(w, "vertex", 6))	 ? KIND_VERTEX
				    : (n == 4 && !memcmp(w, "face", 4)) ? KIND_FACE
									: KIND_OTHER;
			mesh_text_skip_blank(t);
			if (mesh_text_int(t, &count) || !mesh_text_delim(t) || count < 0)
				return header_error(p, "no valid count for PLY element",
						    cur->name, strlen(cur->name));
			cur->count = (unsigned long long)count;
		} else if (mesh_text_word_is(w, n, "property")) {
			struct ply_prop *pr;
			if (!cur)
				return header_error(p, "PLY property before any element", "", 0);
			if (cur->nprops == PLY_MAX_PROPS)
				return header_error(p, "more than 64 properties in PLY element",
						    cur->name, strlen(cur->name));
			pr = &cur->props[cur->nprops++];
			memset(pr, 0, sizeof *pr);
			n = next_word(t, &w);
			if (n == 4 && !memcmp(w, "list", 4)) {
				n = next_word(t, &w);
				pr->count_type = (unsigned char)parse_type(w, n);
				if (!pr->count_type || pr->count_type >= PLY_F32)
					return header_error(p, "bad PLY list count type", w, n);
				n = next_word(t, &w);
			}
			pr->type = (unsigned char)parse_type(w, n);
			if (!pr->type)
				return header_error(p, "unknown PLY property type", w, n);
			n = next_word(t, &w);
			if (cur->kind == KIND_VERTEX && !pr->count_type && n == 1)
				pr->role = w[0] == 'x' ? ROLE_X : w[0] == 'y' ? ROLE_Y
							 : w[0] == 'z' ? ROLE_Z : ROLE_OTHER;
			if (cur->kind == KIND_FACE &&
			    ((n == 14 && !memcmp(w, "vertex_indices", 14)) ||
			     (n == 12 && !memcmp(w, "vertex_index", 12)))) {
				if (!pr->count_type)
					return header_error(p, "PLY face property is not a list:",
							    w, n);
				if (pr->type >= PLY_F32)
					return header_error(p, "PLY vertex indices of a float type:",
							    w, n);
				pr->role = ROLE_INDICES;
			}
		} else if (mesh_text_word_is(w, n, "end_header")) {
			mesh_text_next_line(t);
			break;
		} else {
			return header_error(p, "unknown PLY header keyword", w, n);
		}
		mesh_text_next_line(t);
	}
	if (!have_format)
		return ERR_PLACE(p->e, ERR_PARSE, 0, 2, -1, "PLY header has no format line");
	return 0;
}

/* Read one binary value of type ty at p->pos (bounds checked by caller). */
static double bin_value(struct ply *p, int ty)
{
	unsigned char b[8];
	const unsigned char *s = p->d + p->pos;
	int k, sz = type_size[ty];
	union {
		uint16_t u16;
		uint32_t u32;
		uint64_t u64;
		float f;
		double d;
	} u;
	uint64_t v = 0;

	for (k = 0; k < sz; k++) /* assemble as an unsigned integer, host independent */
		b[k] = s[p->enc == ENC_LE ? k : sz - 1 - k];
	for (k = sz - 1; k >= 0; k--)
		v = v << 8 | b[k];
	p->pos += (size_t)sz;
	switch (ty) {
	case PLY_I8: return (double)(int8_t)v;
	case PLY_U8: return (double)(uint8_t)v;
	case PLY_I16: return (double)(int16_t)v;
	case PLY_U16: return (double)(uint16_t)v;
	case PLY_I32: return (double)(int32_t)v;
	case PLY_U32: return (double)(uint32_t)v;
	case PLY_F32: u.u32 = (uint32_t)v; return (double)u.f;
	default: u.u64 = v; return u.d;
	}
}

/* Read the next value (either encoding) into *v; 0 or an error. */
static int value(struct ply *p, int ty, double *v, const struct ply_elem *el, unsigned long long i)
{
	char found[32];

	if (p->enc != ENC_ASCII) {
		if (p->len - p->pos < (size_t)type_size[ty])
			return ERR_PLACE(p->e, ERR_PARSE, (long long)p->pos, 0, (long long)i,
					 "PLY file truncated in %s %llu", el->name, i);
		*v = bin_value(p, ty);
		return 0;
	}
	mesh_text_skip_ws(&p->t);
	if (mesh_text_number(&p->t, v) || !mesh_text_delim(&p->t)) {
		mesh_text_excerpt(&p->t, found, sizeof found);
		return ERR_PLACE(p->e, ERR_PARSE, (long long)(p->t.p - p->t.base), p->t.line,
				 (long long)i, "%s %llu: expected a number, found '%s'", el->name, i,
				 p->t.p < p->t.end ? found : "the end of the file");
	}
	if (ty < PLY_F32 && *v != floor(*v))
		return ERR_PLACE(p->e, ERR_PARSE, (long long)(p->t.p - p->t.base), p->t.line,
				 (long long)i, "%s %llu: %g is not an integer", el->name, i, *v);
	return 0;
}

static long long place_offset(const struct ply *p)
{
	return p->enc == ENC_ASCII ? (long long)(p->t.p - p->t.base) : (long long)p->pos;
}

static long place_line(const struct ply *p)
{
	return p->enc == ENC_ASCII ? p->t.line : 0;
}

static int read_element(struct ply *p, const struct ply_elem *el)
{
	unsigned long long i;
	int j, rc;

	for (i = 0; i < el->count; i++) {
		double xyz[3] = {0, 0, 0};
		size_t k = 0;
		for (j = 0; j < el->nprops; j++) {
			const struct ply_prop *pr = &el->props[j];
			double v, cnt;
			unsigned long long c, q;
			if (!pr->count_type) {
				if ((rc = value(p, pr->type, &v, el, i)))
					return rc;
				if (pr->role >= ROLE_X && pr->role <= ROLE_Z) {
					if (!isfinite(v))
						return ERR_PLACE(p->e, ERR_PARSE, place_offset(p),
								 place_line(p), (long long)i,
								 "vertex %llu: coordinate is %s", i,
								 isnan(v) ? "NaN" : "infinite");
					xyz[pr->role - ROLE_X] = v;
				}
				continue;
			}
			if ((rc = value(p, pr->count_type, &cnt, el, i)))
				return rc;
			if (cnt < 0 ||
			    cnt * (p->enc == ENC_ASCII ? 2 : type_size[pr->type]) >
				    (double)(p->enc == ENC_ASCII ? (size_t)(p->t.end - p->t.p) + 1
								 : p->len - p->pos))
				return ERR_PLACE(p->e, ERR_PARSE, place_offset(p), place_line(p),
						 (long long)i,
						 "%s %llu: list length %.0f is negative or longer than "
						 "the rest of the file",
						 el->name, i, cnt);
			c = (unsigned long long)cnt;
			if (pr->role == ROLE_INDICES) {
				void *arr = p->idx;
				if (c < 3)
					return ERR_PLACE(p->e, ERR_PARSE, place_offset(p), place_line(p),
							 (long long)i,
							 "face %llu has %llu corners (need at least 3)", i,
							 c);
				if (mem_grow(&arr, &p->icap, (size_t)k + (size_t)c, sizeof *p->idx))
					return ERR_SET(p->e, ERR_NOMEM,
						       "out of memory for a %llu-corner face", c);
				p->idx = arr;
			}
			for (q = 0; q < c; q++) {
				if ((rc = value(p, pr->type, &v, el, i)))
					return rc;
				if (pr->role != ROLE_INDICES)
					continue;
				if (v < 0 || v >= MESH_MAX_VERTICES)
					return ERR_PLACE(p->e, ERR_PARSE, place_offset(p), place_line(p),
							 (long long)i,
							 "face %llu: vertex index %.0f out of range", i, v);
				p->idx[k++] = (uint32_t)v;
				if ((long long)v > p->max_index) {
					p->max_index = (long long)v;
					p->max_index_face = (size_t)i;
				}
			}
		}
		if (el->kind == KIND_VERTEX) {
			p->m->v[i] = v3(xyz[0], xyz[1], xyz[2]);
		} else if (el->kind == KIND_FACE && (rc = mesh_faces_add(&p->faces, p->idx, k, p->e))) {
			return rc == ERR_LIMIT ? ERR_PLACE(p->e, ERR_LIMIT, place_offset(p), place_line(p),
							   (long long)i,
							   "face %llu: more than the limit of %u "
							   "triangles",
							   i, MESH_MAX_TRIANGLES)
					       : rc;
		}
	}
	return 0;
}

/* Check counts against limits and the bytes left, before allocating. */
static int check_counts(struct ply *p, size_t body)
{
	int i, j, have_x = 0, have_y = 0, have_z = 0, nvertex = 0;
	unsigned long long need = 0;

	for (i = 0; i < p->nel; i++) {
		const struct ply_elem *el = &p->el[i];
		unsigned long long min = 0;
		int have_idx = 0;
		for (j = 0; j < el->nprops; j++) {
			const struct ply_prop *pr = &el->props[j];
			if (p->enc == ENC_ASCII)
				min += 2; /* a digit and a separator */
			else
				min += (unsigned long long)type_size[pr->count_type ? pr->count_type
										   : pr->type];
			if (el->kind == KIND_VERTEX) {
				have_x |= pr->role == ROLE_X;
				have_y |= pr->role == ROLE_Y;
				have_z |= pr->role == ROLE_Z;
			}
			have_idx += pr->role == ROLE_INDICES;
		}
		if (el->kind == KIND_VERTEX && !(have_x && have_y && have_z))
			return ERR_PLACE(p->e, ERR_PARSE, 0, 0, -1,
					 "PLY vertex element lacks an x, y or z property");
		nvertex += el->kind == KIND_VERTEX;
		if (nvertex > 1)
			return ERR_PLACE(p->e, ERR_PARSE, 0, 0, -1,
					 "PLY file has more than one vertex element");
		if (el->kind == KIND_FACE && !have_idx)
			return ERR_PLACE(p->e, ERR_PARSE, 0, 0, -1,
					 "PLY face element has no vertex_indices list");
		/* which list would make the polygon is anyone's guess */
		if (el->kind == KIND_FACE && have_idx > 1)
			return ERR_PLACE(p->e, ERR_PARSE, 0, 0, -1,
					 "PLY face element has %d vertex index lists (vertex_indices "
					 "or vertex_index), not one",
					 have_idx);
		if (el->kind == KIND_VERTEX && el->count > MESH_MAX_VERTICES)
			return ERR_PLACE(p->e, ERR_LIMIT, 0, 0, -1,
					 "PLY declares %llu vertices, more than the limit of %u",
					 el->count, MESH_MAX_VERTICES);
		if (el->kind == KIND_FACE && el->count > MESH_MAX_TRIANGLES)
			return ERR_PLACE(p->e, ERR_LIMIT, 0, 0, -1,
					 "PLY declares %llu faces, more than the limit of %u",
					 el->count, MESH_MAX_TRIANGLES);
		if (min == 0 && el->count > 0)
			return ERR_PLACE(p->e, ERR_PARSE, 0, 0, -1,
					 "PLY element '%s' has instances but no properties",
					 el->name);
		if (el->count > body / (min ? min : 1) + 1) {
			return ERR_PLACE(p->e, ERR_PARSE, (long long)(p->len - body), 0, -1,
					 "PLY element '%s' declares %llu instances, more than the "
					 "%zu bytes after the header can hold",
					 el->name, el->count, body);
		}
		need += el->count * min;
	}
	if (need > body + 1)
		return ERR_PLACE(p->e, ERR_PARSE, (long long)(p->len - body), 0, -1,
				 "PLY elements need at least %llu bytes, the body has %zu", need, body);
	return 0;
}

int mesh_read_ply(const unsigned char *d, size_t len, struct mesh *m,
		  struct mesh_read_info *info, struct err *e)
{
	struct ply *p;
	int i, rc;

	if (len < 4 || memcmp(d, "ply", 3) != 0 || (d[3] != '\n' && d[3] != '\r'))
		return ERR_PLACE(e, ERR_PARSE, 0, 1, -1, "not a PLY file: no \"ply\" first line");
	p = mem_calloc(1, sizeof *p);
	if (!p)
		return ERR_SET(e, ERR_NOMEM, "out of memory reading a PLY header");
	p->d = d;
	p->len = len;
	p->m = m;
	p->info = info;
	p->e = e;
	p->max_index = -1;
	mesh_faces_init(&p->faces, m);
	mesh_text_init(&p->t, d, len);
	if ((rc = parse_header(p)))
		goto out;
	p->pos = (size_t)(p->t.p - p->t.base);
	info->binary = p->enc != ENC_ASCII;
	if ((rc = check_counts(p, len - p->pos)))
		goto out;
	for (i = 0; i < p->nel; i++)
		if (p->el[i].kind == KIND_VERTEX) {
			if (mesh_reserve(m, (size_t)p->el[i].count, 0)) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %llu PLY vertices",
					     p->el[i].count);
				goto out;
			}
			m->nv = (size_t)p->el[i].count;
			if (m->nv) /* "element vertex 0": m->v may be NULL */
				memset(m->v, 0, m->nv * sizeof *m->v);
			break;
		}
	for (i = 0; i < p->nel; i++) {
		if ((rc = read_element(p, &p->el[i])))
			goto out;
	}
	if (p->max_index >= (long long)m->nv) {
		rc = ERR_PLACE(e, ERR_PARSE, -1, 0, (long long)p->max_index_face,
			       "face %zu: vertex index %lld out of range (the file has %zu vertices)",
			       p->max_index_face, p->max_index, m->nv);
		goto out;
	}
	rc = mesh_faces_finish(&p->faces, e);
	info->polygons_split = p->faces.polygons_split;
	if (p->faces.nonconvex_fanned)
		mesh_warn(info, "%zu non-convex polygons with more than %d corners fan-triangulated",
			  p->faces.nonconvex_fanned, MESH_EAR_MAX_CORNERS);
out:
	mem_free(p->idx);
	mesh_faces_fini(&p->faces);
	mem_free(p);
	return rc;
}
