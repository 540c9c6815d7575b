/* carve.c - the carving operator (paper 001 section 4.2): cavities of the
 * leaves as exact layer polygons and as closed prisms of a mesh
 * (docs/rhombic.md section 4).
 *
 * A cavity |u - cu|/a + |z - cz|/b <= k, v in [vlo, vhi] cut by the plane
 * z is the rectangle u in cu -+ a (k - |z - cz|/b), v in [vlo, vhi]: its
 * sides along u shrink at dz/du = b/a = tan(pi/2 - alpha), the overhang
 * bound, and its ceiling ends in a ridge along v.
 */
#include "engine/rhombic/rhombic.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int cmp_zlo(const void *pa, const void *pb)
{
	const struct rh_cavity *a = pa, *b = pb;

	return a->zlo < b->zlo ? -1 : a->zlo > b->zlo ? 1 : 0;
}

int rh_carve_init(struct rh_carve *cr, const struct rh_tree *t, struct err *e)
{
	memset(cr, 0, sizeof *cr);
	cr->f = t->f;
	paths_init(&cr->rects);
	cr->last_z = -INFINITY;
	for (size_t i = 0; i < t->n; i++)
		cr->n += t->c[i].state == RH_CAVITY;
	if (!cr->n)
		return 0;
	cr->cv = mem_alloc(cr->n * sizeof *cr->cv);
	cr->active = mem_alloc(cr->n * sizeof *cr->active);
	if (!cr->cv || !cr->active) {
		rh_carve_fini(cr);
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for %zu cavities", t->cavities);
	}
	cr->n = 0;
	for (size_t i = 0; i < t->n; i++)
		if (t->c[i].state == RH_CAVITY)
			rh_cell_cavity(&t->f, &t->c[i], &cr->cv[cr->n++]);
	qsort(cr->cv, cr->n, sizeof *cr->cv, cmp_zlo);
	return 0;
}

void rh_carve_fini(struct rh_carve *cr)
{
	mem_free(cr->cv);
	mem_free(cr->active);
	paths_fini(&cr->rects);
	memset(cr, 0, sizeof *cr);
}

int rh_cavity_section(const struct rh_cavity *cv, double z_mm, double *half_u_mm)
{
	if (!(z_mm > cv->zlo && z_mm < cv->zhi))
		return 0;
	*half_u_mm = cv->a * (cv->k - fabs(z_mm - cv->cz) / cv->b);
	return *half_u_mm > 0;
}

int rh_carve_rects(struct rh_carve *cr, double z_mm, struct paths *out, struct err *e)
{
	size_t keep = 0;

	paths_clear(out);
	if (z_mm < cr->last_z) { /* restart the sweep */
		cr->next = 0;
		cr->nactive = 0;
	}
	cr->last_z = z_mm;
	while (cr->next < cr->n && cr->cv[cr->next].zlo < z_mm)
		cr->active[cr->nactive++] = cr->next++;
	for (size_t q = 0; q < cr->nactive; q++) {
		const struct rh_cavity *cv = &cr->cv[cr->active[q]];
		struct pt2 pts[4];
		double hw;
		if (cv->zhi <= z_mm)
			continue; /* passed: drop it */
		cr->active[keep++] = cr->active[q];
		/* a rectangle under a nanometre wide adds nothing */
		if (!rh_cavity_section(cv, z_mm, &hw) || hw < 1e-6)
			continue;
		for (int c = 0; c < 4; c++) {
			/* counter-clockwise in (u, v), so in (x, y): a rotation */
			double u = cv->cu + ((c == 1 || c == 2) ? hw : -hw);
			double v = c >= 2 ? cv->vhi : cv->vlo, x, y;
			rh_to_printer(&cr->f, u, v, &x, &y);
			pts[c].x = geom_mm_to_nm(x);
			pts[c].y = geom_mm_to_nm(y);
		}
		if (paths_add_pts(out, pts, 4))
			return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for a layer's cavities");
	}
	cr->nactive = keep;
	return 0;
}

/* Signed volume of triangles tri[0..nt) of v (divergence theorem). */
static double tri_volume(const struct vec3 *v, const uint32_t *tri, size_t nt)
{
	double s = 0;

	for (size_t i = 0; i < nt; i++)
		s += v3_dot(v[tri[3 * i]], v3_cross(v[tri[3 * i + 1]], v[tri[3 * i + 2]]));
	return s / 6;
}

int rh_carve_mesh(const struct rh_carve *cr, const struct mesh *part, struct mesh **out,
		  struct err *e)
{
	struct mesh *m = mesh_clone(part);

	if (!m || mesh_reserve(m, part->nv + 8 * cr->n, part->nt + 12 * cr->n)) {
		mesh_free(m);
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for the result mesh");
	}
	for (size_t q = 0; q < cr->n; q++) {
		const struct rh_cavity *cv = &cr->cv[q];
		/* rhombus corners in (u, z), counter-clockwise; 0-3 at vlo, 4-7 at vhi */
		const double du[4] = {cv->a * cv->k, 0, -cv->a * cv->k, 0};
		const double dz[4] = {0, cv->b * cv->k, 0, -cv->b * cv->k};
		uint32_t base = (uint32_t)m->nv, tri[36];
		struct vec3 pv[8];
		int nt = 0;
		for (int c = 0; c < 8; c++) {
			double x, y;
			rh_to_printer(&cr->f, cv->cu + du[c & 3], c < 4 ? cv->vlo : cv->vhi, &x, &y);
			pv[c] = v3(x, y, cv->cz + dz[c & 3]);
		}
		/* caps, then the four sides; every edge traversed once each way */
		static const uint32_t faces[12][3] = {
			{0, 1, 2}, {0, 2, 3}, {4, 6, 5}, {4, 7, 6}, {1, 0, 4}, {1, 4, 5},
			{2, 1, 5}, {2, 5, 6}, {3, 2, 6}, {3, 6, 7}, {0, 3, 7}, {0, 7, 4}};
		for (int f = 0; f < 12; f++)
			for (int c = 0; c < 3; c++)
				tri[nt++] = faces[f][c];
		/* facing into the cavity: a negative volume */
		if (tri_volume(pv, tri, 12) > 0)
			for (int f = 0; f < 12; f++) {
				uint32_t s = tri[3 * f + 1];
				tri[3 * f + 1] = tri[3 * f + 2];
				tri[3 * f + 2] = s;
			}
		for (int c = 0; c < 8; c++)
			if (mesh_add_vertex(m, pv[c]))
				goto nomem;
		for (int f = 0; f < 12; f++)
			if (mesh_add_triangle(m, base + tri[3 * f], base + tri[3 * f + 1],
					      base + tri[3 * f + 2]))
				goto nomem;
	}
	*out = m;
	return 0;
nomem:
	mesh_free(m);
	return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for the result mesh");
}
