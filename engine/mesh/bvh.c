/* bvh.c - bounding volume hierarchy over a mesh: build, closest point, ray cast.
 *
 * Build: binned SAH (16 bins on each axis over triangle centroids), leaves
 * of at most 4 triangles (up to 8 when splitting would not pay).  Below
 * depth 48 the split is the centroid median instead, so the depth stays
 * under 48 + log2(n) and queries use a fixed stack.  O(n log n).
 * Queries are read-only (safe from many threads): closest point visits
 * the nearer child first and prunes by box distance; rays use slab tests
 * and Moller-Trumbore.  Winding numbers: winding.c.
 */
#include "engine/mesh/bvh_int.h"
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define NBINS 16
#define LEAF_MAX 4
#define LEAF_SAH_MAX 8
#define SAH_DEPTH 48

struct build {
	struct mesh_bvh *b;
	struct vec3 *cen;
	struct box3 *tbox;
	uint32_t *idx;
	size_t nnodes;
};

static double half_area(struct box3 b)
{
	struct vec3 d = box3_size(b);

	return box3_is_empty(b) ? 0 : d.x * d.y + d.y * d.z + d.z * d.x;
}

/* Box growth with plain comparisons: fmin/fmax are library calls that
 * dominate the build otherwise (inputs here are never NaN). */
static inline double dmin(double a, double b)
{
	return a < b ? a : b;
}
static inline double dmax(double a, double b)
{
	return a > b ? a : b;
}

static void box_point(struct box3 *a, struct vec3 p)
{
	a->lo.x = dmin(a->lo.x, p.x);
	a->lo.y = dmin(a->lo.y, p.y);
	a->lo.z = dmin(a->lo.z, p.z);
	a->hi.x = dmax(a->hi.x, p.x);
	a->hi.y = dmax(a->hi.y, p.y);
	a->hi.z = dmax(a->hi.z, p.z);
}

static void box_union(struct box3 *a, struct box3 b)
{
	a->lo.x = dmin(a->lo.x, b.lo.x);
	a->lo.y = dmin(a->lo.y, b.lo.y);
	a->lo.z = dmin(a->lo.z, b.lo.z);
	a->hi.x = dmax(a->hi.x, b.hi.x);
	a->hi.y = dmax(a->hi.y, b.hi.y);
	a->hi.z = dmax(a->hi.z, b.hi.z);
}

static void swap_items(struct build *s, size_t i, size_t j)
{
	struct vec3 c = s->cen[i];
	struct box3 bx = s->tbox[i];
	uint32_t x = s->idx[i];

	s->cen[i] = s->cen[j];
	s->tbox[i] = s->tbox[j];
	s->idx[i] = s->idx[j];
	s->cen[j] = c;
	s->tbox[j] = bx;
	s->idx[j] = x;
}

struct keyed {
	double k;
	uint32_t i;
};

static int cmp_keyed(const void *pa, const void *pb)
{
	const struct keyed *a = pa, *b = pb;

	if (a->k != b->k)
		return a->k < b->k ? -1 : 1;
	return (a->i > b->i) - (a->i < b->i);
}

/* Bin of centroid coordinate c, 0..NBINS-1; clamped in double before the
 * cast: a denormal extent makes scale infinite, and 0 * inf is NaN (which
 * lands in bin 0). */
static int sah_bin(double c, double clo, double scale)
{
	double t = (c - clo) * scale;

	return t >= NBINS - 1 ? NBINS - 1 : t > 0 ? (int)t : 0;
}

/* Binned SAH: partitions the range and returns the split position
 * (first < mid < first + n), or 0 when a leaf is cheaper or no axis
 * separates the centroids. */
static size_t sah_split(struct build *s, size_t first, size_t n, struct box3 box,
			struct box3 cbox)
{
	double best = INFINITY;
	int best_axis = -1, best_bin = 0, axis, i;
	size_t j, lo, hi;

