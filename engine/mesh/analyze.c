/* analyze.c - mesh_analyze: measures and topology of a triangle mesh.
 *
 * Volume by the divergence theorem, sum of (a-o).((b-o)x(c-o))/6 with o
 * the bbox centre (same value for a closed mesh, less cancellation);
 * edge classes from the undirected edge table (edges.c); components by
 * union-find over faces sharing any edge.  Definitions: docs/mesh.md.
 * O(n) plus the edge table's per-vertex sorts.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

static uint32_t uf_find(uint32_t *parent, uint32_t x)
{
	while (parent[x] != x) {
		parent[x] = parent[parent[x]]; /* path halving */
		x = parent[x];
	}
	return x;
}

static void uf_union(uint32_t *parent, uint32_t a, uint32_t b)
{
	a = uf_find(parent, a);
	b = uf_find(parent, b);
	/* Smaller index becomes the root: deterministic, and with path
	 * halving the amortised cost stays near-constant in practice. */
	if (a < b)
		parent[b] = a;
	else if (b < a)
		parent[a] = b;
}

void mesh_mass(const struct mesh *m, double *vol_mm3, struct vec3 *moment_mm4)
{
	double V = 0;
	struct vec3 M = v3(0, 0, 0);

	for (size_t t = 0; t < m->nt; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], b = m->v[m->tri[3 * t + 1]],
			    c = m->v[m->tri[3 * t + 2]];
		/* signed tetrahedron (origin, a, b, c): volume, centroid (a+b+c)/4 */
		double v6 = v3_dot(a, v3_cross(b, c)) / 6;
		V += v6;
		M = v3_madd(M, v3_add(v3_add(a, b), c), v6 / 4);
	}
	*vol_mm3 = V;
	*moment_mm4 = M;
}

int mesh_analyze(const struct mesh *m, struct mesh_report *out, struct err *e)
{
	struct mesh_report r;
	struct mesh_edges ed;
	uint32_t *parent = NULL;
	struct vec3 o;
	size_t t, v;
	double vol = 0, area = 0;
	int rc;

	memset(&r, 0, sizeof r);
	r.triangles = m->nt;
	r.vertices = m->nv;
	r.bbox = box3_empty();
	for (t = 0; t < 3 * m->nt; t++) {
		struct vec3 p;
		if (m->tri[t] >= m->nv)
			return ERR_SET(e, ERR_GEOMETRY, "triangle %zu refers to vertex %u of %zu",
				       t / 3, m->tri[t], m->nv);
		/* plain comparisons: fmin/fmax are library calls (NaN rules) */
		p = m->v[m->tri[t]];
		r.bbox.lo.x = p.x < r.bbox.lo.x ? p.x : r.bbox.lo.x;
		r.bbox.lo.y = p.y < r.bbox.lo.y ? p.y : r.bbox.lo.y;
		r.bbox.lo.z = p.z < r.bbox.lo.z ? p.z : r.bbox.lo.z;
		r.bbox.hi.x = p.x > r.bbox.hi.x ? p.x : r.bbox.hi.x;
		r.bbox.hi.y = p.y > r.bbox.hi.y ? p.y : r.bbox.hi.y;
		r.bbox.hi.z = p.z > r.bbox.hi.z ? p.z : r.bbox.hi.z;
	}
	o = m->nt ? box3_center(r.bbox) : v3(0, 0, 0);
	for (t = 0; t < m->nt; t++) {
		struct vec3 a = v3_sub(m->v[m->tri[3 * t]], o), b = v3_sub(m->v[m->tri[3 * t + 1]], o),
			    c = v3_sub(m->v[m->tri[3 * t + 2]], o);
		vol += v3_dot(a, v3_cross(b, c));
		area += v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
		r.degenerate_faces += (size_t)mesh_tri_degenerate(m, t);
	}
	r.volume_mm3 = vol / 6;
	r.area_mm2 = area / 2;
	if ((rc = mesh_edges_build(m, &ed, e)))
		return rc;
	parent = mem_alloc((m->nt ? m->nt : 1) * sizeof *parent);
	if (!parent) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory analysing %zu triangles", m->nt);
		goto out;
	}
	for (t = 0; t < m->nt; t++)
		parent[t] = (uint32_t)t;
	for (v = 0; v < ed.nv; v++) {
		size_t a = ed.off[v], end = ed.off[v + 1], b;
		for (; a < end; a = b) {
			size_t fwd = 0, n;
			for (b = a; b < end && MESH_EDGE_OTHER(ed.rec[b]) == MESH_EDGE_OTHER(ed.rec[a]);
			     b++) {
				fwd += (ed.rec[b] & MESH_EDGE_FWD) != 0;
				if (b > a)
					uf_union(parent, (uint32_t)(MESH_EDGE_CORNER(ed.rec[a]) / 3),
						 (uint32_t)(MESH_EDGE_CORNER(ed.rec[b]) / 3));
			}
			n = b - a;
			r.edges++;
			if (n == 1)
				r.border_edges++;
			else if (n > 2)
				r.nonmanifold_edges++;
			else if (fwd != 1)
				r.inconsistent_edges++;
		}
	}
	for (t = 0; t < m->nt; t++)
		r.components += parent[t] == t;
	r.watertight = m->nt > 0 && r.border_edges == 0 && r.nonmanifold_edges == 0 &&
		       r.inconsistent_edges == 0;
	*out = r;
	rc = 0;
out:
	mem_free(parent);
	mesh_edges_fini(&ed);
	return rc;
}
