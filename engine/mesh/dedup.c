/* dedup.c - sharing of bitwise-identical corners while an STL is read.
 *
 * An STL is a triangle soup: without sharing, a 1M-triangle file becomes
 * 3M vertices (72 MB) that mesh_weld() then merges.  Readers instead look
 * each corner up in an open-addressing table keyed by its coordinate bits
 * (-0 as +0, as mesh_weld does).  The hash is seeded per table (address
 * entropy), so crafted collisions cannot be prepared; should probing
 * still exceed 16 probes per corner on average, sharing switches off and
 * the rest is appended as a soup (mesh_weld still merges it): never
 * quadratic.  Vertex order = first occurrence, whatever the seed.
 */
#include "engine/mesh/mesh_int.h"

#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

void mesh_dedup_init(struct mesh_dedup *d)
{
	memset(d, 0, sizeof *d);
	d->seed = mesh_mix64((uint64_t)(uintptr_t)d ^ UINT64_C(0x9e3779b97f4a7c15));
}

void mesh_dedup_fini(struct mesh_dedup *d)
{
	mem_free(d->slot);
	memset(d, 0, sizeof *d);
}

/* Double the table (or create it) and re-insert the known vertices. */
static int grow(struct mesh_dedup *d, const struct mesh *m)
{
	size_t n = d->mask ? 2 * (d->mask + 1) : 1024, i;
	uint32_t *s = mem_alloc(n * sizeof *s);

	if (!s)
		return ERR_NOMEM;
	memset(s, 0xff, n * sizeof *s);
	for (i = 0; i < m->nv; i++) {
		size_t h = (size_t)mesh_hash_coords(m->v[i], d->seed) & (n - 1);
		while (s[h] != UINT32_MAX)
			h = (h + 1) & (n - 1);
		s[h] = (uint32_t)i;
	}
	mem_free(d->slot);
	d->slot = s;
	d->mask = n - 1;
	return 0;
}

void mesh_dedup_prefetch(const struct mesh_dedup *d, struct vec3 p)
{
	if (d->slot && !d->off)
		__builtin_prefetch(&d->slot[(size_t)mesh_hash_coords(p, d->seed) & d->mask]);
}

int mesh_dedup_add(struct mesh_dedup *d, struct mesh *m, struct vec3 p, uint32_t *idx)
{
	size_t h;

	if (!d->off) {
		if (2 * (m->nv + 1) > d->mask && grow(d, m))
			return ERR_NOMEM;
		d->lookups++;
		for (h = (size_t)mesh_hash_coords(p, d->seed) & d->mask; d->slot[h] != UINT32_MAX;
		     h = (h + 1) & d->mask) {
			if (mesh_same_coords(m->v[d->slot[h]], p)) {
				*idx = d->slot[h];
				return 0;
			}
			if (++d->probes > 16 * d->lookups + 4096) {
				d->off = 1; /* pathological probing: stop sharing */
				break;
			}
		}
		if (!d->off)
			d->slot[h] = (uint32_t)m->nv;
	}
	if (mesh_add_vertex(m, p))
		return ERR_NOMEM;
	*idx = (uint32_t)(m->nv - 1);
	return 0;
}
