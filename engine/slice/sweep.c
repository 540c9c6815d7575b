/* sweep.c - mesh -> layer regions by a z-sweep (slice_new, slice_at).
 *
 * Triangles are sorted once by min z; planes visited in increasing z keep
 * an active list, so a whole schedule costs O(n log n + k).  Each active
 * triangle yields one segment between two of its edges; segments are
 * chained through the mesh's edge ids (topology, no epsilon), open
 * chains are closed by chains.c and the loops normalised by clip_union.
 * Design and degenerate cases: docs/slicing.md.
 */
#include "engine/slice/slice.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/chains.h"

#include <math.h>
#include <string.h>

/* One triangle/plane intersection, oriented with the material on its
 * left seen from +z (the mesh's outward normals point to its right). */
struct seg {
	uint32_t e0, e1; /* starts on edge e0, ends on edge e1 */
	int32_t next;    /* next segment starting on e0 not yet chained, -1 = none */
	struct pt2 p0;   /* crossing point on e0, nm */
};

struct slicer {
	const struct mesh *m;
	size_t nt;           /* swept triangles (degenerate ones dropped) */
	uint32_t *order;     /* triangle ids by increasing min z */
	double *zmin;        /* zmin[i]: min z of order[i] */
	double *zmax;        /* per triangle id */
	uint32_t *tri_edge;  /* per triangle id, 3: edge of corner i -> i+1 */
	uint32_t *edge_v;    /* per edge, 2: vertex ids, lower id first */
	uint32_t *edge_hole; /* per edge: the hole (border loop) a border edge
				belongs to, SLICE_NO_HOLE for other edges */
	size_t ne;

	/* sweep state */
	size_t next;         /* order[next..] not yet added */
	uint32_t *active;
	size_t nactive;
	double last_z;

	/* per-plane scratch, edge arrays valid where edge_stamp == stamp */
	struct seg *seg;
	size_t nseg, seg_cap;
	int32_t *edge_head;  /* first unchained segment starting on the edge */
	int32_t *edge_bal;   /* (segments starting) - (segments ending) */
	uint32_t *edge_stamp;
	uint32_t stamp;
	struct paths raw;    /* closed loops before normalisation */
	struct paths open;   /* open chains (open mesh) */
	uint32_t *open_key;  /* per open chain, 2: hole of its head and tail edge */
	size_t open_key_cap;
};

#define SLICE_NO_HOLE UINT32_MAX

/* ---- sorting: LSD radix sort of (key, value) pairs, 11 bits a pass ---- */

#define RADIX_BITS 11
#define RADIX_SIZE (1u << RADIX_BITS)

/* Sort n pairs by key (stable) over the low `bits` bits.  0 or ERR_NOMEM. */
static int radix_sort(uint64_t *key, uint32_t *val, size_t n, int bits)
{
	uint64_t *k2 = mem_alloc((n ? n : 1) * sizeof *k2);
	uint32_t *v2 = mem_alloc((n ? n : 1) * sizeof *v2);
	uint64_t *ks = key, *kd = k2;
	uint32_t *vs = val, *vd = v2;
	size_t *cnt = mem_alloc(RADIX_SIZE * sizeof *cnt);

	if (!k2 || !v2 || !cnt) {
		mem_free(k2);
		mem_free(v2);
		mem_free(cnt);
		return ERR_NOMEM;
	}
	for (int shift = 0; shift < bits; shift += RADIX_BITS) {
		size_t sum = 0;
		memset(cnt, 0, RADIX_SIZE * sizeof *cnt);
		for (size_t i = 0; i < n; i++)
			cnt[(ks[i] >> shift) & (RADIX_SIZE - 1)]++;
		if (n && cnt[(ks[0] >> shift) & (RADIX_SIZE - 1)] == n)
			continue; /* every key has the same digit: nothing moves */
		for (size_t d = 0; d < RADIX_SIZE; d++) {
			size_t c = cnt[d];
			cnt[d] = sum;
			sum += c;
		}
		for (size_t i = 0; i < n; i++) {
			size_t at = cnt[(ks[i] >> shift) & (RADIX_SIZE - 1)]++;
			kd[at] = ks[i];
			vd[at] = vs[i];
		}
		{
			uint64_t *tk = ks;
			uint32_t *tv = vs;
			ks = kd, kd = tk;
			vs = vd, vd = tv;
		}
	}
	if (ks != key) {
		memcpy(key, ks, n * sizeof *key);
		memcpy(val, vs, n * sizeof *val);
	}
	mem_free(k2);
	mem_free(v2);
	mem_free(cnt);
	return 0;
}

