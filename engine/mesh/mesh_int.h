/* mesh_int.h - internals shared by the files of engine/mesh/ only.
 *
 * The per-format readers (read_*.c) share: the reader entry signature,
 * quirk warnings, the polygon collector that fan-triangulates while
 * parsing and re-triangulates non-convex polygons at the end
 * (polygon.c), and the text scanner (text.h).  Not for other modules.
 */
#ifndef INFILLD_MESH_INT_H
#define INFILLD_MESH_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/mesh/mesh.h"

struct err;

/* Replace m's arrays (m from mesh_new()); the old ones are freed. */
void mesh_take_arrays(struct mesh *m, struct vec3 *v, size_t nv, size_t vcap, uint32_t *tri,
		      size_t nt, size_t tcap);

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

/* Radix sort of 64-bit keys carrying a 32-bit payload in the low bits
 * (the caller packs key << 32 | payload or similar); stable, O(n) with
 * `bytes` passes over the most significant `bytes` bytes... see sort.c. */
int mesh_sort_u64(uint64_t *a, size_t n, int lo_byte, int hi_byte);

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