	for (axis = 0; axis < 3; axis++) {
		double clo = v3_comp(cbox.lo, axis), ext = v3_comp(cbox.hi, axis) - clo, scale;
		size_t cnt[NBINS] = {0}, lcnt = 0, rcnt[NBINS];
		struct box3 bb[NBINS], acc;
		double rarea[NBINS];
		if (!(ext > 0))
			continue;
		scale = NBINS / ext;
		for (i = 0; i < NBINS; i++)
			bb[i] = box3_empty();
		for (j = first; j < first + n; j++) {
			int k = sah_bin(v3_comp(s->cen[j], axis), clo, scale);
			cnt[k]++;
			box_union(&bb[k], s->tbox[j]);
		}
		acc = box3_empty();
		for (i = NBINS - 1, lcnt = 0; i > 0; i--) {
			lcnt += cnt[i];
			box_union(&acc, bb[i]);
			rcnt[i] = lcnt;
			rarea[i] = half_area(acc);
		}
		acc = box3_empty();
		for (i = 0, lcnt = 0; i < NBINS - 1; i++) {
			double cost;
			lcnt += cnt[i];
			box_union(&acc, bb[i]);
			if (lcnt == 0 || rcnt[i + 1] == 0)
				continue;
			cost = half_area(acc) * (double)lcnt + rarea[i + 1] * (double)rcnt[i + 1];
			if (cost < best) {
				best = cost;
				best_axis = axis;
				best_bin = i;
			}
		}
	}
	if (best_axis < 0 || (best >= half_area(box) * (double)n && n <= LEAF_SAH_MAX))
		return 0;
	{
		double clo = v3_comp(cbox.lo, best_axis);
		double scale = NBINS / (v3_comp(cbox.hi, best_axis) - clo);
		lo = first;
		hi = first + n;
		while (lo < hi) {
			int k = sah_bin(v3_comp(s->cen[lo], best_axis), clo, scale);
			if (k <= best_bin)
				lo++;
			else
				swap_items(s, lo, --hi);
		}
	}
	return lo;
}

/* Median split along the longest centroid axis (deep levels only, or
 * when SAH finds nothing).  Allocation failure still yields a valid
 * (unsorted) halving. */
static size_t median_split(struct build *s, size_t first, size_t n, struct box3 cbox)
{
	struct vec3 d = box3_size(cbox);
	struct keyed *ks;
	struct vec3 *c2;
	struct box3 *b2;
	uint32_t *i2;
	size_t j;
	int axis = d.x >= d.y && d.x >= d.z ? 0 : d.y >= d.z ? 1 : 2;

	if (!(v3_comp(d, axis) > 0))
		return first + n / 2; /* all centroids equal: any halving will do */
	ks = mem_alloc(n * sizeof *ks);
	c2 = mem_alloc(n * sizeof *c2);
	b2 = mem_alloc(n * sizeof *b2);
	i2 = mem_alloc(n * sizeof *i2);
	if (ks && c2 && b2 && i2) {
		for (j = 0; j < n; j++) {
			ks[j].k = v3_comp(s->cen[first + j], axis);
			ks[j].i = (uint32_t)(first + j);
		}
		qsort(ks, n, sizeof *ks, cmp_keyed);
		for (j = 0; j < n; j++) {
			c2[j] = s->cen[ks[j].i];
			b2[j] = s->tbox[ks[j].i];
			i2[j] = s->idx[ks[j].i];
		}
		memcpy(s->cen + first, c2, n * sizeof *c2);
		memcpy(s->tbox + first, b2, n * sizeof *b2);
		memcpy(s->idx + first, i2, n * sizeof *i2);
	}
	mem_free(ks);
	mem_free(c2);
	mem_free(b2);
	mem_free(i2);
	return first + n / 2;
}