/* Order-preserving map of a finite double onto uint64. */
static uint64_t double_key(double d)
{
	uint64_t u;

	if (d == 0)
		d = 0; /* -0 sorts with +0 */
	memcpy(&u, &d, sizeof u);
	return (u >> 63) ? ~u : u | (1ull << 63);
}

static int bits_for(uint64_t v)
{
	int b = 0;

	while (b < 64 && (v >> b))
		b++;
	return b;
}

/* ---- construction ---- */

void slice_free(struct slicer *s)
{
	if (!s)
		return;
	mem_free(s->order);
	mem_free(s->zmin);
	mem_free(s->zmax);
	mem_free(s->tri_edge);
	mem_free(s->edge_v);
	mem_free(s->edge_hole);
	mem_free(s->open_key);
	mem_free(s->active);
	mem_free(s->seg);
	mem_free(s->edge_head);
	mem_free(s->edge_bal);
	mem_free(s->edge_stamp);
	paths_fini(&s->raw);
	paths_fini(&s->open);
	mem_free(s);
}

/* A triangle with a repeated corner: skipped by the sweep. */
static int degenerate(const uint32_t *c)
{
	return c[0] == c[1] || c[1] == c[2] || c[2] == c[0];
}

/* Check indices and coordinates; count usable (non-degenerate) triangles. */
static int check_mesh(const struct mesh *m, size_t *usable, struct err *e)
{
	size_t n = 0;

	if (m->nt > MESH_MAX_TRIANGLES || m->nv > MESH_MAX_VERTICES)
		return ERR_SET(e, ERR_LIMIT, "mesh too large to slice: %zu triangles, %zu vertices",
			       m->nt, m->nv);
	if ((m->nt && !m->tri) || (m->nv && !m->v))
		return ERR_SET(e, ERR_INTERNAL, "mesh arrays missing");
	for (size_t i = 0; i < m->nv; i++) {
		if (!isfinite(m->v[i].x) || !isfinite(m->v[i].y) || !isfinite(m->v[i].z))
			return ERR_PLACE(e, ERR_GEOMETRY, -1, 0, (long long)i,
					 "vertex %zu has a non-finite coordinate", i);
	}
	for (size_t t = 0; t < m->nt; t++) {
		const uint32_t *c = m->tri + 3 * t;
		if (c[0] >= m->nv || c[1] >= m->nv || c[2] >= m->nv)
			return ERR_PLACE(e, ERR_GEOMETRY, -1, 0, (long long)t,
					 "triangle %zu refers to a vertex beyond the %zu vertices", t,
					 m->nv);
		n += !degenerate(c);
	}
	*usable = n;
	return 0;
}

static uint32_t uf_find(uint32_t *parent, uint32_t v)
{
	while (parent[v] != v) {
		parent[v] = parent[parent[v]];
		v = parent[v];
	}
	return v;
}

/* Border edges (used by exactly one usable triangle) grouped into holes,
 * the connected components of the border: the open chains of a plane are
 * closed through the hole they end on (chains.c). */
static int build_holes(struct slicer *s, struct err *e)
{
	const struct mesh *m = s->m;
	uint32_t *count = mem_calloc(s->ne ? s->ne : 1, sizeof *count);
	uint32_t *parent = mem_alloc((m->nv ? m->nv : 1) * sizeof *parent);
	int rc = 0;

	s->edge_hole = mem_alloc((s->ne ? s->ne : 1) * sizeof *s->edge_hole);
	if (!count || !parent || !s->edge_hole) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory finding the mesh's holes");
		goto out;
	}
	for (size_t t = 0; t < m->nt; t++)
		if (!degenerate(m->tri + 3 * t))
			for (int k = 0; k < 3; k++)
				count[s->tri_edge[3 * t + (size_t)k]]++;
	for (size_t v = 0; v < m->nv; v++)
		parent[v] = (uint32_t)v;
	for (size_t id = 0; id < s->ne; id++) {
		if (count[id] == 1) {
			uint32_t a = uf_find(parent, s->edge_v[2 * id]);
			uint32_t b = uf_find(parent, s->edge_v[2 * id + 1]);
			parent[a > b ? a : b] = a < b ? a : b;
		}
	}
	for (size_t id = 0; id < s->ne; id++)
		s->edge_hole[id] = count[id] == 1 ? uf_find(parent, s->edge_v[2 * id]) : SLICE_NO_HOLE;
