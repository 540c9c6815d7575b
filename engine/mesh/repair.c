/* repair.c - mesh_repair: weld, drop degenerate faces, orient consistently and outward.
 *
 * 1. exact weld (weld.c); 2. zero-area caps removed by splitting their
 *    neighbour (the surface stays closed), other zero-area faces dropped;
 * 3. breadth-first search over manifold edges: a neighbour across an
 *    edge both faces traverse the same way is flipped; per orientation
 *    component the smaller of the two consistent choices is applied;
 * 4. outward: each component's signed volume (about its own bbox centre)
 *    must be positive, or negative when it is nested inside an odd number
 *    of closed components (a cavity).  Nesting uses the exact winding
 *    number of each closed component at a point of the other, for
 *    candidates whose bbox contains that point, within a work budget.
 * Steps and what is recorded: docs/mesh.md.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define NO_NBR UINT32_MAX
#define NBR_SAME (UINT32_C(1) << 31) /* neighbour traverses the edge the same way */

/* Work budget for cavity nesting tests, in triangle solid angles. */
#define NEST_BUDGET(nt) (32 * (nt) + 4000000u)

static void flip_face(struct mesh *m, size_t t)
{
	uint32_t x = m->tri[3 * t + 1];

	m->tri[3 * t + 1] = m->tri[3 * t + 2];
	m->tri[3 * t + 2] = x;
}

/* Zero-area faces with three distinct corners are caps: one corner m
 * lies on the segment between the other two (u, w).  Instead of leaving a
 * zero-area hole, the face across u-w (p, q, x) is split at m into
 * (p, m, x) and (m, q, x), the cap's slot taking the second half: the
 * surface stays closed and the triangle count is unchanged.  Only caps
 * whose long edge is manifold with a sound neighbour are handled; a face
 * or vertex is touched at most once per pass (the edge table is then
 * stale); up to three passes.  *fixed = caps removed. */
static int split_caps(struct mesh *m, size_t *fixed, struct err *e)
{
	unsigned char *touched, *vtouched;
	int pass, rc = 0;

	*fixed = 0;
	for (pass = 0; pass < 3; pass++) {
		struct mesh_edges ed;
		size_t t, done = 0;
		for (t = 0; t < m->nt; t++) { /* any cap at all?  (usually none) */
			const uint32_t *c = m->tri + 3 * t;
			if (c[0] != c[1] && c[1] != c[2] && c[2] != c[0] && mesh_tri_degenerate(m, t))
				break;
		}
		if (t == m->nt)
			break;
		if ((rc = mesh_edges_build(m, &ed, e)))
			break;
		touched = mem_calloc(m->nt ? m->nt : 1, 1);
		vtouched = mem_calloc(m->nv ? m->nv : 1, 1);
		if (!touched || !vtouched) {
			mem_free(touched);
			mem_free(vtouched);
			mesh_edges_fini(&ed);
			rc = ERR_SET(e, ERR_NOMEM, "out of memory repairing %zu triangles", m->nt);
			break;
		}
		for (t = 0; t < m->nt; t++) {
			uint32_t *c = m->tri + 3 * t, u, w, mid, lo, hi, *g;
			double best = -1;
			size_t r, other = SIZE_MAX;
			int k, j;
			if (touched[t] || c[0] == c[1] || c[1] == c[2] || c[2] == c[0] ||
			    !mesh_tri_degenerate(m, t))
				continue;
			for (k = 0, u = w = mid = 0; k < 3; k++) { /* longest edge u-w */
				double l = v3_len2(v3_sub(m->v[c[(k + 1) % 3]], m->v[c[k]]));
				if (l > best) {
					best = l;
					u = c[k];
					w = c[(k + 1) % 3];
					mid = c[(k + 2) % 3];
				}
			}
			lo = u < w ? u : w;
			hi = u < w ? w : u;
			for (r = ed.off[lo], k = 0; r < ed.off[lo + 1]; r++)
				if (MESH_EDGE_OTHER(ed.rec[r]) == hi) {
					k++;
					if (MESH_EDGE_CORNER(ed.rec[r]) / 3 != t)
						other = MESH_EDGE_CORNER(ed.rec[r]) / 3;
				}
			if (k != 2 || other == SIZE_MAX || touched[other] ||
			    mesh_tri_degenerate(m, other) || vtouched[u] || vtouched[w] ||
			    vtouched[mid])
				continue;
			g = m->tri + 3 * other;
			for (j = 0; j < 3; j++)
				if ((g[j] == u && g[(j + 1) % 3] == w) ||
				    (g[j] == w && g[(j + 1) % 3] == u))
					break;
			{
				uint32_t p = g[j], q = g[(j + 1) % 3], x = g[(j + 2) % 3];
				g[0] = p;
				g[1] = mid;
				g[2] = x;
				c[0] = mid;
				c[1] = q;
				c[2] = x;
			}
			touched[t] = touched[other] = 1;
			/* edges among these vertices changed: not looked up again
			 * before the table is rebuilt */
			vtouched[u] = vtouched[w] = vtouched[mid] = vtouched[m->tri[3 * t + 2]] = 1;
			done++;
		}
		mesh_edges_fini(&ed);
		mem_free(touched);
		mem_free(vtouched);
		*fixed += done;
		if (done == 0)
			break;
	}
	return rc;
}

