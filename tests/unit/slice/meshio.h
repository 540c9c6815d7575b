/* meshio.h - a minimal OFF / binary-STL loader and placement for the
 * slice tests and benchmark (header-only, static).  Test scaffolding
 * only, trusting the shared meshes: the product reads meshes with
 * engine/mesh (mesh_read_file, mesh_repair, mesh_place); once that
 * module is on main these helpers defer to it.
 */
#ifndef INFILLD_TEST_MESHIO_H
#define INFILLD_TEST_MESHIO_H

#include <stdio.h>
#include <string.h>

#include "meshgen.h"

static inline struct mesh *tm_read_off(const char *path)
{
	FILE *f = fopen(path, "r");
	struct mesh *m;
	char magic[8];
	long nv, nf, ne;

	if (!f)
		return NULL;
	if (fscanf(f, "%7s %ld %ld %ld", magic, &nv, &nf, &ne) != 4 || strcmp(magic, "OFF") != 0) {
		fclose(f);
		return NULL;
	}
	m = tm_new();
	for (long i = 0; i < nv; i++) {
		double x, y, z;
		if (fscanf(f, "%lf %lf %lf", &x, &y, &z) != 3)
			goto bad;
		tm_vert(m, x, y, z);
	}
	for (long i = 0; i < nf; i++) {
		long n, a, b, c;
		if (fscanf(f, "%ld %ld %ld", &n, &a, &b) != 3 || n < 3)
			goto bad;
		for (long k = 2; k < n; k++) { /* fan */
			if (fscanf(f, "%ld", &c) != 1)
				goto bad;
			tm_tri(m, (uint32_t)a, (uint32_t)b, (uint32_t)c);
			b = c;
		}
	}
	fclose(f);
	return m;
bad:
	fclose(f);
	tm_free(m);
	return NULL;
}

static inline struct mesh *tm_read_stl(const char *path)
{
	FILE *f = fopen(path, "rb");
	struct mesh *m;
	unsigned char hdr[84], rec[50];
	uint32_t n;

	if (!f)
		return NULL;
	if (fread(hdr, 1, 84, f) != 84) {
		fclose(f);
		return NULL;
	}
	memcpy(&n, hdr + 80, 4);
	m = tm_new();
	for (uint32_t t = 0; t < n; t++) {
		float v[9];
		uint32_t id[3];
		if (fread(rec, 1, 50, f) != 50) {
			fclose(f);
			tm_free(m);
			return NULL;
		}
		memcpy(v, rec + 12, sizeof v);
		for (int k = 0; k < 3; k++)
			id[k] = tm_vert(m, v[3 * k], v[3 * k + 1], v[3 * k + 2]);
		tm_tri(m, id[0], id[1], id[2]);
	}
	fclose(f);
	tm_weld(m);
	return m;
}

/* Drop triangles with a repeated corner (left by welding). */
static inline void tm_drop_degenerate(struct mesh *m)
{
	for (size_t t = 0; t < m->nt;) {
		uint32_t *c = m->tri + 3 * t;
		if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0])
			tm_delete_tri(m, t);
		else
			t++;
	}
}

/* Read by extension, make +y up files +z up (proper rotation), scale to
 * height_mm, stand on z = 0 centred at (cx, cy). */
static inline struct mesh *tm_load(const char *path, int y_up, double height_mm, double cx,
				   double cy)
{
	size_t len = strlen(path);
	struct mesh *m = len > 4 && strcmp(path + len - 4, ".stl") == 0 ? tm_read_stl(path)
									   : tm_read_off(path);
	struct box3 b = box3_empty();
	double s;

	if (!m)
		return NULL;
	tm_drop_degenerate(m);
	for (size_t i = 0; i < m->nv; i++) {
		if (y_up)
			m->v[i] = v3(m->v[i].x, -m->v[i].z, m->v[i].y);
		box3_add(&b, m->v[i]);
	}
	s = height_mm / (b.hi.z - b.lo.z);
	for (size_t i = 0; i < m->nv; i++)
		m->v[i] = v3((m->v[i].x - (b.lo.x + b.hi.x) / 2) * s + cx,
			     (m->v[i].y - (b.lo.y + b.hi.y) / 2) * s + cy, (m->v[i].z - b.lo.z) * s);
	return m;
}

#endif