out:
	mem_free(count);
	mem_free(parent);
	return rc;
}

/* Number the undirected edges of the triangles (tri_edge, edge_v). */
static int build_edges(struct slicer *s, struct err *e)
{
	const struct mesh *m = s->m;
	size_t nh = 3 * m->nt;
	uint64_t *key = mem_alloc((nh ? nh : 1) * sizeof *key);
	uint32_t *val = mem_alloc((nh ? nh : 1) * sizeof *val);
	int rc = 0;

	s->tri_edge = mem_alloc((nh ? nh : 1) * sizeof *s->tri_edge);
	if (!key || !val || !s->tri_edge) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory numbering %zu mesh edges", nh);
		goto out;
	}
	for (size_t h = 0; h < nh; h++) {
		uint64_t a = m->tri[h], b = m->tri[h - h % 3 + (h % 3 + 1) % 3];
		key[h] = a < b ? (a << 32) | b : (b << 32) | a;
		val[h] = (uint32_t)h;
	}
	if (radix_sort(key, val, nh, 32 + bits_for(m->nv))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory sorting mesh edges");
		goto out;
	}
	s->ne = 0;
	for (size_t i = 0; i < nh; i++)
		s->ne += i == 0 || key[i] != key[i - 1];
	s->edge_v = mem_alloc((s->ne ? 2 * s->ne : 1) * sizeof *s->edge_v);
	s->edge_head = mem_alloc((s->ne ? s->ne : 1) * sizeof *s->edge_head);
	s->edge_bal = mem_alloc((s->ne ? s->ne : 1) * sizeof *s->edge_bal);
	s->edge_stamp = mem_calloc(s->ne ? s->ne : 1, sizeof *s->edge_stamp);
	if (!s->edge_v || !s->edge_head || !s->edge_bal || !s->edge_stamp) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu mesh edges", s->ne);
		goto out;
	}
	for (size_t i = 0, id = 0; i < nh; i++) {
		if (i > 0 && key[i] != key[i - 1])
			id++;
		s->tri_edge[val[i]] = (uint32_t)id;
		s->edge_v[2 * id] = (uint32_t)(key[i] >> 32);
		s->edge_v[2 * id + 1] = (uint32_t)(key[i] & 0xffffffffu);
	}
	rc = build_holes(s, e);
out:
	mem_free(key);
	mem_free(val);
	return rc;
}

/* Sort the usable triangles by min z. */
static int build_order(struct slicer *s, struct err *e)
{
	const struct mesh *m = s->m;
	uint64_t *key = mem_alloc((s->nt ? s->nt : 1) * sizeof *key);
	int rc = 0;

	s->order = mem_alloc((s->nt ? s->nt : 1) * sizeof *s->order);
	s->zmin = mem_alloc((s->nt ? s->nt : 1) * sizeof *s->zmin);
	s->zmax = mem_alloc((m->nt ? m->nt : 1) * sizeof *s->zmax);
	s->active = mem_alloc((s->nt ? s->nt : 1) * sizeof *s->active);
	if (!key || !s->order || !s->zmin || !s->zmax || !s->active) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory sorting %zu triangles", m->nt);
		goto out;
	}
	for (size_t t = 0, i = 0; t < m->nt; t++) {
		const uint32_t *c = m->tri + 3 * t;
		double z0 = m->v[c[0]].z, z1 = m->v[c[1]].z, z2 = m->v[c[2]].z;
		s->zmax[t] = fmax(z0, fmax(z1, z2));
		if (degenerate(c))
			continue;
		key[i] = double_key(fmin(z0, fmin(z1, z2)));
		s->order[i++] = (uint32_t)t;
	}
	if (radix_sort(key, s->order, s->nt, 64)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory sorting triangles");
		goto out;
	}
	for (size_t i = 0; i < s->nt; i++) {
		const uint32_t *c = m->tri + 3 * (size_t)s->order[i];
		s->zmin[i] = fmin(m->v[c[0]].z, fmin(m->v[c[1]].z, m->v[c[2]].z));
	}
