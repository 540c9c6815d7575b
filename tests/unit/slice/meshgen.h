/* meshgen.h - procedural test meshes for the slice tests (header-only,
 * static; included by tests/unit/slice/test_*.c, not a test itself).
 *
 * Boxes, prisms of polygons, icospheres, tori, built directly into a
 * struct mesh with CCW-from-outside triangles, plus the independent
 * measures the tests compare against (divergence-theorem volume, exact
 * generalised winding number).  Meshes are freed with tm_free().
 */
#ifndef INFILLD_TEST_MESHGEN_H
#define INFILLD_TEST_MESHGEN_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "engine/geom/vec.h"
#include "engine/mesh/mesh.h"

static inline struct mesh *tm_new(void)
{
	return calloc(1, sizeof(struct mesh));
}

static inline void tm_free(struct mesh *m)
{
	if (!m)
		return;
	free(m->v);
	free(m->tri);
	free(m);
}

static inline uint32_t tm_vert(struct mesh *m, double x, double y, double z)
{
	if ((m->nv & (m->nv - 1)) == 0) /* grow at powers of two */
		m->v = realloc(m->v, (m->nv ? 2 * m->nv : 1) * sizeof *m->v);
	m->v[m->nv] = v3(x, y, z);
	return (uint32_t)m->nv++;
}

static inline void tm_tri(struct mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
	if ((m->nt & (m->nt - 1)) == 0)
		m->tri = realloc(m->tri, 3 * (m->nt ? 2 * m->nt : 1) * sizeof *m->tri);
	m->tri[3 * m->nt] = a;
	m->tri[3 * m->nt + 1] = b;
	m->tri[3 * m->nt + 2] = c;
	m->nt++;
}

/* Signed volume by the divergence theorem (independent of the slicer). */
static inline double tm_volume(const struct mesh *m)
{
	double s = 0;
	for (size_t t = 0; t < m->nt; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], b = m->v[m->tri[3 * t + 1]],
			    c = m->v[m->tri[3 * t + 2]];
		s += v3_dot(a, v3_cross(b, c));
	}
	return s / 6.0;
}

/* Exact generalised winding number of the mesh around p (solid angles,
 * Van Oosterom-Strackee): ~1 inside a closed mesh, ~0 outside. */
static inline double tm_winding(const struct mesh *m, struct vec3 p)
{
	double s = 0;
	for (size_t t = 0; t < m->nt; t++) {
		struct vec3 a = v3_sub(m->v[m->tri[3 * t]], p), b = v3_sub(m->v[m->tri[3 * t + 1]], p),
			    c = v3_sub(m->v[m->tri[3 * t + 2]], p);
		double la = v3_len(a), lb = v3_len(b), lc = v3_len(c);
		double num = v3_dot(a, v3_cross(b, c));
		double den = la * lb * lc + v3_dot(a, b) * lc + v3_dot(b, c) * la + v3_dot(c, a) * lb;
		s += 2.0 * atan2(num, den);
	}
	return s / (4.0 * M_PI);
}

/* Prism: polygon (n points, CCW in XY) triangulated by tris (nt, CCW),
 * extruded from z0 to z1. */
static inline void tm_prism(struct mesh *m, const double (*poly)[2], int n, const int (*tris)[3], int nt,
		     double z0, double z1)
{
	uint32_t b = (uint32_t)m->nv;
	for (int i = 0; i < n; i++)
		tm_vert(m, poly[i][0], poly[i][1], z0);
	for (int i = 0; i < n; i++)
		tm_vert(m, poly[i][0], poly[i][1], z1);
	for (int t = 0; t < nt; t++) {
		tm_tri(m, b + (uint32_t)tris[t][0], b + (uint32_t)tris[t][2], b + (uint32_t)tris[t][1]);
		tm_tri(m, b + (uint32_t)(n + tris[t][0]), b + (uint32_t)(n + tris[t][1]),
		       b + (uint32_t)(n + tris[t][2]));
	}
	for (int i = 0; i < n; i++) {
		uint32_t a0 = b + (uint32_t)i, b0 = b + (uint32_t)((i + 1) % n);
		tm_tri(m, a0, b0, b0 + (uint32_t)n);
		tm_tri(m, a0, b0 + (uint32_t)n, a0 + (uint32_t)n);
	}
}

