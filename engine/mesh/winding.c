/* winding.c - generalised winding number with a hierarchical far-field expansion.
 *
 * w(q) = sum over triangles of solid angle / 4 pi (exact: mesh_solid_angle).
 * For a BVH node far from q (|p - q| > BETA r, p the node's area-weighted
 * centroid, r the radius holding all its corners) the node's triangles act
 * like dipoles: with x = p - q, g(x) = x / (4 pi |x|^3), each triangle
 * contributes A_t . g(x + d_t) (A_t its area vector, d_t = c_t - p), and
 * the Taylor expansion to first order in d_t gives
 *   N . g(x) + J(x) : M,  N = sum A_t,  M = sum A_t (x) d_t,
 *   J(x) : M = (tr M / |x|^3 - 3 x^T M x / |x|^5) / (4 pi)
 * (Barill et al. 2018, "Fast winding numbers for soups and clouds", in its
 * order-1 form).  Nodes near q are opened, leaves near q summed exactly.
 * Cost O(log n)-like per query for points away from the surface.
 */
#include "engine/mesh/bvh_int.h"
#include "engine/mesh/mesh_int.h"

#include <math.h>

/* Opening ratio: larger is more accurate and slower (docs/mesh.md). */
#ifndef BETA
#define BETA 2.0
#endif

/* A leaf's centroid, area vector, moment and radius; returns its area. */
static double leaf_stats(const struct mesh_bvh *b, const struct bvh_node *nd, struct bvh_wn *w)
{
	double area = 0, m[9] = {0};
	struct vec3 p = v3(0, 0, 0), n = v3(0, 0, 0);
	uint32_t i;
	int r, c;

	for (i = nd->left; i < nd->left + nd->count; i++) {
		const struct bvh_tri *t = &b->tris[i];
		struct vec3 av = v3_scale(v3_cross(v3_sub(t->b, t->a), v3_sub(t->c, t->a)), 0.5);
		struct vec3 ct = v3_scale(v3_add(v3_add(t->a, t->b), t->c), 1.0 / 3);
		double a = v3_len(av);
		area += a;
		p = v3_madd(p, ct, a);
		n = v3_add(n, av);
	}
	p = area > 0 ? v3_scale(p, 1 / area) : box3_center(nd->box);
	w->r = 0;
	for (i = nd->left; i < nd->left + nd->count; i++) {
		const struct bvh_tri *t = &b->tris[i];
		struct vec3 av = v3_scale(v3_cross(v3_sub(t->b, t->a), v3_sub(t->c, t->a)), 0.5);
		struct vec3 d = v3_sub(v3_scale(v3_add(v3_add(t->a, t->b), t->c), 1.0 / 3), p);
		for (r = 0; r < 3; r++)
			for (c = 0; c < 3; c++)
				m[3 * r + c] += v3_comp(av, r) * v3_comp(d, c);
		w->r = fmax(w->r, fmax(v3_dist(t->a, p), fmax(v3_dist(t->b, p), v3_dist(t->c, p))));
	}
	w->p = p;
	w->n = n;
	for (r = 0; r < 9; r++)
		w->m[r] = m[r];
	return area;
}

static double box_radius(struct box3 bx, struct vec3 p)
{
	double dx = fmax(fabs(bx.lo.x - p.x), fabs(bx.hi.x - p.x));
	double dy = fmax(fabs(bx.lo.y - p.y), fabs(bx.hi.y - p.y));
	double dz = fmax(fabs(bx.lo.z - p.z), fabs(bx.hi.z - p.z));

	return sqrt(dx * dx + dy * dy + dz * dz);
}

