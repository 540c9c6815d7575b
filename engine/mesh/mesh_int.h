/* mesh_int.h - internals shared by the files of engine/mesh/ only.
 *
 * The per-format readers (read_*.c) share: the reader entry signature,
 * quirk warnings, the polygon collector that fan-triangulates while
 * parsing and re-triangulates non-convex polygons at the end
 * (polygon.c), and the text scanner (text.h).  Not for other modules.
 */
#ifndef INFILLD_MESH_INT_H
#define INFILLD_MESH_INT_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "engine/mesh/mesh.h"

struct err;

/* A format reader: parse data[0, len) into the empty mesh m (from
 * mesh_new()), fill info.  0 or an err_code with e filled (place set). */
typedef int mesh_reader_fn(const unsigned char *data, size_t len, struct mesh *m,
			   struct mesh_read_info *info, struct err *e);
mesh_reader_fn mesh_read_stl, mesh_read_obj, mesh_read_off, mesh_read_ply;

/* Record a tolerated quirk: counts it, keeps the first message. */
void mesh_warn(struct mesh_read_info *info, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 2, 3)))
#endif
	;

/* Polygon faces of OBJ/OFF/PLY.  mesh_faces_add() emits a triangle, or a
 * fan of k - 2 triangles for a polygon and remembers its corners;
 * mesh_faces_finish(), once every vertex is known and every index is
 * valid, re-triangulates the non-convex polygons in place (ear clipping
 * in the polygon's best-fit plane, O(k^2), for k <= MESH_EAR_MAX_CORNERS;
 * larger ones keep their fan).  The triangle count never changes. */
#define MESH_EAR_MAX_CORNERS 64
struct mesh_faces {
	struct mesh *m;
	uint32_t *corners; /* corners of recorded polygons, owned */
	size_t ncorners, ccap;
	struct mesh_poly {
		size_t first_tri, first_corner;
		uint32_t k;
	} *polys; /* owned */
	size_t npolys, pcap;
	size_t polygons_split;
	size_t nonconvex_fanned; /* non-convex polygons too large to ear-clip */
};
void mesh_faces_init(struct mesh_faces *f, struct mesh *m);
void mesh_faces_fini(struct mesh_faces *f);
/* 0, ERR_NOMEM or ERR_LIMIT (triangle cap; message set, caller adds the
 * place).  k >= 3 is the caller's check. */
int mesh_faces_add(struct mesh_faces *f, const uint32_t *idx, size_t k, struct err *e);
int mesh_faces_finish(struct mesh_faces *f, struct err *e);

/* Coordinate bits for exact comparison and hashing: -0 counts as +0. */
static inline uint64_t mesh_coord_bits(double x)
{
	union {
		double d;
		uint64_t u;
	} c;
	c.d = x + 0.0; /* -0 -> +0 */
	return c.u;
}

static inline int mesh_same_coords(struct vec3 a, struct vec3 b)
{
	return mesh_coord_bits(a.x) == mesh_coord_bits(b.x) &&
	       mesh_coord_bits(a.y) == mesh_coord_bits(b.y) &&
	       mesh_coord_bits(a.z) == mesh_coord_bits(b.z);
}

/* 64-bit finaliser (MurmurHash3's fmix64): every input bit affects every
 * output bit. */
static inline uint64_t mesh_mix64(uint64_t k)
{
	k ^= k >> 33;
	k *= UINT64_C(0xff51afd7ed558ccd);
	k ^= k >> 33;
	k *= UINT64_C(0xc4ceb9fe1a85ec53);
	k ^= k >> 33;
	return k;
}

/* Hash of a point's coordinate bits under a seed. */
static inline uint64_t mesh_hash_coords(struct vec3 p, uint64_t seed)
{
	uint64_t h = mesh_mix64(mesh_coord_bits(p.x) ^ seed);

	h = mesh_mix64(h ^ mesh_coord_bits(p.y));
	return mesh_mix64(h ^ mesh_coord_bits(p.z));
}

