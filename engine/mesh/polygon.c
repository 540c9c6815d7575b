/* polygon.c - polygon faces of OBJ/OFF/PLY: fan while parsing, ear clipping after.
 *
 * While parsing, a k-gon becomes the fan (c0, ci, ci+1); its corners are
 * kept.  Once all vertices are known, each kept polygon is projected on
 * the plane of its Newell normal (dropping the dominant axis, sign chosen
 * so the polygon is counter-clockwise) and re-triangulated in place:
 * convex polygons fan from a strictly convex corner (so collinear corners
 * give no zero-area triangles), non-convex ones with at most
 * MESH_EAR_MAX_CORNERS corners are ear-clipped (O(k^2): ear flags are
 * cached and only the two neighbours of a clipped ear are re-tested).  A
 * self-intersecting polygon with no ear left keeps a fan for the rest.
 */
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

void mesh_faces_init(struct mesh_faces *f, struct mesh *m)
{
	memset(f, 0, sizeof *f);
	f->m = m;
}

void mesh_faces_fini(struct mesh_faces *f)
{
	mem_free(f->corners);
	mem_free(f->polys);
	memset(f, 0, sizeof *f);
}

int mesh_faces_add(struct mesh_faces *f, const uint32_t *idx, size_t k, struct err *e)
{
	struct mesh *m = f->m;
	void *arr;
	size_t i;

	if (k - 2 > MESH_MAX_TRIANGLES - m->nt)
		return ERR_SET(e, ERR_LIMIT, "more than the limit of %u triangles",
			       MESH_MAX_TRIANGLES);
	if (k > 3) {
		arr = f->corners;
		if (mem_grow(&arr, &f->ccap, f->ncorners + k, sizeof *f->corners))
			goto nomem;
		f->corners = arr;
		arr = f->polys;
		if (mem_grow(&arr, &f->pcap, f->npolys + 1, sizeof *f->polys))
			goto nomem;
		f->polys = arr;
		f->polys[f->npolys].first_tri = m->nt;
		f->polys[f->npolys].first_corner = f->ncorners;
		f->polys[f->npolys].k = (uint32_t)k;
		f->npolys++;
		memcpy(f->corners + f->ncorners, idx, k * sizeof *idx);
		f->ncorners += k;
		f->polygons_split++;
	}
	for (i = 1; i + 1 < k; i++)
		if (mesh_add_triangle(m, idx[0], idx[i], idx[i + 1]))
			goto nomem;
	return 0;
nomem:
	return ERR_SET(e, ERR_NOMEM, "out of memory storing polygon faces");
}

struct pt {
	double x, y;
};

static double cross3(struct pt a, struct pt b, struct pt c)
{
	return (b.x - a.x) * (c.y - b.y) - (b.y - a.y) * (c.x - b.x);
}

/* p inside or on triangle abc (counter-clockwise)? */
static int in_triangle(struct pt p, struct pt a, struct pt b, struct pt c)
{
	double d1 = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
	double d2 = (c.x - b.x) * (p.y - b.y) - (c.y - b.y) * (p.x - b.x);
	double d3 = (a.x - c.x) * (p.y - c.y) - (a.y - c.y) * (p.x - c.x);

	return d1 >= 0 && d2 >= 0 && d3 >= 0;
}

static int same_pt(struct pt a, struct pt b)
{
	return a.x == b.x && a.y == b.y;
}

struct ear_state {
	struct pt p[MESH_EAR_MAX_CORNERS];
	int prev[MESH_EAR_MAX_CORNERS], next[MESH_EAR_MAX_CORNERS];
	unsigned char ear[MESH_EAR_MAX_CORNERS];
};

static int is_ear(const struct ear_state *s, int b)
{
	int a = s->prev[b], c = s->next[b], q;

	if (cross3(s->p[a], s->p[b], s->p[c]) <= 0)
		return 0;
	for (q = s->next[c]; q != a; q = s->next[q]) {
		struct pt x = s->p[q];
		if (same_pt(x, s->p[a]) || same_pt(x, s->p[b]) || same_pt(x, s->p[c]))
			continue;
		if (in_triangle(x, s->p[a], s->p[b], s->p[c]))
			return 0;
	}
	return 1;
}

static struct pt project(const struct vec3 *v, uint32_t ci, int ax, double sgn)
{
	struct vec3 q = v[ci];
	struct pt r;

