/* weld.c - mesh_weld: merge coincident vertices, drop collapsed triangles.
 *
 * tol 0 (exact): vertices are equal when their coordinates are bitwise
 * equal after -0 -> +0.  A 32-bit hash of the coordinates is radix sorted
 * with the vertex index (4 passes, stable); runs of equal hash whose
 * coordinates all match map to their first vertex, and the rare run with
 * a collision is sorted by full coordinates.  O(n) typical, O(n log n)
 * worst case (hostile collisions).
 * tol > 0: grid of cells 2 tol wide; vertices in index order either join
 * the nearest earlier representative within tol in the 8 cells that can
 * hold one, or become a representative.  Representatives are pairwise
 * more than tol apart, so a cell holds O(1) of them: O(n log n) overall.
 * Kept vertices keep their first-occurrence order.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* qsort context for collision runs: indices compared by coordinate bits. */
struct vkey {
	uint64_t x, y, z;
	uint32_t i;
};

static int cmp_vkey(const void *pa, const void *pb)
{
	const struct vkey *a = pa, *b = pb;

	if (a->x != b->x)
		return a->x < b->x ? -1 : 1;
	if (a->y != b->y)
		return a->y < b->y ? -1 : 1;
	if (a->z != b->z)
		return a->z < b->z ? -1 : 1;
	return (a->i > b->i) - (a->i < b->i);
}

static int exact_reps(const struct mesh *m, uint32_t *rep, struct err *e)
{
	uint64_t *key = mem_alloc(m->nv * sizeof *key);
	struct vkey *vk = NULL;
	size_t i, a, b, g, vcap = 0;
	int rc = 0;

	if (!key)
		return ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices", m->nv);
	for (i = 0; i < m->nv; i++)
		key[i] = (mesh_hash_coords(m->v[i], 0) & ~UINT64_C(0xffffffff)) | i; /* hash:32 idx:32 */
	if (mesh_sort_u64(key, m->nv, 4, 7)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices", m->nv);
		goto out;
	}
	for (a = 0; a < m->nv; a = b) {
		uint32_t first = (uint32_t)key[a];
		int all_same = 1;
		/* Vertices are visited in hash order: fetch ahead to hide the
		 * cache misses of these random accesses. */
		if (a + 32 < m->nv) {
			__builtin_prefetch(&m->v[(uint32_t)key[a + 32]]);
			__builtin_prefetch(&rep[(uint32_t)key[a + 32]], 1);
		}
		for (b = a + 1; b < m->nv && key[b] >> 32 == key[a] >> 32; b++) {
			if (b + 32 < m->nv) {
				__builtin_prefetch(&m->v[(uint32_t)key[b + 32]]);
				__builtin_prefetch(&rep[(uint32_t)key[b + 32]], 1);
			}
			all_same &= mesh_same_coords(m->v[(uint32_t)key[b]], m->v[first]);
		}
		if (all_same) {
			for (i = a; i < b; i++)
				rep[(uint32_t)key[i]] = first;
			continue;
		}
		if (b - a > vcap) { /* hash collision: sort the run by coordinates */
			mem_free(vk);
			vcap = b - a;
			vk = mem_alloc(vcap * sizeof *vk);
			if (!vk) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices",
					     m->nv);
				goto out;
			}
		}
		for (i = a; i < b; i++) {
			struct vec3 p = m->v[(uint32_t)key[i]];
			vk[i - a].x = mesh_coord_bits(p.x);
			vk[i - a].y = mesh_coord_bits(p.y);
			vk[i - a].z = mesh_coord_bits(p.z);
			vk[i - a].i = (uint32_t)key[i];
		}
		qsort(vk, b - a, sizeof *vk, cmp_vkey);
		for (i = 0, g = 0; i < b - a; i++) {
			if (vk[i].x != vk[g].x || vk[i].y != vk[g].y || vk[i].z != vk[g].z)
				g = i; /* a new group; its first entry has the smallest index */
			rep[vk[i].i] = vk[g].i;
		}
	}
out:
	mem_free(vk);
	mem_free(key);
	return rc;
}

struct cell {
	int64_t c[3];
	uint32_t i; /* vertex */
};

static int cmp_coords(const int64_t *a, const int64_t *b)
{
	int k;

	for (k = 0; k < 3; k++)
		if (a[k] != b[k])
			return a[k] < b[k] ? -1 : 1;
	return 0;
}

static int cmp_cell(const void *pa, const void *pb)
{
	const struct cell *a = pa, *b = pb;
	int r = cmp_coords(a->c, b->c);

	return r ? r : (a->i > b->i) - (a->i < b->i);
}

/* Index of the cell with coordinates c among the n sorted unique cells, or -1. */
static long find_cell(const struct cell *u, size_t n, const int64_t c[3])
{
	size_t lo = 0, hi = n;

	while (lo < hi) {
		size_t mid = lo + (hi - lo) / 2;
		int r = cmp_coords(u[mid].c, c);
		if (r == 0)
			return (long)mid;
		if (r < 0)
			lo = mid + 1;
		else
			hi = mid;
	}
	return -1;
}