out:
	mem_free(key);
	return rc;
}

int slice_new(const struct mesh *m, struct slicer **out, struct err *e)
{
	struct slicer *s;
	size_t usable = 0;
	int rc;

	if (!m)
		return ERR_SET(e, ERR_INTERNAL, "slice_new: no mesh");
	rc = check_mesh(m, &usable, e);
	if (rc)
		return rc;
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the slicer");
	s->m = m;
	s->nt = usable;
	s->last_z = -INFINITY;
	paths_init(&s->raw);
	paths_init(&s->open);
	rc = build_edges(s, e);
	if (!rc)
		rc = build_order(s, e);
	if (rc) {
		slice_free(s);
		return rc;
	}
	*out = s;
	return 0;
}

/* ---- one plane ---- */

/* Point where edge (p below, q above: p.z < z <= q.z) meets the plane.
 * Both triangles of an edge pass the same (p, q), so they agree bit for
 * bit. */
static struct pt2 crossing(struct vec3 p, struct vec3 q, double z)
{
	double t = (z - p.z) / (q.z - p.z);
	struct pt2 r = {geom_mm_to_nm(p.x + t * (q.x - p.x)), geom_mm_to_nm(p.y + t * (q.y - p.y))};
	return r;
}

static struct pt2 edge_crossing(const struct slicer *s, uint32_t edge, double z)
{
	struct vec3 a = s->m->v[s->edge_v[2 * (size_t)edge]];
	struct vec3 b = s->m->v[s->edge_v[2 * (size_t)edge + 1]];

	return a.z < z ? crossing(a, b, z) : crossing(b, a, z);
}

static void edge_touch(struct slicer *s, uint32_t edge)
{
	if (s->edge_stamp[edge] != s->stamp) {
		s->edge_stamp[edge] = s->stamp;
		s->edge_head[edge] = -1;
		s->edge_bal[edge] = 0;
	}
}

/* Advance the active list to plane z and cut every active triangle.
 * Symbolic perturbation: a vertex with z_v >= z counts as above, so a
 * triangle is cut iff zmin < z <= zmax, in exactly two edges, and faces
 * lying in the plane are never cut. */
static int cut_plane(struct slicer *s, double z, struct err *e)
{
	const struct mesh *m = s->m;
	size_t keep = 0;

	if (z < s->last_z) { /* going down: restart the sweep */
		s->next = 0;
		s->nactive = 0;
	}
	s->last_z = z;
	while (s->next < s->nt && s->zmin[s->next] < z)
		s->active[s->nactive++] = s->order[s->next++];
	if (++s->stamp == 0) { /* wrapped: stale stamps could alias */
		memset(s->edge_stamp, 0, s->ne * sizeof *s->edge_stamp);
		s->stamp = 1;
	}
	s->nseg = 0;
	for (size_t i = 0; i < s->nactive; i++) {
		uint32_t t = s->active[i];
		const uint32_t *c = m->tri + 3 * (size_t)t;
		struct vec3 p[3];
		int below[3], i0 = -1, i1 = -1;
		struct seg *g;

		if (s->zmax[t] < z)
			continue; /* entirely below: leaves the active list */
		s->active[keep++] = t;
		for (int k = 0; k < 3; k++) {
			p[k] = m->v[c[k]];
			below[k] = p[k].z < z;
		}
		for (int k = 0; k < 3; k++) {
			int k1 = k == 2 ? 0 : k + 1;
			if (!below[k] && below[k1])
				i0 = k; /* edge k runs from above to below: segment start */
			else if (below[k] && !below[k1])
				i1 = k; /* edge k runs from below to above: segment end */
		}
		if (s->nseg == s->seg_cap) {
			void *arr = s->seg;
			if (s->nseg >= (size_t)INT32_MAX ||
			    mem_grow(&arr, &s->seg_cap, s->nseg + 1, sizeof *s->seg))
				return ERR_SET(e, ERR_NOMEM, "out of memory for %zu contour segments",
					       s->nseg + 1);
			s->seg = arr;
		}
		g = &s->seg[s->nseg];
		g->e0 = s->tri_edge[3 * (size_t)t + (size_t)i0];
		g->e1 = s->tri_edge[3 * (size_t)t + (size_t)i1];
		g->p0 = crossing(p[i0 == 2 ? 0 : i0 + 1], p[i0], z);
		edge_touch(s, g->e0);
		edge_touch(s, g->e1);
		g->next = s->edge_head[g->e0];
		s->edge_head[g->e0] = (int32_t)s->nseg;
		s->edge_bal[g->e0]++;
		s->edge_bal[g->e1]--;
		s->nseg++;
	}
	s->nactive = keep;
	return 0;
}