static void build_node(struct build *s, uint32_t ni, size_t first, size_t n, int depth)
{
	struct bvh_node *node = &s->b->nodes[ni];
	struct box3 box = box3_empty(), cbox = box3_empty();
	size_t j, mid;
	uint32_t left;

	for (j = first; j < first + n; j++) {
		box_union(&box, s->tbox[j]);
		box_point(&cbox, s->cen[j]);
	}
	node->box = box;
	node->left = (uint32_t)first;
	node->count = (uint32_t)n;
	if (n <= LEAF_MAX)
		return;
	mid = depth < SAH_DEPTH ? sah_split(s, first, n, box, cbox) : median_split(s, first, n, cbox);
	if (mid == 0) {
		if (n <= LEAF_SAH_MAX)
			return;
		mid = median_split(s, first, n, cbox);
	}
	left = (uint32_t)s->nnodes;
	s->nnodes += 2;
	node->left = left;
	node->count = 0;
	build_node(s, left, first, mid - first, depth + 1);
	build_node(s, left + 1, mid, first + n - mid, depth + 1);
}

/* Closed = every undirected edge is traversed as often forward as
 * backward (a 2-cycle: winding numbers are integers, ray crossings count
 * them exactly).  Repeated-index edges are ignored. */
static int is_closed(const struct mesh *m, int *closed, struct err *e)
{
	struct mesh_edges ed;
	size_t v, r;
	int rc;

	if ((rc = mesh_edges_build(m, &ed, e)))
		return rc;
	*closed = 1;
	for (v = 0; v < ed.nv && *closed; v++) {
		long bal = 0;
		for (r = ed.off[v]; r < ed.off[v + 1]; r++) {
			bal += (ed.rec[r] & MESH_EDGE_FWD) ? 1 : -1;
			if (r + 1 == ed.off[v + 1] ||
			    MESH_EDGE_OTHER(ed.rec[r + 1]) != MESH_EDGE_OTHER(ed.rec[r])) {
				if (bal != 0)
					*closed = 0;
				bal = 0;
			}
		}
	}
	mesh_edges_fini(&ed);
	return 0;
}

int mesh_bvh_new(const struct mesh *m, struct mesh_bvh **out, struct err *e)
{
	struct mesh_bvh *b = mem_calloc(1, sizeof *b);
	struct build s;
	size_t t, n = m->nt;
	int rc = 0;

	memset(&s, 0, sizeof s);
	if (!b)
		return ERR_SET(e, ERR_NOMEM, "out of memory for a BVH");
	b->m = m;
	if (n > MESH_MAX_TRIANGLES) {
		rc = ERR_SET(e, ERR_LIMIT, "BVH over %zu triangles exceeds the limit", n);
		goto out;
	}
	for (t = 0; t < 3 * n; t++)
		if (m->tri[t] >= m->nv) {
			rc = ERR_SET(e, ERR_GEOMETRY, "triangle %zu refers to vertex %u of %zu",
				     t / 3, m->tri[t], m->nv);
			goto out;
		}
	if (n == 0) {
		*out = b;
		return 0;
	}
	b->nodes = mem_alloc(2 * n * sizeof *b->nodes);
	b->tris = mem_alloc(n * sizeof *b->tris);
	b->idx = mem_alloc(n * sizeof *b->idx);
	s.cen = mem_alloc(n * sizeof *s.cen);
	s.tbox = mem_alloc(n * sizeof *s.tbox);
	if (!b->nodes || !b->tris || !b->idx || !s.cen || !s.tbox) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a BVH over %zu triangles", n);
		goto out;
	}
	s.b = b;
	s.idx = b->idx;
	for (t = 0; t < n; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], c1 = m->v[m->tri[3 * t + 1]],
			    c2 = m->v[m->tri[3 * t + 2]];
		s.tbox[t] = box3_empty();
		box_point(&s.tbox[t], a);
		box_point(&s.tbox[t], c1);
		box_point(&s.tbox[t], c2);
		s.cen[t] = v3_scale(v3_add(v3_add(a, c1), c2), 1.0 / 3);
		s.idx[t] = (uint32_t)t;
	}
	s.nnodes = 1;
	build_node(&s, 0, 0, n, 0);
	b->nnodes = s.nnodes;
	for (t = 0; t < n; t++) {
		const uint32_t *c = m->tri + 3 * (size_t)b->idx[t];
		b->tris[t].a = m->v[c[0]];
		b->tris[t].b = m->v[c[1]];
		b->tris[t].c = m->v[c[2]];
	}
	b->wn = mem_alloc(b->nnodes * sizeof *b->wn);
	if (!b->wn) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a BVH over %zu triangles", n);
		goto out;
	}
	mesh_bvh_winding_prepare(b);
	if ((rc = is_closed(m, &b->closed, e)))
		goto out;