static inline void tm_box(struct mesh *m, double x0, double y0, double z0, double x1, double y1,
		   double z1)
{
	const double sq[4][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
	const int tr[2][3] = {{0, 1, 2}, {0, 2, 3}};
	tm_prism(m, sq, 4, tr, 2, z0, z1);
}

/* Icosphere: icosahedron subdivided `level` times, vertices on the
 * sphere of radius r around c. */
static inline struct mesh *tm_icosphere(struct vec3 c, double r, int level)
{
	struct mesh *m = tm_new();
	const double t = (1.0 + sqrt(5.0)) / 2.0;
	const double iv[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
				  {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
				  {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
	const int it[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11},
			       {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
			       {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8}, {3, 8, 9},
			       {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
	uint32_t *tri;
	size_t nt = 20;

	for (int i = 0; i < 12; i++) {
		struct vec3 p = v3_normalize(v3(iv[i][0], iv[i][1], iv[i][2]));
		tm_vert(m, p.x, p.y, p.z);
	}
	tri = malloc(3 * nt * sizeof *tri);
	for (int i = 0; i < 20; i++)
		for (int k = 0; k < 3; k++)
			tri[3 * i + k] = (uint32_t)it[i][k];
	for (int l = 0; l < level; l++) {
		/* midpoint per edge via a (small) linear-probing table */
		size_t cap = 16;
		while (cap < 6 * nt)
			cap *= 2;
		uint64_t *keys = malloc(cap * sizeof *keys);
		uint32_t *vals = malloc(cap * sizeof *vals);
		uint32_t *nw = malloc(12 * nt * sizeof *nw);
		memset(keys, 0xff, cap * sizeof *keys);
		for (size_t f = 0; f < nt; f++) {
			uint32_t mid[3];
			for (int k = 0; k < 3; k++) {
				uint64_t a = tri[3 * f + k], b = tri[3 * f + (k + 1) % 3];
				uint64_t key = a < b ? (a << 32) | b : (b << 32) | a;
				size_t h = (size_t)(key * 0x9E3779B97F4A7C15ull) & (cap - 1);
				while (keys[h] != UINT64_MAX && keys[h] != key)
					h = (h + 1) & (cap - 1);
				if (keys[h] != key) {
					struct vec3 p = v3_normalize(
						v3_scale(v3_add(m->v[a], m->v[b]), 0.5));
					keys[h] = key;
					vals[h] = tm_vert(m, p.x, p.y, p.z);
				}
				mid[k] = vals[h];
			}
			uint32_t a = tri[3 * f], b = tri[3 * f + 1], cc = tri[3 * f + 2];
			uint32_t q[12] = {a, mid[0], mid[2], mid[0], b, mid[1],
					  mid[2], mid[1], cc, mid[0], mid[1], mid[2]};
			memcpy(nw + 12 * f, q, sizeof q);
		}
		free(keys);
		free(vals);
		free(tri);
		tri = nw;
		nt *= 4;
	}
	for (size_t i = 0; i < m->nv; i++)
		m->v[i] = v3_add(c, v3_scale(m->v[i], r));
	for (size_t f = 0; f < nt; f++)
		tm_tri(m, tri[3 * f], tri[3 * f + 1], tri[3 * f + 2]);
	free(tri);
	return m;
}

/* Torus around the z axis through c: major radius R, minor r. */
static inline struct mesh *tm_torus(struct vec3 c, double R, double r, int nu, int nv)
{
	struct mesh *m = tm_new();
	for (int i = 0; i < nu; i++) {
		double u = 2 * M_PI * i / nu;
		for (int j = 0; j < nv; j++) {
			double v = 2 * M_PI * j / nv;
			tm_vert(m, c.x + (R + r * cos(v)) * cos(u), c.y + (R + r * cos(v)) * sin(u),
				c.z + r * sin(v));
		}
	}
	for (int i = 0; i < nu; i++) {
		for (int j = 0; j < nv; j++) {
			uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j);
			uint32_t cc = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv);
			uint32_t d = (uint32_t)(i * nv + (j + 1) % nv);
			tm_tri(m, a, b, cc);
			tm_tri(m, a, cc, d);
		}
	}
	return m;
}

/* Remove triangle t (swap with the last): opens the mesh. */
static inline void tm_delete_tri(struct mesh *m, size_t t)
{
	memcpy(m->tri + 3 * t, m->tri + 3 * (m->nt - 1), 3 * sizeof *m->tri);
	m->nt--;
}

static inline int tm_vcmp(const void *a, const void *b)
{
	const double *p = a, *q = b;
	for (int k = 0; k < 3; k++)
		if (p[k] != q[k])
			return p[k] < q[k] ? -1 : 1;
	return 0;
}

/* Merge exactly coincident vertices (what the driver's weld does). */
static inline void tm_weld(struct mesh *m)
{
	double (*key)[4] = malloc(m->nv * sizeof *key);
	uint32_t *map = malloc(m->nv * sizeof *map);
	size_t n = 0;

	for (size_t i = 0; i < m->nv; i++) {
		key[i][0] = m->v[i].x, key[i][1] = m->v[i].y, key[i][2] = m->v[i].z;
		key[i][3] = (double)i;
	}
	qsort(key, m->nv, sizeof *key, tm_vcmp);
	for (size_t i = 0; i < m->nv; i++) {
		if (i == 0 || tm_vcmp(key[i], key[i - 1]) != 0)
			m->v[n++] = v3(key[i][0], key[i][1], key[i][2]);
		map[(size_t)key[i][3]] = (uint32_t)(n - 1);
	}
	m->nv = n;
	for (size_t k = 0; k < 3 * m->nt; k++)
		m->tri[k] = map[m->tri[k]];
	free(key);
	free(map);
}

#endif