	r.x = ax == 0 ? q.y : ax == 1 ? q.z : q.x;
	r.y = ax == 0 ? q.z : ax == 1 ? q.x : q.y;
	if (sgn < 0)
		r.y = -r.y;
	return r;
}

static void fan(const uint32_t *c, size_t k, size_t apex, uint32_t *out)
{
	size_t i;

	for (i = 1; i + 1 < k; i++) {
		out[3 * (i - 1)] = c[apex];
		out[3 * (i - 1) + 1] = c[(apex + i) % k];
		out[3 * (i - 1) + 2] = c[(apex + i + 1) % k];
	}
}

/* Ear clipping of a k-gon, k <= MESH_EAR_MAX_CORNERS, into out. */
static void ear_clip(const struct vec3 *v, const uint32_t *c, int k, int ax, double sgn,
		     uint32_t *out)
{
	struct ear_state s;
	int i, left = k, w = 0, cur = 0, guard, first, q;

	for (i = 0; i < k; i++) {
		s.p[i] = project(v, c[i], ax, sgn);
		s.prev[i] = (i + k - 1) % k;
		s.next[i] = (i + 1) % k;
	}
	for (i = 0; i < k; i++)
		s.ear[i] = (unsigned char)is_ear(&s, i);
	while (left > 3) {
		for (guard = 0; guard < left && !s.ear[cur]; guard++)
			cur = s.next[cur];
		if (guard == left)
			break; /* no ear: self-intersecting; fan the rest */
		out[3 * w] = c[s.prev[cur]];
		out[3 * w + 1] = c[cur];
		out[3 * w + 2] = c[s.next[cur]];
		w++;
		s.next[s.prev[cur]] = s.next[cur];
		s.prev[s.next[cur]] = s.prev[cur];
		left--;
		i = s.prev[cur];
		cur = s.next[cur];
		s.ear[i] = (unsigned char)is_ear(&s, i);
		s.ear[cur] = (unsigned char)is_ear(&s, cur);
	}
	/* The remaining corners in ring order, fanned. */
	for (first = cur, q = s.next[cur]; s.next[q] != first; q = s.next[q], w++) {
		out[3 * w] = c[first];
		out[3 * w + 1] = c[q];
		out[3 * w + 2] = c[s.next[q]];
	}
}

/* Triangulate one kept polygon of k corners into out[3 * (k - 2)]. */
static void triangulate(const struct mesh *m, const uint32_t *c, size_t k, uint32_t *out,
			size_t *nonconvex_fanned)
{
	struct vec3 n = v3(0, 0, 0);
	size_t i, apex = k;
	int ax, convex = 1;
	double sgn;

	for (i = 0; i < k; i++) { /* Newell normal */
		struct vec3 a = m->v[c[i]], b = m->v[c[(i + 1) % k]];
		n.x += (a.y - b.y) * (a.z + b.z);
		n.y += (a.z - b.z) * (a.x + b.x);
		n.z += (a.x - b.x) * (a.y + b.y);
	}
	ax = fabs(n.x) > fabs(n.y) ? (fabs(n.x) > fabs(n.z) ? 0 : 2)
				   : (fabs(n.y) > fabs(n.z) ? 1 : 2);
	sgn = v3_comp(n, ax);
	if (!(sgn != 0)) { /* zero net area (or NaN): keep the fan */
		fan(c, k, 0, out);
		return;
	}
	for (i = 0; i < k; i++) {
		double t = cross3(project(m->v, c[(i + k - 1) % k], ax, sgn),
				  project(m->v, c[i], ax, sgn),
				  project(m->v, c[(i + 1) % k], ax, sgn));
		if (t < 0)
			convex = 0;
		else if (t > 0 && apex == k)
			apex = i;
	}
	if (convex && apex < k)
		fan(c, k, apex, out);
	else if (k <= MESH_EAR_MAX_CORNERS)
		ear_clip(m->v, c, (int)k, ax, sgn, out);
	else {
		(*nonconvex_fanned)++;
		fan(c, k, 0, out);
	}
}

int mesh_faces_finish(struct mesh_faces *f, struct err *e)
{
	size_t i;

	(void)e;
	for (i = 0; i < f->npolys; i++) {
		const struct mesh_poly *p = &f->polys[i];
		triangulate(f->m, f->corners + p->first_corner, p->k,
			    f->m->tri + 3 * p->first_tri, &f->nonconvex_fanned);
	}
	return 0;
}
