/* check.c - the independent re-evaluation of an optimised void (see
 * opt_int.h): loop moments, enclosed volume and the support-free check at the
 * user's alpha.  Kept apart from nlp.c on purpose: it shares no code with
 * the optimiser's constraint evaluation (docs/hollow.md "Solving").
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"

#include "engine/hollow/opt/opt_int.h"

void hl_loop_moments(const struct hl_void *v, size_t k, const double *l, double *area,
		     double *mx, double *my)
{
	double A = 0, Mx = 0, My = 0;
	size_t s = v->off[k], n = v->off[k + 1] - s;

	for (size_t i = 0; i < n; i++) {
		struct vec3 p = hl_void_pos(v, s + i, l ? l[s + i] : 0);
		struct vec3 q = hl_void_pos(v, s + (i + 1) % n, l ? l[s + (i + 1) % n] : 0);
		double C = p.x * q.y - q.x * p.y;
		A += 0.5 * C;
		Mx += (p.x + q.x) * C / 6;
		My += (p.y + q.y) * C / 6;
	}
	*area = A;
	if (mx)
		*mx = Mx;
	if (my)
		*my = My;
}

double hl_void_volume(const struct hl_void *v, const double *l)
{
	double s = 0, a0, a1;

	/* divergence theorem with normals into the void: V = -1/6 sum p_a.(p_b x p_c)
	 * over the strips, the floor (normal +z) gives -A z / 3, the ceiling +A z / 3 */
	for (size_t t = 0; t < v->nt; t++) {
		const uint32_t *c = v->tri + 3 * t;
		struct vec3 a = hl_void_pos(v, c[0], l ? l[c[0]] : 0);
		struct vec3 b = hl_void_pos(v, c[1], l ? l[c[1]] : 0);
		struct vec3 d = hl_void_pos(v, c[2], l ? l[c[2]] : 0);
		s += v3_dot(a, v3_cross(b, d));
	}
	hl_loop_moments(v, 0, l, &a0, NULL, NULL);
	hl_loop_moments(v, v->nloops - 1, l, &a1, NULL, NULL);
	return -s / 6 - a0 * v->z[0] / 3 + a1 * v->z[v->nloops - 1] / 3;
}

double hl_void_loop_h(const struct hl_void *v, size_t k)
{
	size_t n = v->nloops;

	if (n < 2)
		return 0;
	if (k == 0)
		return v->z[1] - v->z[0];
	if (k + 1 >= n)
		return v->z[n - 1] - v->z[n - 2];
	return 0.5 * (v->z[k + 1] - v->z[k - 1]);
}

void hl_void_check(const struct hl_void *v, const double *l, double alpha_rad, double gate_tau,
		   struct hl_check *c)
{
	double sa = sin(alpha_rad), ta = tan(alpha_rad);

	memset(c, 0, sizeof *c);
	c->worst_face = -INFINITY;
	c->worst_edge_mm = -INFINITY;
	c->min_shift_mm = INFINITY;
	c->max_shift_mm = -INFINITY;
	for (size_t t = 0; t < v->nt; t++) {
		const uint32_t *q = v->tri + 3 * t;
		struct vec3 a = hl_void_pos(v, q[0], l[q[0]]), b = hl_void_pos(v, q[1], l[q[1]]);
		struct vec3 d = hl_void_pos(v, q[2], l[q[2]]);
		struct vec3 N = v3_cross(v3_sub(b, a), v3_sub(d, a));
		double nn = v3_len(N);
		if (nn < 1e-12)
			continue; /* degenerate (collapsed ceiling): no overhang area */
		/* violation as an angle: asin(-n.z) - alpha > 0 means too flat */
		c->worst_face = fmax(c->worst_face, asin(fmax(-1, fmin(1, -N.z / nn))) -
							    asin(sa));
	}
	for (size_t k = 0; k < v->nxe; k++) {
		const struct hl_xedge *x = &v->xe[k];
		double nz = 0;
		for (int i = 0; i < 2; i++) {
			const uint32_t *q = v->tri + 3 * x->f[i];
			struct vec3 a = hl_void_pos(v, q[0], l[q[0]]), b = hl_void_pos(v, q[1], l[q[1]]);
			struct vec3 d = hl_void_pos(v, q[2], l[q[2]]);
			nz += 0.5 * v3_normalize(v3_cross(v3_sub(b, a), v3_sub(d, a))).z;
		}
		if (!(nz < -gate_tau))
			continue;
		struct vec3 p = hl_void_pos(v, x->lo, l[x->lo]), q = hl_void_pos(v, x->hi, l[x->hi]);
		/* eq. 5 with this edge's own rise (slices may differ in thickness) */
		c->worst_edge_mm = fmax(c->worst_edge_mm,
					hypot(q.x - p.x, q.y - p.y) - (q.z - p.z) * ta);
	}
	for (size_t j = 0; j < v->nv; j++) {
		c->min_shift_mm = fmin(c->min_shift_mm, l[j]);
		c->max_shift_mm = fmax(c->max_shift_mm, l[j] - v->ub[j]);
	}
	hl_loop_moments(v, v->nloops - 1, l, &c->top_area_mm2, NULL, NULL);
}

int hl_void_top_overhang_mm2(const struct hl_void *v, const double *l, double reach_mm, double *a,
			      struct err *e)
{
	size_t k = v->nloops - 1, o = v->off[k], n = v->off[k + 1] - o;
	struct paths top, un, er;
	struct path *p;
	int rc = 0;

	*a = 0;
	paths_init(&top);
	paths_init(&un);
	paths_init(&er);
	p = paths_add(&top);
	if (!p || !(p->pts = mem_alloc((n + 1) * sizeof *p->pts))) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	p->cap = n + 1;
	for (size_t j = 0; j < n; j++) {
		struct vec3 q = hl_void_pos(v, o + j, l ? l[o + j] : 0);
		p->pts[j].x = geom_mm_to_nm(q.x);
		p->pts[j].y = geom_mm_to_nm(q.y);
	}
	p->n = n;
	/* the walk overlaps itself: its region is where it winds */
	rc = clip_union(&top, CLIP_FILL_NONZERO, &un, e);
	if (!rc && un.n)
		rc = clip_offset(&un, -reach_mm * GEOM_NM_PER_MM, CLIP_JOIN_ROUND, 0, 100.0, &er, e);
	if (!rc)
		*a = paths_area_mm2(&er);
out:
	paths_fini(&top);
	paths_fini(&un);
	paths_fini(&er);
	return rc;
}