static size_t drop_degenerate(struct mesh *m)
{
	size_t t, kept = 0, n = m->nt;

	for (t = 0; t < m->nt; t++) {
		if (mesh_tri_degenerate(m, t))
			continue;
		memmove(m->tri + 3 * kept, m->tri + 3 * t, 3 * sizeof *m->tri);
		kept++;
	}
	m->nt = kept;
	return n - kept;
}

struct comp {
	size_t first, n;   /* faces order[first .. first + n) */
	struct box3 bbox;
	double volume;     /* about the bbox centre */
	struct vec3 ref;   /* a point on the component (a face centroid) */
	int closed;        /* no border edge */
};

struct orient {
	struct mesh *m;
	uint32_t *nbr;     /* 3 per face: neighbour face | NBR_SAME, or NO_NBR */
	uint32_t *order;   /* faces in BFS order, component after component */
	unsigned char *flip;
	struct comp *comps;
	size_t ncomp, ccap;
};

static int build_neighbours(struct orient *o, struct err *e)
{
	struct mesh_edges ed;
	size_t v, i;
	int rc;

	if ((rc = mesh_edges_build(o->m, &ed, e)))
		return rc;
	for (i = 0; i < 3 * o->m->nt; i++)
		o->nbr[i] = NO_NBR;
	for (v = 0; v < ed.nv; v++) {
		size_t a = ed.off[v], end = ed.off[v + 1], b;
		for (; a < end; a = b) {
			for (b = a; b < end && MESH_EDGE_OTHER(ed.rec[b]) == MESH_EDGE_OTHER(ed.rec[a]);
			     b++)
				;
			if (b - a == 2) {
				uint64_t r0 = ed.rec[a], r1 = ed.rec[a + 1];
				uint32_t same = ((r0 ^ r1) & MESH_EDGE_FWD) ? 0 : NBR_SAME;
				size_t c0 = MESH_EDGE_CORNER(r0), c1 = MESH_EDGE_CORNER(r1);
				o->nbr[c0] = (uint32_t)(c1 / 3) | same;
				o->nbr[c1] = (uint32_t)(c0 / 3) | same;
			}
		}
	}
	mesh_edges_fini(&ed);
	return 0;
}

/* BFS from every unvisited face; returns faces flipped for consistency. */
static int bfs_components(struct orient *o, size_t *reoriented, struct err *e)
{
	struct mesh *m = o->m;
	unsigned char *seen = mem_calloc(m->nt ? m->nt : 1, 1);
	size_t seed, head = 0, tail = 0, flips_total = 0;

	if (!seen)
		return ERR_SET(e, ERR_NOMEM, "out of memory orienting %zu triangles", m->nt);
	for (seed = 0; seed < m->nt; seed++) {
		size_t first = tail, flips = 0, i;
		void *arr;
		if (seen[seed])
			continue;
		seen[seed] = 1;
		o->flip[seed] = 0;
		o->order[tail++] = (uint32_t)seed;
		while (head < tail) {
			uint32_t f = o->order[head++];
			int k;
			for (k = 0; k < 3; k++) {
				uint32_t nb = o->nbr[3 * (size_t)f + (size_t)k], g;
				if (nb == NO_NBR)
					continue;
				g = nb & ~NBR_SAME;
				if (seen[g])
					continue; /* a conflict here means non-orientable: keep */
				seen[g] = 1;
				o->flip[g] = (unsigned char)(o->flip[f] ^ ((nb & NBR_SAME) != 0));
				o->order[tail++] = g;
			}
		}
		for (i = first; i < tail; i++)
			flips += o->flip[o->order[i]];
		if (2 * flips > tail - first) { /* the other consistent choice flips fewer */
			for (i = first; i < tail; i++)
				o->flip[o->order[i]] ^= 1;
			flips = tail - first - flips;
		}
		flips_total += flips;
		arr = o->comps;
		if (mem_grow(&arr, &o->ccap, o->ncomp + 1, sizeof *o->comps)) {
			mem_free(seen);
			return ERR_SET(e, ERR_NOMEM, "out of memory orienting %zu triangles", m->nt);
		}
		o->comps = arr;
		memset(&o->comps[o->ncomp], 0, sizeof o->comps[0]);
		o->comps[o->ncomp].first = first;
		o->comps[o->ncomp].n = tail - first;
		o->ncomp++;
	}
	for (seed = 0; seed < m->nt; seed++)
		if (o->flip[seed])
			flip_face(m, seed);
	*reoriented = flips_total;
	mem_free(seen);
	return 0;
}