/* Follow segments from `first` (already unlinked) until no unchained
 * segment starts where the last one ends.  A walk that ends on its own
 * start edge is a closed loop (into raw), else an open chain whose tail
 * is the last edge's crossing (into open). */
static int walk(struct slicer *s, int32_t first, double z, struct slice_stats *st, struct err *e)
{
	struct path *p;
	int32_t cur = first;
	uint32_t end;
	int closed;

	p = paths_add(&s->raw);
	if (!p)
		return ERR_SET(e, ERR_NOMEM, "out of memory chaining contours");
	for (;;) {
		int32_t nx;
		if (path_push(p, s->seg[cur].p0))
			return ERR_SET(e, ERR_NOMEM, "out of memory chaining contours");
		end = s->seg[cur].e1;
		nx = s->edge_head[end];
		if (nx < 0)
			break;
		s->edge_head[end] = s->seg[nx].next;
		cur = nx;
	}
	closed = end == s->seg[first].e0;
	if (closed) {
		if (st)
			st->loops++;
		return 0;
	}
	if (path_push(p, edge_crossing(s, end, z)))
		return ERR_SET(e, ERR_NOMEM, "out of memory chaining contours");
	{ /* move the open chain from raw to open, noting its holes */
		struct path *q;
		void *arr = s->open_key;
		if (mem_grow(&arr, &s->open_key_cap, 2 * (s->open.n + 1), sizeof *s->open_key))
			return ERR_SET(e, ERR_NOMEM, "out of memory chaining contours");
		s->open_key = arr;
		s->open_key[2 * s->open.n] = s->edge_hole[s->seg[first].e0];
		s->open_key[2 * s->open.n + 1] = s->edge_hole[end];
		q = paths_add(&s->open);
		if (!q)
			return ERR_SET(e, ERR_NOMEM, "out of memory chaining contours");
		*q = s->raw.v[--s->raw.n];
	}
	if (st)
		st->chains_closed++;
	return 0;
}

static int chain_plane(struct slicer *s, double z, struct slice_stats *st, struct err *e)
{
	int rc;

	paths_clear(&s->raw);
	paths_clear(&s->open);
	/* Open chains first: they start on edges with more segments
	 * starting than ending (border edges of an open mesh, odd
	 * non-manifold fans).  What remains is balanced and decomposes into
	 * closed walks. */
	for (size_t i = 0; i < s->nseg; i++) {
		uint32_t e0 = s->seg[i].e0;
		while (s->edge_bal[e0] > 0 && s->edge_head[e0] >= 0) {
			int32_t first = s->edge_head[e0];
			s->edge_head[e0] = s->seg[first].next;
			s->edge_bal[e0]--;
			rc = walk(s, first, z, st, e);
			if (rc)
				return rc;
		}
	}
	for (size_t i = 0; i < s->nseg; i++) {
		uint32_t e0 = s->seg[i].e0;
		while (s->edge_head[e0] >= 0) {
			int32_t first = s->edge_head[e0];
			s->edge_head[e0] = s->seg[first].next;
			rc = walk(s, first, z, st, e);
			if (rc)
				return rc;
		}
	}
	return slice_chains_close(&s->open, s->open_key, &s->raw, e);
}

int slice_at(struct slicer *s, double z_mm, struct paths *region, struct slice_stats *stats,
	     struct err *e)
{
	int rc;

	if (!isfinite(z_mm))
		return ERR_SET(e, ERR_PARAM, "slice plane z is not finite");
	rc = cut_plane(s, z_mm, e);
	if (rc)
		return rc;
	if (stats)
		stats->segments += s->nseg;
	rc = chain_plane(s, z_mm, stats, e);
	if (rc)
		return rc;
	if (s->raw.n == 0) {
		paths_clear(region);
		return 0;
	}
	return clip_union(&s->raw, CLIP_FILL_NONZERO, region, e);
}