out:
	mem_free(s.cen);
	mem_free(s.tbox);
	if (rc)
		mesh_bvh_free(b);
	else
		*out = b;
	return rc;
}

void mesh_bvh_free(struct mesh_bvh *b)
{
	if (!b)
		return;
	mem_free(b->nodes);
	mem_free(b->tris);
	mem_free(b->idx);
	mem_free(b->wn);
	mem_free(b);
}

static inline double box_dist2(const struct box3 *b, struct vec3 p)
{
	double dx = dmax(dmax(b->lo.x - p.x, 0), p.x - b->hi.x);
	double dy = dmax(dmax(b->lo.y - p.y, 0), p.y - b->hi.y);
	double dz = dmax(dmax(b->lo.z - p.z, 0), p.z - b->hi.z);

	return dx * dx + dy * dy + dz * dz;
}

static struct vec3 closest_on_segment(struct vec3 p, struct vec3 a, struct vec3 b)
{
	struct vec3 ab = v3_sub(b, a);
	double l2 = v3_len2(ab), t = l2 > 0 ? v3_dot(v3_sub(p, a), ab) / l2 : 0;

	return v3_madd(a, ab, t < 0 ? 0 : t > 1 ? 1 : t);
}

/* Closest point of triangle abc to p (Voronoi regions of vertices,
 * edges, face); degenerate triangles fall back to their edges. */
static struct vec3 closest_on_tri(struct vec3 p, struct vec3 a, struct vec3 b, struct vec3 c)
{
	struct vec3 ab = v3_sub(b, a), ac = v3_sub(c, a), ap = v3_sub(p, a), bp, cp;
	double d1 = v3_dot(ab, ap), d2 = v3_dot(ac, ap), d3, d4, d5, d6, va, vb, vc, den;

	if (d1 <= 0 && d2 <= 0)
		return a;
	bp = v3_sub(p, b);
	d3 = v3_dot(ab, bp);
	d4 = v3_dot(ac, bp);
	if (d3 >= 0 && d4 <= d3)
		return b;
	vc = d1 * d4 - d3 * d2;
	if (vc <= 0 && d1 >= 0 && d3 <= 0 && d1 - d3 > 0)
		return v3_madd(a, ab, d1 / (d1 - d3));
	cp = v3_sub(p, c);
	d5 = v3_dot(ab, cp);
	d6 = v3_dot(ac, cp);
	if (d6 >= 0 && d5 <= d6)
		return c;
	vb = d5 * d2 - d1 * d6;
	if (vb <= 0 && d2 >= 0 && d6 <= 0 && d2 - d6 > 0)
		return v3_madd(a, ac, d2 / (d2 - d6));
	va = d3 * d6 - d5 * d4;
	if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0 && (d4 - d3) + (d5 - d6) > 0)
		return v3_madd(b, v3_sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
	den = va + vb + vc;
	if (!(den > 0)) { /* collinear or coincident corners */
		struct vec3 q1 = closest_on_segment(p, a, b), q2 = closest_on_segment(p, b, c),
			    q3 = closest_on_segment(p, c, a), q = q1;
		if (v3_len2(v3_sub(q2, p)) < v3_len2(v3_sub(q, p)))
			q = q2;
		if (v3_len2(v3_sub(q3, p)) < v3_len2(v3_sub(q, p)))
			q = q3;
		return q;
	}
	return v3_add(a, v3_add(v3_scale(ab, vb / den), v3_scale(ac, vc / den)));
}