static void measure(struct orient *o, struct comp *c)
{
	const struct mesh *m = o->m;
	struct vec3 ctr;
	size_t i;
	int k;

	c->bbox = box3_empty();
	c->closed = 1;
	for (i = c->first; i < c->first + c->n; i++)
		for (k = 0; k < 3; k++) {
			box3_add(&c->bbox, m->v[m->tri[3 * (size_t)o->order[i] + (size_t)k]]);
			if (o->nbr[3 * (size_t)o->order[i] + (size_t)k] == NO_NBR)
				c->closed = 0;
		}
	ctr = box3_center(c->bbox);
	c->volume = 0;
	for (i = c->first; i < c->first + c->n; i++) {
		const uint32_t *t = m->tri + 3 * (size_t)o->order[i];
		c->volume += v3_dot(v3_sub(m->v[t[0]], ctr),
				    v3_cross(v3_sub(m->v[t[1]], ctr), v3_sub(m->v[t[2]], ctr))) / 6;
	}
	{
		const uint32_t *t = m->tri + 3 * (size_t)o->order[c->first];
		c->ref = v3_scale(v3_add(v3_add(m->v[t[0]], m->v[t[1]]), m->v[t[2]]), 1.0 / 3);
	}
}

/* Winding number of component d at p (exact sum over its faces). */
static double comp_winding(const struct orient *o, const struct comp *d, struct vec3 p)
{
	const struct mesh *m = o->m;
	double w = 0;
	size_t i;

	for (i = d->first; i < d->first + d->n; i++) {
		const uint32_t *t = m->tri + 3 * (size_t)o->order[i];
		w += mesh_solid_angle(m->v[t[0]], m->v[t[1]], m->v[t[2]], p);
	}
	return w / (4 * M_PI);
}

/* Flip whole components so each is outward (or inward when a cavity). */
static size_t make_outward(struct orient *o)
{
	size_t c, d, flipped = 0, budget = NEST_BUDGET(o->m->nt), spent = 0;
	int nest = 1;

	for (c = 0; c < o->ncomp; c++)
		measure(o, &o->comps[c]);
	for (c = 0; c < o->ncomp; c++) {
		struct comp *cc = &o->comps[c];
		int depth = 0;
		double want;
		size_t i;
		if (cc->volume == 0)
			continue;
		for (d = 0; nest && o->ncomp > 1 && d < o->ncomp; d++) {
			const struct comp *dc = &o->comps[d];
			if (d == c || !dc->closed || !box3_contains(dc->bbox, cc->ref))
				continue;
			if (spent + dc->n > budget) {
				nest = 0; /* too costly: treat the rest as unnested */
				break;
			}
			spent += dc->n;
			depth += fabs(comp_winding(o, dc, cc->ref)) >= 0.5;
		}
		want = depth % 2 ? -1.0 : 1.0;
		if (cc->volume * want >= 0)
			continue;
		for (i = cc->first; i < cc->first + cc->n; i++)
			flip_face(o->m, o->order[i]);
		flipped++;
	}
	return flipped;
}

int mesh_repair(struct mesh *m, struct mesh_report *r, struct err *e)
{
	struct orient o;
	size_t welded = 0, dropped = 0, reoriented = 0, flipped = 0, caps = 0;
	int rc;

	memset(&o, 0, sizeof o);
	o.m = m;
	if ((rc = mesh_weld(m, 0, &welded, &dropped, e)) || (rc = split_caps(m, &caps, e)))
		return rc;
	dropped += caps + drop_degenerate(m);
	if (m->nt) {
		o.nbr = mem_alloc(3 * m->nt * sizeof *o.nbr);
		o.order = mem_alloc(m->nt * sizeof *o.order);
		o.flip = mem_alloc(m->nt);
		if (!o.nbr || !o.order || !o.flip) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory orienting %zu triangles", m->nt);
			goto out;
		}
		if ((rc = build_neighbours(&o, e)) || (rc = bfs_components(&o, &reoriented, e)))
			goto out;
		flipped = make_outward(&o);
	}
	if ((rc = mesh_analyze(m, r, e)))
		goto out;
	r->welded_vertices = welded;
	r->dropped_triangles = dropped;
	r->reoriented_faces = reoriented;
	r->flipped_components = flipped;
	r->flipped = flipped > 0;
out:
	mem_free(o.nbr);
	mem_free(o.order);
	mem_free(o.flip);
	mem_free(o.comps);
	return rc;
}
