/* mesh.c - the struct mesh container: lifecycle, growth, deep copy.
 *
 * Arrays grow by doubling through mem_grow(), so building a mesh one
 * vertex/triangle at a time is amortised O(1).  Capacities live in a
 * private wrapper around the public struct, which stays the plain
 * (v, tri, nv, nt) view readers and engines use.
 */
#include "engine/mesh/mesh.h"

#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* The public struct is the first member, so a struct mesh * handed out
 * by mesh_new() can be converted back to find the capacities. */
struct mesh_box {
	struct mesh m;
	size_t vcap, tcap;
};

static struct mesh_box *box_of(struct mesh *m)
{
	return (struct mesh_box *)m;
}

struct mesh *mesh_new(void)
{
	struct mesh_box *b = mem_calloc(1, sizeof *b);

	return b ? &b->m : NULL;
}

void mesh_free(struct mesh *m)
{
	if (!m)
		return;
	mem_free(m->v);
	mem_free(m->tri);
	mem_free(box_of(m));
}

int mesh_reserve(struct mesh *m, size_t nv, size_t nt)
{
	struct mesh_box *b = box_of(m);
	void *p;

	if (nv > b->vcap) {
		p = mem_realloc_array(m->v, nv, sizeof *m->v);
		if (!p)
			return ERR_NOMEM;
		m->v = p;
		b->vcap = nv;
	}
	if (nt > b->tcap) {
		if (nt > SIZE_MAX / 3)
			return ERR_NOMEM;
		p = mem_realloc_array(m->tri, 3 * nt, sizeof *m->tri);
		if (!p)
			return ERR_NOMEM;
		m->tri = p;
		b->tcap = nt;
	}
	return 0;
}

int mesh_add_vertex(struct mesh *m, struct vec3 p)
{
	struct mesh_box *b = box_of(m);
	void *arr = m->v;

	if (m->nv == b->vcap && mem_grow(&arr, &b->vcap, m->nv + 1, sizeof *m->v))
		return ERR_NOMEM;
	m->v = arr;
	m->v[m->nv++] = p;
	return 0;
}

int mesh_add_triangle(struct mesh *m, uint32_t a, uint32_t c1, uint32_t c2)
{
	struct mesh_box *b = box_of(m);

	if (m->nt == b->tcap) {
		size_t want = b->tcap ? 2 * b->tcap : 16;
		if (mesh_reserve(m, m->nv, want))
			return ERR_NOMEM;
	}
	m->tri[3 * m->nt] = a;
	m->tri[3 * m->nt + 1] = c1;
	m->tri[3 * m->nt + 2] = c2;
	m->nt++;
	return 0;
}

struct mesh *mesh_clone(const struct mesh *m)
{
	struct mesh *c = mesh_new();

	if (!c)
		return NULL;
	if (mesh_reserve(c, m->nv, m->nt)) {
		mesh_free(c);
		return NULL;
	}
	if (m->nv)
		memcpy(c->v, m->v, m->nv * sizeof *m->v);
	if (m->nt)
		memcpy(c->tri, m->tri, 3 * m->nt * sizeof *m->tri);
	c->nv = m->nv;
	c->nt = m->nt;
	return c;
}