double mesh_bvh_closest(const struct mesh_bvh *b, struct vec3 p, struct vec3 *q, size_t *tri)
{
	/* Stack entries carry their box distance, computed once when pushed. */
	struct {
		uint32_t node;
		double d2;
	} stack[BVH_STACK];
	int sp = 0;
	double best2 = INFINITY;
	struct vec3 bestq = p;
	size_t bestt = 0;

	if (!b->nnodes)
		return INFINITY;
	stack[0].node = 0;
	stack[0].d2 = box_dist2(&b->nodes[0].box, p);
	sp = 1;
	while (sp > 0) {
		const struct bvh_node *nd;
		sp--;
		if (stack[sp].d2 >= best2)
			continue;
		nd = &b->nodes[stack[sp].node];
		if (nd->count) {
			uint32_t i;
			for (i = nd->left; i < nd->left + nd->count; i++) {
				const struct bvh_tri *t = &b->tris[i];
				struct vec3 c = closest_on_tri(p, t->a, t->b, t->c);
				double d2 = v3_len2(v3_sub(c, p));
				if (d2 < best2) {
					best2 = d2;
					bestq = c;
					bestt = i;
				}
			}
		} else {
			double dl = box_dist2(&b->nodes[nd->left].box, p);
			double dr = box_dist2(&b->nodes[nd->left + 1].box, p);
			int near_right = dr < dl;
			double dn = near_right ? dr : dl, df = near_right ? dl : dr;
			if (df < best2) { /* farther child first: popped last */
				stack[sp].node = nd->left + (uint32_t)!near_right;
				stack[sp++].d2 = df;
			}
			if (dn < best2) {
				stack[sp].node = nd->left + (uint32_t)near_right;
				stack[sp++].d2 = dn;
			}
		}
	}
	if (q)
		*q = bestq;
	if (tri)
		*tri = b->idx[bestt];
	return sqrt(best2);
}

/* Ray/box slab test: entry distance, or INFINITY when missed or beyond tmax. */
static double ray_box(struct box3 bx, struct vec3 o, struct vec3 inv, double tmax)
{
	double t0 = 0, t1 = tmax;
	int k;

	for (k = 0; k < 3; k++) {
		double lo = (v3_comp(bx.lo, k) - v3_comp(o, k)) * v3_comp(inv, k);
		double hi = (v3_comp(bx.hi, k) - v3_comp(o, k)) * v3_comp(inv, k);
		if (lo > hi) {
			double x = lo;
			lo = hi;
			hi = x;
		}
		/* NaN (0 * inf: origin on a slab plane of a flat axis) does not cut */
		t0 = lo > t0 ? lo : t0;
		t1 = hi < t1 ? hi : t1;
	}
	return t0 <= t1 ? t0 : INFINITY;
}

/* Moller-Trumbore: t > 0 of the hit, or INFINITY. */
static double ray_tri(struct vec3 o, struct vec3 d, const struct bvh_tri *t)
{
	struct vec3 e1 = v3_sub(t->b, t->a), e2 = v3_sub(t->c, t->a), pv = v3_cross(d, e2), tv, qv;
	double det = v3_dot(e1, pv), inv, u, v, s;

	if (det == 0)
		return INFINITY;
	inv = 1 / det;
	tv = v3_sub(o, t->a);
	u = v3_dot(tv, pv) * inv;
	if (u < 0 || u > 1)
		return INFINITY;
	qv = v3_cross(tv, e1);
	v = v3_dot(d, qv) * inv;
	if (v < 0 || u + v > 1)
		return INFINITY;
	s = v3_dot(e2, qv) * inv;
	return s > 0 ? s : INFINITY;
}

