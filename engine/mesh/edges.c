/* edges.c - undirected edge table of a triangle mesh, facet adjacency across
 * edges (mesh_facet_neighbours), and the degeneracy test.
 *
 * Counting sort of the 3 nt directed edges by their smaller vertex (CSR),
 * then each vertex's short list is sorted by the larger vertex: O(n) for
 * bounded degree, O(d log d) for a vertex of degree d, so a hostile fan
 * around one vertex stays n log n.  Shared by analysis and repair.
 */
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

	return (x > y) - (x < y);
}

static void sort_small(uint64_t *r, size_t n)
{
	size_t i, j;

	if (n > 24) {
		qsort(r, n, sizeof *r, cmp_u64);
		return;
	}
	for (i = 1; i < n; i++) {
		uint64_t x = r[i];
		for (j = i; j > 0 && r[j - 1] > x; j--)
			r[j] = r[j - 1];
		r[j] = x;
	}
}

int mesh_edges_build(const struct mesh *m, struct mesh_edges *ed, struct err *e)
{
	size_t t, v, n = 0;
	int k;

	memset(ed, 0, sizeof *ed);
	if (m->nt > MESH_MAX_TRIANGLES || m->nv > MESH_MAX_VERTICES)
		return ERR_SET(e, ERR_LIMIT, "mesh too large for the edge table (%zu triangles)",
			       m->nt);
	ed->nv = m->nv;
	ed->off = mem_calloc(m->nv + 1, sizeof *ed->off);
	ed->rec = mem_alloc((m->nt > 0 ? 3 * m->nt : 1) * sizeof *ed->rec);
	if (!ed->off || !ed->rec) {
		mesh_edges_fini(ed);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the edges of %zu triangles", m->nt);
	}
	for (t = 0; t < m->nt; t++)
		for (k = 0; k < 3; k++) {
			uint32_t a = m->tri[3 * t + (size_t)k], b = m->tri[3 * t + (size_t)(k + 1) % 3];
			if (a != b)
				ed->off[(a < b ? a : b) + 1]++;
		}
	for (v = 0; v < m->nv; v++)
		ed->off[v + 1] += ed->off[v];
	for (t = 0; t < m->nt; t++)
		for (k = 0; k < 3; k++) {
			uint32_t a = m->tri[3 * t + (size_t)k], b = m->tri[3 * t + (size_t)(k + 1) % 3];
			uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
			if (a == b)
				continue;
			/* off[lo] is used as the fill cursor, restored below. */
			ed->rec[ed->off[lo]++] = (uint64_t)hi << 32 | (a < b ? MESH_EDGE_FWD : 0) |
						 (uint64_t)(3 * t + (size_t)k);
			n++;
		}
	for (v = m->nv; v > 0; v--)
		ed->off[v] = ed->off[v - 1];
	ed->off[0] = 0;
	for (v = 0; v < m->nv; v++)
		sort_small(ed->rec + ed->off[v], ed->off[v + 1] - ed->off[v]);
	ed->nrec = n;
	return 0;
}

void mesh_edges_fini(struct mesh_edges *ed)
{
	mem_free(ed->off);
	mem_free(ed->rec);
	memset(ed, 0, sizeof *ed);
}

int mesh_facet_neighbours(const struct mesh *m, uint32_t *nb, struct err *e)
{
	struct mesh_edges ed;
	size_t v, i;
	int rc;

	if ((rc = mesh_edges_build(m, &ed, e)))
		return rc;
	for (i = 0; i < 3 * m->nt; i++)
		nb[i] = MESH_NO_FACET;
	for (v = 0; v < ed.nv; v++) {
		size_t a = ed.off[v], end = ed.off[v + 1], b;
		for (; a < end; a = b) {
			/* a vertex's records are sorted by the other end first */
			for (b = a; b < end && MESH_EDGE_OTHER(ed.rec[b]) == MESH_EDGE_OTHER(ed.rec[a]);
			     b++)
				;
			if (b - a == 2) {
				size_t c0 = MESH_EDGE_CORNER(ed.rec[a]), c1 = MESH_EDGE_CORNER(ed.rec[a + 1]);
				nb[c0] = (uint32_t)(c1 / 3);
				nb[c1] = (uint32_t)(c0 / 3);
			}
		}
	}
	mesh_edges_fini(&ed);
	return 0;
}

int mesh_tri_degenerate(const struct mesh *m, size_t t)
{
	const uint32_t *c = m->tri + 3 * t;
	struct vec3 a, b, d, ab, bd, da;
	double l2;

	if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0])
		return 1;
	a = m->v[c[0]];
	b = m->v[c[1]];
	d = m->v[c[2]];
	ab = v3_sub(b, a);
	bd = v3_sub(d, b);
	da = v3_sub(a, d);
	l2 = v3_len2(ab);
	l2 = v3_len2(bd) > l2 ? v3_len2(bd) : l2;
	l2 = v3_len2(da) > l2 ? v3_len2(da) : l2;
	return !(v3_len(v3_cross(ab, v3_sub(d, a))) > 1e-12 * l2);
}