/* Corner sharing for soup readers (dedup.c): identical coordinates get
 * one vertex.  mesh_dedup_add appends p to m or finds its twin; 0 or
 * ERR_NOMEM. */
struct mesh_dedup {
	uint32_t *slot; /* vertex index or UINT32_MAX, owned */
	size_t mask;
	uint64_t seed;
	size_t lookups, probes;
	int off; /* sharing given up (pathological probing) */
};
void mesh_dedup_init(struct mesh_dedup *d);
void mesh_dedup_fini(struct mesh_dedup *d);
int mesh_dedup_add(struct mesh_dedup *d, struct mesh *m, struct vec3 p, uint32_t *idx);
/* Hint: p will be looked up soon (hides the table's cache miss). */
void mesh_dedup_prefetch(const struct mesh_dedup *d, struct vec3 p);

/* Stable LSD radix sort of a[0, n) by bytes lo_byte..hi_byte (0 = least
 * significant) of each key; passes whose byte is constant are skipped.
 * O(n) per pass.  0 or ERR_NOMEM (a untouched). */
int mesh_sort_u64(uint64_t *a, size_t n, int lo_byte, int hi_byte);

/* Undirected edges grouped by vertex pair: the records of edges whose
 * smaller vertex is v are rec[off[v] .. off[v + 1]), sorted; a record is
 * (larger vertex << 32) | MESH_EDGE_FWD if the face runs small -> large |
 * face corner (3 t + k: edge from corner k to k + 1 of triangle t).
 * Edges with equal ends (repeated index) are left out.  O(n) plus the
 * sort of each vertex's fan (O(d log d) for degree d). */
#define MESH_EDGE_FWD (UINT64_C(1) << 31)
#define MESH_EDGE_CORNER(r) ((size_t)((r) & 0x7fffffffu))
#define MESH_EDGE_OTHER(r) ((uint32_t)((r) >> 32))
struct mesh_edges {
	uint32_t *off; /* nv + 1 offsets, owned */
	uint64_t *rec; /* owned */
	size_t nv, nrec;
};
int mesh_edges_build(const struct mesh *m, struct mesh_edges *ed, struct err *e);
void mesh_edges_fini(struct mesh_edges *ed);

/* Whether triangle t counts as degenerate (zero area):
 * repeated corner, or 2 * area <= 1e-12 * (longest edge)^2. */
int mesh_tri_degenerate(const struct mesh *m, size_t t);

/* Signed solid angle (steradians) of triangle abc seen from p: positive
 * when p lies behind the triangle (opposite its normal (b-a)x(c-a)), so a
 * closed outward mesh sums to 4 pi at inner points and 0 outside.  Van Oosterom & Strackee: tan(W/2) = a.(b x c) /
 * (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|) with a, b, c relative to p. */
static inline double mesh_solid_angle(struct vec3 a, struct vec3 b, struct vec3 c, struct vec3 p)
{
	double la, lb, lc, num, den;

	a = v3_sub(a, p);
	b = v3_sub(b, p);
	c = v3_sub(c, p);
	la = v3_len(a);
	lb = v3_len(b);
	lc = v3_len(c);
	num = v3_dot(a, v3_cross(b, c));
	den = la * lb * lc + v3_dot(a, b) * lc + v3_dot(b, c) * la + v3_dot(c, a) * lb;
	return 2 * atan2(num, den);
}

/* Little-endian loads/stores independent of the host's byte order. */
static inline uint32_t mesh_le32(const unsigned char *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline float mesh_lef32(const unsigned char *p)
{
	union {
		uint32_t u;
		float f;
	} c;
	c.u = mesh_le32(p);
	return c.f;
}
static inline void mesh_put_le32(unsigned char *p, uint32_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
	p[2] = (unsigned char)(v >> 16);
	p[3] = (unsigned char)(v >> 24);
}

#endif
