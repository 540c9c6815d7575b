/* mesh_fixtures.h - generated test meshes and small helpers for tests/unit/mesh.
 *
 * Shapes with known closed-form measures (boxes, tetrahedra, icosphere),
 * built directly from vertex/index tables so that they do not depend on
 * the readers under test.  Header-only: each test program is one file.
 */
#ifndef INFILLD_TEST_MESH_FIXTURES_H
#define INFILLD_TEST_MESH_FIXTURES_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

/* Axis-aligned box [0,a]x[0,b]x[0,c] shifted by (ox, oy, oz), outward CCW. */
static inline struct mesh *fx_box(double a, double b, double c, double ox, double oy, double oz)
{
	static const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
				     {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
	struct mesh *m = mesh_new();
	int i;

	if (!m)
		return NULL;
	for (i = 0; i < 8; i++) {
		double x = (i == 1 || i == 2 || i == 5 || i == 6) ? a : 0;
		double y = (i == 2 || i == 3 || i == 6 || i == 7) ? b : 0;
		double z = i >= 4 ? c : 0;
		mesh_add_vertex(m, v3(x + ox, y + oy, z + oz));
	}
	for (i = 0; i < 12; i++)
		mesh_add_triangle(m, (uint32_t)f[i][0], (uint32_t)f[i][1], (uint32_t)f[i][2]);
	return m;
}

/* Tetrahedron with corners o, o+a e_x, o+b e_y, o+c e_z; volume abc/6. */
static inline struct mesh *fx_tetra(double a, double b, double c, struct vec3 o)
{
	struct mesh *m = mesh_new();

	mesh_add_vertex(m, o);
	mesh_add_vertex(m, v3(o.x + a, o.y, o.z));
	mesh_add_vertex(m, v3(o.x, o.y + b, o.z));
	mesh_add_vertex(m, v3(o.x, o.y, o.z + c));
	mesh_add_triangle(m, 0, 2, 1);
	mesh_add_triangle(m, 0, 1, 3);
	mesh_add_triangle(m, 0, 3, 2);
	mesh_add_triangle(m, 1, 2, 3);
	return m;
}

/* Regular icosahedron of circumradius r, subdivided `level` times with the
 * new vertices pushed to the sphere (duplicated per face: weld before use
 * when topology matters). */
static inline void fx_ico_face(struct mesh *m, struct vec3 a, struct vec3 b, struct vec3 c, double r,
			       int level)
{
	if (level == 0) {
		uint32_t k = (uint32_t)m->nv;
		mesh_add_vertex(m, a);
		mesh_add_vertex(m, b);
		mesh_add_vertex(m, c);
		mesh_add_triangle(m, k, k + 1, k + 2);
		return;
	}
	{
		struct vec3 ab = v3_scale(v3_normalize(v3_add(a, b)), r);
		struct vec3 bc = v3_scale(v3_normalize(v3_add(b, c)), r);
		struct vec3 ca = v3_scale(v3_normalize(v3_add(c, a)), r);
		fx_ico_face(m, a, ab, ca, r, level - 1);
		fx_ico_face(m, ab, b, bc, r, level - 1);
		fx_ico_face(m, ca, bc, c, r, level - 1);
		fx_ico_face(m, ab, bc, ca, r, level - 1);
	}
}

static inline struct mesh *fx_icosphere(double r, int level)
{
	static const int f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
				     {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
				     {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
				     {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
	double t = (1 + sqrt(5.0)) / 2;
	struct vec3 v[12] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
			     {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
			     {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
	struct mesh *m = mesh_new();
	int i;

	for (i = 0; i < 12; i++)
		v[i] = v3_scale(v3_normalize(v[i]), r);
	for (i = 0; i < 20; i++)
		fx_ico_face(m, v[f[i][0]], v[f[i][1]], v[f[i][2]], r, level);
	return m;
}

/* Read a whole file into memory (caller frees); NULL if unreadable. */
static inline unsigned char *fx_slurp(const char *path, size_t *len)
{
	FILE *f = fopen(path, "rb");
	unsigned char *d;
	long n;

	if (!f)
		return NULL;
	fseek(f, 0, SEEK_END);
	n = ftell(f);
	fseek(f, 0, SEEK_SET);
	d = malloc((size_t)n + 1);
	if (d && fread(d, 1, (size_t)n, f) != (size_t)n) {
		free(d);
		d = NULL;
	}
	fclose(f);
	*len = (size_t)n;
	return d;
}

/* Read from a string; returns the code, *out set on success. */
static inline int fx_read_str(const char *s, enum mesh_format fmt, struct mesh **out,
			      struct mesh_read_info *info, struct err *e)
{
	err_clear(e);
	return mesh_read_buffer(s, strlen(s), fmt, NULL, out, info, e);
}

/* Number of distinct undirected edges, counted by sorting (independent
 * of engine/mesh/edges.c). */
static inline int fx_cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return (x > y) - (x < y);
}

static inline size_t fx_count_edges(const struct mesh *m)
{
	uint64_t *k = malloc(3 * m->nt * sizeof *k + 1);
	size_t i, n = 0;

	for (i = 0; i < 3 * m->nt; i++) {
		uint64_t a = m->tri[i], b = m->tri[i % 3 == 2 ? i - 2 : i + 1];
		k[i] = a < b ? a << 32 | b : b << 32 | a;
	}
	qsort(k, 3 * m->nt, sizeof *k, fx_cmp_u64);
	for (i = 0; i < 3 * m->nt; i++)
		n += i == 0 || k[i] != k[i - 1];
	free(k);
	return n;
}

#endif