double mesh_bvh_ray(const struct mesh_bvh *b, struct vec3 o, struct vec3 d, size_t *tri)
{
	uint32_t stack[BVH_STACK];
	int sp = 0;
	double best = INFINITY;
	size_t bestt = 0;
	struct vec3 inv = v3(1 / d.x, 1 / d.y, 1 / d.z);

	if (!b->nnodes || v3_len2(d) == 0)
		return INFINITY;
	stack[sp++] = 0;
	while (sp > 0) {
		const struct bvh_node *nd = &b->nodes[stack[--sp]];
		if (ray_box(nd->box, o, inv, best) == INFINITY)
			continue;
		if (nd->count) {
			uint32_t i;
			for (i = nd->left; i < nd->left + nd->count; i++) {
				double t = ray_tri(o, d, &b->tris[i]);
				if (t < best) {
					best = t;
					bestt = i;
				}
			}
		} else {
			double tl = ray_box(b->nodes[nd->left].box, o, inv, best);
			double tr = ray_box(b->nodes[nd->left + 1].box, o, inv, best);
			uint32_t near = tl <= tr ? nd->left : nd->left + 1;
			uint32_t far = tl <= tr ? nd->left + 1 : nd->left;
			if ((tl <= tr ? tr : tl) < INFINITY)
				stack[sp++] = far;
			if ((tl <= tr ? tl : tr) < INFINITY)
				stack[sp++] = near;
		}
	}
	if (best < INFINITY && tri)
		*tri = b->idx[bestt];
	return best;
}

int mesh_bvh_crossings(const struct mesh_bvh *b, struct vec3 q, int *crossings)
{
	/* An oblique direction: axis-aligned rays meet grid-like CAD meshes
	 * exactly on edges far more often. */
	const struct vec3 d = {0.3141592653589793, 0.5772156649015329, 0.7548776662466927};
	const double eps = 1e-9;
	struct vec3 inv = v3(1 / d.x, 1 / d.y, 1 / d.z);
	uint32_t stack[BVH_STACK];
	int sp = 0, sum = 0;

	if (!b->nnodes) {
		*crossings = 0;
		return 0;
	}
	stack[sp++] = 0;
	while (sp > 0) {
		const struct bvh_node *nd = &b->nodes[stack[--sp]];
		uint32_t i;
		if (ray_box(nd->box, q, inv, INFINITY) == INFINITY)
			continue;
		if (!nd->count) {
			stack[sp++] = nd->left;
			stack[sp++] = nd->left + 1;
			continue;
		}
		for (i = nd->left; i < nd->left + nd->count; i++) {
			const struct bvh_tri *t = &b->tris[i];
			struct vec3 e1 = v3_sub(t->b, t->a), e2 = v3_sub(t->c, t->a);
			struct vec3 pv = v3_cross(d, e2), tv, qv;
			double det = v3_dot(e1, pv), u, v, s, scale;
			scale = v3_len(e1) * v3_len(e2);
			tv = v3_sub(q, t->a);
			if (fabs(det) <= 1e-12 * scale) {
				/* ray parallel to the face: only a problem if it lies in it */
				if (fabs(v3_dot(tv, v3_cross(e1, e2))) <= 1e-12 * scale * v3_len(tv))
					return -1;
				continue;
			}
			u = v3_dot(tv, pv) / det;
			qv = v3_cross(tv, e1);
			v = v3_dot(d, qv) / det;
			s = v3_dot(e2, qv) / det;
			if (u < -eps || v < -eps || u + v > 1 + eps || s < -eps * (1 + v3_len(tv)))
				continue;
			if (u <= eps || v <= eps || u + v >= 1 - eps || s <= eps * (1 + v3_len(tv)))
				return -1; /* on an edge, a vertex, or q on the face */
			sum += det < 0 ? 1 : -1; /* det = -d.n: leaving when d.n > 0 */
		}
	}
	*crossings = sum;
	return 0;
}