void mesh_bvh_winding_prepare(struct mesh_bvh *b)
{
	size_t k;

	/* Children come after their parent: a reverse sweep sees them first.
	 * Moments are shifted to the parent's centroid:
	 * sum A_t (x) (c_t - p) = M_child + N_child (x) (p_child - p). */
	for (k = b->nnodes; k-- > 0;) {
		const struct bvh_node *nd = &b->nodes[k];
		struct bvh_wn *w = &b->wn[k];
		if (nd->count) {
			w->area = leaf_stats(b, nd, w);
		} else {
			const struct bvh_wn *l = &b->wn[nd->left], *r = &b->wn[nd->left + 1];
			double a = l->area + r->area, rr;
			struct vec3 dl, dr;
			int i, j;
			w->area = a;
			w->p = a > 0 ? v3_scale(v3_add(v3_scale(l->p, l->area), v3_scale(r->p, r->area)),
						1 / a)
				     : box3_center(nd->box);
			w->n = v3_add(l->n, r->n);
			dl = v3_sub(l->p, w->p);
			dr = v3_sub(r->p, w->p);
			for (i = 0; i < 3; i++)
				for (j = 0; j < 3; j++)
					w->m[3 * i + j] = l->m[3 * i + j] + r->m[3 * i + j] +
							  v3_comp(l->n, i) * v3_comp(dl, j) +
							  v3_comp(r->n, i) * v3_comp(dr, j);
			rr = fmax(l->r + v3_len(dl), r->r + v3_len(dr));
			w->r = fmin(rr, box_radius(nd->box, w->p));
		}
	}
}

static double far_field(const struct bvh_wn *w, struct vec3 x, double d2)
{
	double inv = 1 / sqrt(d2), inv3 = inv * inv * inv, inv5 = inv3 * inv * inv;
	double tr = w->m[0] + w->m[4] + w->m[8], xmx = 0;
	int i, j;

	for (i = 0; i < 3; i++)
		for (j = 0; j < 3; j++)
			xmx += v3_comp(x, i) * w->m[3 * i + j] * v3_comp(x, j);
	return v3_dot(w->n, x) * inv3 + tr * inv3 - 3 * xmx * inv5;
}

/* One triangle's solid angle: its dipole term when q is farther than
 * BETA times the triangle's radius (same accuracy as the node far field,
 * a fifth of the cost), else exact. */
static double triangle_term(const struct bvh_tri *t, struct vec3 q)
{
	struct vec3 c = v3_scale(v3_add(v3_add(t->a, t->b), t->c), 1.0 / 3);
	struct vec3 x = v3_sub(c, q);
	double d2 = v3_len2(x);
	double r2 = fmax(v3_len2(v3_sub(t->a, c)), fmax(v3_len2(v3_sub(t->b, c)), v3_len2(v3_sub(t->c, c))));

	if (d2 > BETA * BETA * r2) {
		struct vec3 av = v3_scale(v3_cross(v3_sub(t->b, t->a), v3_sub(t->c, t->a)), 0.5);
		return v3_dot(av, x) / (d2 * sqrt(d2));
	}
	return mesh_solid_angle(t->a, t->b, t->c, q);
}

double mesh_bvh_winding(const struct mesh_bvh *b, struct vec3 q)
{
	uint32_t stack[BVH_STACK];
	int sp = 0;
	double far = 0, exact = 0;

	if (!b->nnodes)
		return 0;
	stack[sp++] = 0;
	while (sp > 0) {
		uint32_t k = stack[--sp];
		const struct bvh_node *nd = &b->nodes[k];
		const struct bvh_wn *w = &b->wn[k];
		struct vec3 x = v3_sub(w->p, q);
		double d2 = v3_len2(x);
		if (d2 > BETA * BETA * w->r * w->r) {
			far += far_field(w, x, d2);
		} else if (nd->count) {
			uint32_t i;
			for (i = nd->left; i < nd->left + nd->count; i++)
				exact += triangle_term(&b->tris[i], q);
		} else {
			stack[sp++] = nd->left + 1;
			stack[sp++] = nd->left;
		}
	}
	return (far + exact) / (4 * M_PI);
}

int mesh_bvh_inside(const struct mesh_bvh *b, struct vec3 p)
{
	int crossings;

	/* Closed meshes: the signed ray crossing count is the exact winding
	 * number, at the cost of one ray; grazing hits fall back. */
	if (b->closed && mesh_bvh_crossings(b, p, &crossings) == 0)
		return crossings > 0;
	return mesh_bvh_winding(b, p) > 0.5;
}