static int tol_reps(const struct mesh *m, double tol, uint32_t *rep, struct err *e)
{
	double w = 2 * tol, tol2 = tol * tol;
	struct cell *cells = mem_alloc(m->nv * sizeof *cells);
	uint32_t *cell_of = mem_alloc(m->nv * sizeof *cell_of);
	uint32_t *head = NULL, *next = mem_alloc(m->nv * sizeof *next);
	size_t i, nu = 0;
	int rc = 0, k;

	if (!cells || !cell_of || !next) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices", m->nv);
		goto out;
	}
	for (i = 0; i < m->nv; i++) {
		for (k = 0; k < 3; k++) {
			double q = floor(v3_comp(m->v[i], k) / w);
			if (!(fabs(q) < 4e18)) {
				rc = ERR_FIELD(e, "tol_mm",
					       "weld tolerance %g mm is too small for coordinate %g "
					       "(or the coordinate is not finite)",
					       tol, v3_comp(m->v[i], k));
				goto out;
			}
			cells[i].c[k] = (int64_t)q;
		}
		cells[i].i = (uint32_t)i;
	}
	qsort(cells, m->nv, sizeof *cells, cmp_cell);
	/* Unique cells in place at the front; cell_of maps vertex -> cell. */
	for (i = 0; i < m->nv; i++) {
		uint32_t v = cells[i].i;
		if (nu == 0 || cmp_coords(cells[nu - 1].c, cells[i].c) != 0)
			cells[nu++] = cells[i];
		cell_of[v] = (uint32_t)(nu - 1);
	}
	head = mem_alloc(nu * sizeof *head);
	if (!head) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices", m->nv);
		goto out;
	}
	memset(head, 0xff, nu * sizeof *head);
	for (i = 0; i < m->nv; i++) {
		struct vec3 p = m->v[i];
		const int64_t *c = cells[cell_of[i]].c;
		int64_t side[3];
		uint32_t best = UINT32_MAX;
		double best_d2 = tol2;
		int s;
		for (k = 0; k < 3; k++) /* the neighbour on the nearer side of each axis */
			side[k] = v3_comp(p, k) / w - (double)c[k] < 0.5 ? -1 : 1;
		for (s = 0; s < 8; s++) {
			int64_t q[3];
			long cidx;
			uint32_t r;
			for (k = 0; k < 3; k++)
				q[k] = c[k] + ((s >> k) & 1 ? side[k] : 0);
			cidx = s == 0 ? (long)cell_of[i] : find_cell(cells, nu, q);
			if (cidx < 0)
				continue;
			for (r = head[cidx]; r != UINT32_MAX; r = next[r]) {
				double d2 = v3_len2(v3_sub(m->v[r], p));
				if (d2 < best_d2 || (d2 == best_d2 && (best == UINT32_MAX || r < best))) {
					best_d2 = d2;
					best = r;
				}
			}
		}
		if (best != UINT32_MAX) {
			rep[i] = best;
		} else {
			rep[i] = (uint32_t)i;
			next[i] = head[cell_of[i]];
			head[cell_of[i]] = (uint32_t)i;
		}
	}
out:
	mem_free(head);
	mem_free(next);
	mem_free(cell_of);
	mem_free(cells);
	return rc;
}

int mesh_weld(struct mesh *m, double tol_mm, size_t *merged_vertices, size_t *dropped_triangles,
	      struct err *e)
{
	uint32_t *rep = NULL;
	size_t i, k = 0, t, kept = 0;
	int rc;

	if (!(tol_mm >= 0) || !isfinite(tol_mm))
		return ERR_FIELD(e, "tol_mm", "weld tolerance must be finite and >= 0, not %g",
				 tol_mm);
	if (m->nv > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "too many vertices to weld (%zu)", m->nv);
	for (t = 0; t < 3 * m->nt; t++)
		if (m->tri[t] >= m->nv)
			return ERR_SET(e, ERR_INTERNAL, "triangle %zu refers to vertex %u of %zu",
				       t / 3, m->tri[t], m->nv);
	if (m->nv) {
		rep = mem_alloc(m->nv * sizeof *rep);
		if (!rep)
			return ERR_SET(e, ERR_NOMEM, "out of memory welding %zu vertices", m->nv);
		rc = tol_mm == 0 ? exact_reps(m, rep, e) : tol_reps(m, tol_mm, rep, e);
		if (rc)
			goto out;
		/* rep[i] <= i: compact in place, rep[] becomes the new index. */
		for (i = 0; i < m->nv; i++) {
			if (rep[i] == i) {
				m->v[k] = m->v[i];
				rep[i] = (uint32_t)k++;
			} else {
				rep[i] = rep[rep[i]];
			}
		}
	}
	for (t = 0; t < m->nt; t++) {
		uint32_t a = m->tri[3 * t], b = m->tri[3 * t + 1], c = m->tri[3 * t + 2];
		a = rep[a];
		b = rep[b];
		c = rep[c];
		if (a == b || b == c || c == a)
			continue;
		m->tri[3 * kept] = a;
		m->tri[3 * kept + 1] = b;
		m->tri[3 * kept + 2] = c;
		kept++;
	}
	if (merged_vertices)
		*merged_vertices = m->nv - k;
	if (dropped_triangles)
		*dropped_triangles = m->nt - kept;
	m->nv = k;
	m->nt = kept;
	rc = 0;
out:
	mem_free(rep);
	return rc;
}
