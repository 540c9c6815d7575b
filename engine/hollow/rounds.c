/* rounds.c - repeated support-free hollowing (paper 004, sections 3 and
 * 7.2; docs/hollow.md "Pipeline").
 *
 * Round r works on the solid S_r (the part, then the part minus the voids
 * of earlier rounds, as one mesh: outer surface + void surfaces):
 *  1. uniform offset: S_r eroded by a ball of radius t_r (t_1 = wall_mm,
 *     later wall_next_mm) with the exact 3D eroder of slice/erode.h; in
 *     later rounds intersected with round 1's offset, so the shell to the
 *     outside never gets thinner than wall_mm;
 *  2. the offset sampled at optimisation slices (every m-th layer of the
 *     eroded stack) and turned into loops (contour.c);
 *  3. loops grouped into chains (group.c) and chains into voids with
 *     strips that keep clear of S_r (void.c, strip.c; a triangle closer
 *     than t_r / 2 to S_r's surface is refused);
 *  4. every void optimised (solve.c, nlp.c); voids under min_void_mm3
 *     dropped;
 *  5. the kept voids appended to the result mesh, which is S_{r+1}.
 * Stop when a round keeps no void or after `rounds` rounds.
 */
#include "engine/hollow/rounds.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/clip.h"
#include "engine/geom/polytri.h"
#include "engine/hollow/hollow_int.h"
#include "engine/hollow/solve.h"
#include "engine/hollow/start.h"
#include "engine/hollow/void.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

void hl_outcome_fini(struct hl_outcome *o)
{
	mesh_free(o->mesh);
	hl_fill_fini(&o->fill);
	memset(o, 0, sizeof *o);
}

void hl_mesh_mass(const struct mesh *m, double *vol, double com[3])
{
	struct vec3 M;

	mesh_mass(m, vol, &M);
	com[0] = *vol != 0 ? M.x / *vol : 0;
	com[1] = *vol != 0 ? M.y / *vol : 0;
	com[2] = *vol != 0 ? M.z / *vol : 0;
}

/* ---- strip triangles must keep clear of the current solid's surface ---- */

struct block_ctx {
	const struct mesh_bvh *bvh;
	double wall_mm, pixel_mm, min_mm;
};

/* Loop vertices lie at >= wall - pixel from the surface (they come from
 * the offset), and the distance to the surface is 1-Lipschitz, so every
 * point of a triangle keeps >= wall - pixel - rho, rho the largest
 * distance from a point of the triangle to its nearest corner (the
 * circumradius for an acute triangle, half the longest edge otherwise).
 * When that clears min_mm no query is needed (the common case: strip
 * triangles are about h by s).  Otherwise the distance is sampled on a
 * barycentric grid of step <= wall / 2: every point then lies within
 * wall / (2 sqrt 3) < 0.29 wall of a sample, so a triangle passing this
 * test (min_mm = wall / 2) never crosses the surface and keeps > 0.2 wall
 * from it. */
static int blocked(void *vctx, struct vec3 a, struct vec3 b, struct vec3 c)
{
	const struct block_ctx *x = vctx;
	double la = v3_dist(b, c), lb = v3_dist(c, a), lc = v3_dist(a, b);
	double L = fmax(la, fmax(lb, lc)), rho;
	double area2 = v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
	int n;

	/* acute iff the longest edge's square is below the sum of the others' */
	if (2 * L * L < la * la + lb * lb + lc * lc && area2 > 0)
		rho = la * lb * lc / (2 * area2); /* circumradius abc / (4 A) */
	else
		rho = 0.5 * L;
	if (x->wall_mm - x->pixel_mm - rho >= x->min_mm)
		return 0;
	n = (int)ceil(L / (0.5 * x->wall_mm));
	if (n < 1)
		n = 1;
	if (n > 16)
		return 1; /* a triangle this long is no part of a sensible strip */
	for (int i = 0; i <= n; i++)
		for (int j = 0; i + j <= n; j++) {
			double u = (double)i / n, w = (double)j / n;
			struct vec3 p = v3_add(v3_add(v3_scale(a, 1 - u - w), v3_scale(b, u)),
					       v3_scale(c, w));
			if (mesh_bvh_closest(x->bvh, p, NULL, NULL) < x->min_mm)
				return 1;
		}
	return 0;
}

/* ---- the eroded stack pulls layers of the current solid ---- */

/* ---- result mesh ---- */

/* Append void v (offsets v->l) to m: its vertices, strips, and both caps
 * (floor: normal +z into the void; ceiling reversed: -z). */
static int append_void(struct mesh *m, const struct hl_void *v, struct err *e)
{
	uint32_t base = (uint32_t)m->nv;
	size_t cap_n = 0;
	uint32_t *ct = NULL;
	double *xy = NULL;
	int rc = 0;

	if (m->nv + v->nv > MESH_MAX_VERTICES)
		return ERR_SET(e, ERR_LIMIT, "hollow: result mesh over %u vertices",
			       MESH_MAX_VERTICES);
	for (size_t j = 0; j < v->nv; j++)
		if (mesh_add_vertex(m, hl_void_pos(v, j, v->l[j])))
			goto nomem;
	for (size_t t = 0; t < v->nt; t++)
		if (mesh_add_triangle(m, base + v->tri[3 * t], base + v->tri[3 * t + 1],
				      base + v->tri[3 * t + 2]))
			goto nomem;
	for (int cap = 0; cap < 2; cap++) {
		size_t k = cap == 0 ? 0 : v->nloops - 1, o = v->off[k], n = v->off[k + 1] - o;
		if (n > cap_n) {
			mem_free(ct);
			mem_free(xy);
			ct = mem_alloc(3 * n * sizeof *ct);
			xy = mem_alloc(2 * n * sizeof *xy);
			cap_n = n;
			if (!ct || !xy)
				goto nomem;
		}
		for (size_t j = 0; j < n; j++) {
			struct vec3 p = hl_void_pos(v, o + j, v->l[o + j]);
			xy[2 * j] = p.x;
			xy[2 * j + 1] = p.y;
		}
		rc = polytri_ears(xy, n, ct, e);
		if (rc)
			goto out;
		for (size_t t = 0; t + 2 < n; t++) {
			uint32_t a = base + (uint32_t)(o + ct[3 * t]), b = base + (uint32_t)(o + ct[3 * t + 1]),
				 c = base + (uint32_t)(o + ct[3 * t + 2]);
			if (cap == 0 ? mesh_add_triangle(m, a, b, c) : mesh_add_triangle(m, a, c, b))
				goto nomem;
		}
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory building the result mesh");
out:
	mem_free(ct);
	mem_free(xy);
	return rc;
}

/* ---- one round ---- */

struct round_in {
	const struct hl_config *c;
	const struct mesh *solid; /* S_r */
	double wall;              /* t_r */
	int m;                    /* stack layers per optimisation slice */
	int nslices;              /* optimisation slices */
	int stack_count;
	struct paths *base;       /* round 1 offset per slice (rounds >= 2), or NULL */
	struct paths *keep;       /* round 1: receives the offset per slice */
	const struct hl_nlp_opts *nlp;
};

static void slices_fini(struct hl_slice *sl, size_t n)
{
	if (!sl)
		return;
	for (size_t k = 0; k < n; k++) {
		for (size_t i = 0; i < sl[k].n; i++)
			hl_loop_fini(&sl[k].loop[i]);
		mem_free(sl[k].loop);
	}
	mem_free(sl);
}

static void voids_fini(struct hl_void *v, size_t n)
{
	for (size_t i = 0; v && i < n; i++)
		hl_void_fini(&v[i]);
	mem_free(v);
}

/* Steps 1-3: the voids of one round, unoptimised. */
/* Voids of chain[a, b) (loops bottom to top): void.c builds upward until
 * a pair of loops has no strip at offset 0 (the rest is the next void);
 * restrip.c may then end a void higher up, and the loops below it, less
 * `gap` loops under its floor (so the wall between the two voids is at
 * least wall_next_mm), are a chain of their own. */
struct chain_ctx {
	const struct hl_block *blk;
	double reach_mm;
	size_t gap;
	struct hl_void *vv;
	size_t nvv, vcap;
};

static int chain_voids(struct chain_ctx *x, const struct hl_loop **chain, size_t a, size_t b,
		       struct err *e)
{
	while (a + 1 < b) {
		size_t used = 0, first = 0;
		struct hl_void V;
		void *arr;
		int rc;
		hl_void_init(&V);
		rc = hl_void_build(chain + a, b - a, x->blk, &V, &used, e);
		if (rc < 0)
			return rc;
		if (rc == 0)
			rc = hl_void_restrip(&V, x->reach_mm, x->blk, &first, e);
		if (rc < 0) {
			hl_void_fini(&V);
			return rc;
		}
		if (rc == 0) {
			arr = x->vv;
			if (mem_grow(&arr, &x->vcap, x->nvv + 1, sizeof *x->vv)) {
				hl_void_fini(&V);
				return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			}
			x->vv = arr;
			x->vv[x->nvv++] = V;
		} else {
			hl_void_fini(&V);
		}
		if (first >= x->gap + 2) {
			rc = chain_voids(x, chain, a, a + first - x->gap, e);
			if (rc)
				return rc;
		}
		a += used > 0 ? used : 1;
	}
	return 0;
}

static int round_voids(const struct round_in *in, struct hl_outcome *o, struct hl_void **vout,
		       size_t *nvout, struct err *e)
{
	const struct hl_config *c = in->c;
	struct slicer *ss = NULL;
	struct slice_eroder *er = NULL;
	struct mesh_bvh *bvh = NULL;
	struct hl_slice *sl = NULL;
	struct hl_void *vv = NULL;
	size_t nvv = 0, vcap = 0;
	int **up = NULL, **down = NULL;
	struct paths reg, tmp;
	struct box3 bb = box3_empty();
	double t0 = progress_now_s();
	int rc;

	paths_init(&reg);
	paths_init(&tmp);
	for (size_t i = 0; i < in->solid->nv; i++)
		box3_add(&bb, in->solid->v[i]);
	rc = slice_new(in->solid, &ss, e);
	if (rc)
		goto out;
	{
		struct slice_erode_params ep;
		struct hl_src_ctx sc = {ss, c->stack_layer_mm};
		struct slice_erode_source src = {hl_src_layer, &sc};
		memset(&ep, 0, sizeof ep);
		ep.r_mm = in->wall;
		ep.pixel_mm = c->pixel_mm;
		ep.layer_mm = c->stack_layer_mm;
		ep.layer_count = in->stack_count;
		ep.x0_mm = bb.lo.x;
		ep.y0_mm = bb.lo.y;
		ep.x1_mm = bb.hi.x;
		ep.y1_mm = bb.hi.y;
		/* sc lives on this stack frame for the whole erosion below */
		rc = slice_erode_new(&ep, &src, &er, e);
		if (rc)
			goto out;
		sl = mem_calloc((size_t)in->nslices + 1, sizeof *sl);
		if (!sl)
			goto nomem;
		for (int k = 0; k < in->nslices; k++) {
			int j = in->m * k + in->m / 2;
			struct hl_contour_params cp = {c->sample_mm, c->wall_next_mm,
						       4 * c->sample_mm * c->sample_mm};
			rc = slice_erode_layer(er, j, &reg, e);
			if (rc)
				goto out;
			if (in->keep) {
				rc = paths_copy(&in->keep[k], &reg);
				if (rc) {
					rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
					goto out;
				}
			}
			if (in->base && reg.n) {
				rc = clip_boolean(CLIP_INTERSECTION, &reg, &in->base[k],
						  CLIP_FILL_NONZERO, &tmp, e);
				if (rc)
					goto out;
				paths_fini(&reg);
				reg = tmp;
				paths_init(&tmp);
			}
			if (!reg.n)
				continue;
			rc = hl_contours_from_region(&reg, k, (j + 0.5) * c->stack_layer_mm, &cp,
						     &sl[k], e);
			if (rc)
				goto out;
		}
	}
	o->s_offset += progress_now_s() - t0;
	t0 = progress_now_s();
	/* groups: chains of mutually best links */
	rc = hl_group_links(sl, (size_t)in->nslices, 0.5, &up, e);
	if (rc)
		goto out;
	down = mem_calloc((size_t)in->nslices + 1, sizeof *down);
	if (!down)
		goto nomem;
	for (int k = 0; k < in->nslices; k++) {
		down[k] = mem_alloc((sl[k].n + 1) * sizeof **down);
		if (!down[k])
			goto nomem;
		for (size_t a = 0; a < sl[k].n; a++)
			down[k][a] = -1;
	}
	for (int k = 0; k + 1 < in->nslices; k++)
		for (size_t a = 0; a < sl[k].n; a++)
			if (up[k][a] >= 0)
				down[k + 1][up[k][a]] = (int)a;
	rc = mesh_bvh_new(in->solid, &bvh, e);
	if (rc)
		goto out;
	{
		struct block_ctx bx = {bvh, in->wall, c->pixel_mm, 0.5 * in->wall};
		struct hl_block blk = {blocked, &bx};
		const struct hl_loop **chain = mem_alloc(((size_t)in->nslices + 1) * sizeof *chain);
		struct chain_ctx cx = {&blk, 0.95 * in->nlp->h_mm * tan(in->nlp->alpha_rad), 0, vv,
				       nvv, vcap};
		double g = ceil(c->wall_next_mm / in->nlp->h_mm - 1e-9) - 1;
		cx.gap = g > 0 ? (size_t)g : 0;
		if (!chain)
			goto nomem;
		for (int k = 0; k < in->nslices; k++)
			for (size_t a = 0; a < sl[k].n; a++) {
				size_t len = 0;
				if (down[k][a] >= 0)
					continue; /* not the bottom of a chain */
				for (int kk = k, aa = (int)a; aa >= 0 && kk < in->nslices;
				     aa = kk + 1 < in->nslices ? up[kk][aa] : -1, kk++)
					chain[len++] = &sl[kk].loop[aa];
				rc = chain_voids(&cx, chain, 0, len, e);
				if (rc)
					break;
			}
		vv = cx.vv;
		nvv = cx.nvv;
		vcap = cx.vcap;
		if (rc) {
			mem_free(chain);
			goto out;
		}
		mem_free(chain);
		rc = 0;
	}
	o->s_groups += progress_now_s() - t0;
	*vout = vv;
	*nvout = nvv;
	vv = NULL;
	nvv = 0;
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
out:
	voids_fini(vv, nvv);
	hl_links_free(up, (size_t)in->nslices);
	hl_links_free(down, (size_t)in->nslices);
	slices_fini(sl, (size_t)in->nslices);
	mesh_bvh_free(bvh);
	slice_erode_free(er);
	slice_free(ss);
	paths_fini(&reg);
	paths_fini(&tmp);
	return rc;
}

/* Would voids a and b (at their offsets ->l) leave a wall thinner than
 * d_mm?  In a slice both cross: the distance between their loops (vertex
 * to edge, both ways; a vertex inside the other loop counts 0).  Stacked
 * (one's bottom loop less than d_mm above the other's top loop): their
 * bounding boxes grown by d_mm overlap.  Loops from one slice's region can
 * lie a neck's width apart (contour.c opens necks narrower than s). */
static void loop_box(const struct hl_void *v, size_t k, double box[4])
{
	box[0] = box[1] = INFINITY;
	box[2] = box[3] = -INFINITY;
	for (size_t j = v->off[k]; j < v->off[k + 1]; j++) {
		struct vec3 p = hl_void_pos(v, j, v->l[j]);
		box[0] = fmin(box[0], p.x);
		box[1] = fmin(box[1], p.y);
		box[2] = fmax(box[2], p.x);
		box[3] = fmax(box[3], p.y);
	}
}

static double loop_gap_mm(const struct hl_void *a, size_t ka, const struct hl_void *b, size_t kb)
{
	double best = INFINITY;

	for (int pass = 0; pass < 2; pass++) {
		const struct hl_void *u = pass ? b : a, *w = pass ? a : b;
		size_t ku = pass ? kb : ka, kw = pass ? ka : kb, n = w->off[kw + 1] - w->off[kw];
		for (size_t i = u->off[ku]; i < u->off[ku + 1]; i++) {
			struct vec3 p = hl_void_pos(u, i, u->l[i]);
			int in = 0;
			for (size_t j = 0; j < n; j++) {
				size_t j0 = w->off[kw] + j, j1 = w->off[kw] + (j + 1) % n;
				struct vec3 q0 = hl_void_pos(w, j0, w->l[j0]), q1 = hl_void_pos(w, j1, w->l[j1]);
				double dx = q1.x - q0.x, dy = q1.y - q0.y, L2 = dx * dx + dy * dy, t;
				t = L2 > 0 ? ((p.x - q0.x) * dx + (p.y - q0.y) * dy) / L2 : 0;
				t = fmin(1, fmax(0, t));
				best = fmin(best, hypot(q0.x + t * dx - p.x, q0.y + t * dy - p.y));
				if ((q0.y > p.y) != (q1.y > p.y) &&
				    p.x < q0.x + dx * (p.y - q0.y) / dy)
					in = !in;
			}
			if (in)
				return 0;
		}
	}
	return best;
}

static int voids_too_close(const struct hl_void *a, const struct hl_void *b, double d_mm)
{
	for (int pass = 0; pass < 2; pass++) {
		const struct hl_void *u = pass ? b : a, *w = pass ? a : b;
		double bu[4], bw[4];
		/* w stacked above u */
		if (w->z[0] > u->z[u->nloops - 1] && w->z[0] - u->z[u->nloops - 1] < d_mm) {
			loop_box(u, u->nloops - 1, bu);
			loop_box(w, 0, bw);
			if (bu[0] - d_mm < bw[2] && bw[0] - d_mm < bu[2] && bu[1] - d_mm < bw[3] &&
			    bw[1] - d_mm < bu[3])
				return 1;
		}
	}
	for (size_t ka = 0; ka < a->nloops; ka++)
		for (size_t kb = 0; kb < b->nloops; kb++) {
			double ba[4], bb[4], dz = fabs(a->z[ka] - b->z[kb]), r;
			if (dz >= d_mm)
				continue;
			/* in-plane gap that with dz still makes a wall of d_mm */
			r = sqrt(d_mm * d_mm - dz * dz);
			loop_box(a, ka, ba);
			loop_box(b, kb, bb);
			if (ba[0] - r >= bb[2] || bb[0] - r >= ba[2] || ba[1] - r >= bb[3] ||
			    bb[1] - r >= ba[3])
				continue;
			if (loop_gap_mm(a, ka, b, kb) < r)
				return 1;
		}
	return 0;
}

static int cmp_void_volume_desc(const void *x, const void *y)
{
	const struct hl_void *a = x, *b = y;
	double va = a->status >= 0 ? a->volume_mm3 : -1, vb = b->status >= 0 ? b->volume_mm3 : -1;

	return (va < vb) - (va > vb);
}

/* (x, y) centroid of void v at its offsets v->l in eq. 12's prism
 * approximation (loop first moments over loop areas).  -1 when degenerate. */
static int void_centroid(const struct hl_void *v, double cxy[2])
{
	double A = 0, Mx = 0, My = 0;

	for (size_t k = 0; k < v->nloops; k++) {
		double a, mx, my;
		hl_loop_moments(v, k, v->l, &a, &mx, &my);
		A += a;
		Mx += mx;
		My += my;
	}
	if (!(fabs(A) > 0))
		return -1;
	cxy[0] = Mx / A;
	cxy[1] = My / A;
	return 0;
}

/* Standing fill: at most this many passes of the half-plane's fixed
 * point, stopping when the centre of mass moved less than the step (mm). */
#define HL_STAND_PASSES 4
#define HL_STAND_STEP_MM 0.05

/* (x, y) of the centre of mass of o's part: its mesh (part less the
 * optimised voids) less the fill's void. */
static struct hull_pt com_after(const struct hl_outcome *o)
{
	double vm, cm[3], vf, cf[2];
	struct hull_pt q;

	hl_mesh_mass(o->mesh, &vm, cm);
	hl_fill_mass(&o->fill, &vf, cf);
	q.x = cm[0];
	q.y = cm[1];
	if (vf > 0 && vm - vf > 0) {
		q.x = (vm * cm[0] - vf * cf[0]) / (vm - vf);
		q.y = (vm * cm[1] - vf * cf[1]) / (vm - vf);
	}
	return q;
}

/* The fill alone (step 9's other candidate) on a helper thread, while the
 * job thread fills around the optimised voids: the two are independent
 * (both read the part and the config only).  The helper has a private
 * progress record whose cancel hook is the flag the job thread raises
 * when its own fill stops (progress.h: helpers never touch the job's). */
struct alone_job {
	const struct mesh *part;
	const struct hl_config *c;
	struct hl_fill fill;
	struct progress prog;
	struct err e;
	atomic_int stop;
	int rc;
};

static int alone_cancelled(void *ctx)
{
	return atomic_load(&((struct alone_job *)ctx)->stop);
}

static void *alone_main(void *arg)
{
	struct alone_job *j = arg;

	j->rc = hl_fill_build(j->part, NULL, j->c, &j->prog, 0, 1, &j->fill, &j->e);
	return NULL;
}

/* The top-down fill of what the optimiser left (o->mesh holds its voids).
 * Lightweight: everywhere.  Stability (target: the goal region, hull: the
 * contact hull, r: its offset): removing mass at p moves the centre of
 * mass c along c - p, so while c is outside the target the fill keeps to
 * the half-plane behind c, away from the target's closest point q (the
 * raster counterpart of eq. 13-14's gradient); when c already stands, the
 * fill goes everywhere and is redone behind c only if it would tip the
 * part out of the offset hull H_r. */
static int fill_run(const struct mesh *part, const struct hl_config *c,
		    const struct hull_pt *target, size_t ntarget, const struct hull_pt *hull,
		    size_t nhull, double r_mm, struct progress *prog, struct hl_outcome *o,
		    struct err *e)
{
	const struct mesh *solid = o->voids ? o->mesh : NULL;
	struct hl_config fc = *c;
	struct hull_pt q = com_after(o), t;
	int edge, vertex, rc;
	double d;

	fc.fill_keep_set = 0;
	if (ntarget < 3)
		return hl_fill_build(part, solid, &fc, prog, 0.9, 1.0, &o->fill, e);
	d = hull_closest_mm(target, ntarget, q, &t, &edge, &vertex);
	if (!(d > 0)) {
		struct hull_pt *hr = NULL;
		size_t nhr = 0;
		rc = hl_fill_build(part, solid, &fc, prog, 0.9, 0.95, &o->fill, e);
		if (!rc)
			rc = hull_offset_in(hull, nhull, r_mm, &hr, &nhr, e);
		if (rc || (nhr >= 3 && hull_signed_distance_mm(hr, nhr, com_after(o)) > 0)) {
			mem_free(hr);
			return rc;
		}
		mem_free(hr);
		hl_fill_fini(&o->fill);
		/* behind c, away from the target's inscribed centre */
		hull_inradius_mm(target, ntarget, &t);
		d = hypot(t.x - q.x, t.y - q.y);
		if (!(d > 0))
			return 0;
	}
	/* c moves along n as the fill removes mass behind it, and then more
	 * mass lies behind it: the half-plane follows c (a fixed point) */
	fc.fill_keep_set = 1;
	fc.fill_keep[0] = (t.x - q.x) / d;
	fc.fill_keep[1] = (t.y - q.y) / d;
	for (int it = 0; it < HL_STAND_PASSES; it++) {
		double shift;
		fc.fill_keep[2] = fc.fill_keep[0] * q.x + fc.fill_keep[1] * q.y;
		rc = hl_fill_build(part, solid, &fc, prog, 0.95, 1.0, &o->fill, e);
		if (rc)
			return rc;
		t = com_after(o);
		shift = fc.fill_keep[0] * (t.x - q.x) + fc.fill_keep[1] * (t.y - q.y);
		q = t;
		if (!(shift > HL_STAND_STEP_MM) || !(hull_closest_mm(target, ntarget, q, &t, &edge,
								      &vertex) > 0))
			break;
	}
	return 0;
}

int hl_run(const struct mesh *part, const struct hl_config *c, struct progress *prog,
	   struct hl_outcome *o, struct err *e)
{
	struct hl_outcome res;
	struct hl_nlp_opts nlp;
	struct paths *base = NULL;
	struct hull_pt *hull = NULL, *target = NULL;
	size_t nhull = 0, ntarget = 0;
	struct box3 bb = box3_empty();
	double com[3];
	int rc = 0, m, stack_count, nslices;

	memset(&res, 0, sizeof res);
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	m = (int)lround(c->opt_layer_mm / c->stack_layer_mm);
	if (m < 1)
		m = 1;
	stack_count = layer_count_for(bb.hi.z, c->stack_layer_mm);
	if (stack_count < 1)
		return ERR_SET(e, ERR_LIMIT, "hollow: %.2f mm at %g mm stack layers is too many layers",
			       bb.hi.z, c->stack_layer_mm);
	nslices = (stack_count - 1 - m / 2) / m + 1;
	res.opt_layer_mm = m * c->stack_layer_mm;
	res.sample_mm = c->sample_mm;
	res.mesh = mesh_clone(part);
	if (!res.mesh)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory copying the part");
	hl_mesh_mass(part, &res.part_volume_mm3, com);

	memset(&nlp, 0, sizeof nlp);
	nlp.alpha_rad = c->alpha_rad - c->margin_rad;
	nlp.h_mm = res.opt_layer_mm;
	nlp.ceil_eps_mm2 = 1e-5;
	nlp.gate_tau = 1e-3;
	nlp.max_iter = 400;
	nlp.max_outer = 4;
	nlp.deadline_s = c->optimise_s > 0 ? progress_now_s() + c->optimise_s : 0;
	nlp.objective = c->objective;
	nlp.light_weight = c->light_weight;
	if (c->objective == HL_OBJ_STABILITY) {
		double rho;
		struct hull_pt q = {com[0], com[1]};
		rc = slice_contact_hull(part, c->print_layer_mm, &hull, &nhull, e);
		if (rc)
			goto out;
		if (nhull < 3) {
			snprintf(res.note, sizeof res.note, "no contact area found on the first layer");
		} else {
			rho = hull_inradius_mm(hull, nhull, NULL);
			res.has_com = 1;
			res.hull_offset_mm = 0.5 * rho;
			res.com_before_mm = hull_signed_distance_mm(hull, nhull, q);
			res.stands_before = res.com_before_mm > 0;
			/* target: H_r shrunk by another 10 % of r, so the optimum (on
			 * the target's boundary) lies strictly inside H_r */
			rc = hull_offset_in(hull, nhull, 0.55 * rho, &target, &ntarget, e);
			if (rc)
				goto out;
			nlp.target = target;
			nlp.ntarget = ntarget;
		}
	}
	base = mem_calloc((size_t)nslices + 1, sizeof *base);
	if (!base) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	for (int k = 0; k < nslices; k++)
		paths_init(&base[k]);
	for (int r = 1; r <= c->rounds; r++) {
		struct round_in in = {c, res.mesh, r == 1 ? c->wall_mm : c->wall_next_mm, m, nslices,
				      stack_count, r == 1 ? NULL : base, r == 1 ? base : NULL, &nlp};
		struct hl_void *vv = NULL;
		size_t nvv = 0, kept = 0;
		unsigned char *kept_mask = NULL;
		double f0 = (double)(r - 1) / c->rounds, f1 = (double)r / c->rounds, t0;

		if (nlp.deadline_s > 0 && progress_now_s() >= nlp.deadline_s) {
			res.budget_spent = 1;
			break;
		}
		if (prog) {
			rc = progress_update(prog, f0, e);
			if (rc)
				goto out;
		}
		rc = round_voids(&in, &res, &vv, &nvv, e);
		if (rc)
			goto out;
		if (c->objective == HL_OBJ_STABILITY && ntarget >= 3) {
			double vs, cs[3];
			hl_mesh_mass(res.mesh, &vs, cs);
			nlp.vol_mm3 = vs;
			nlp.com_xy[0] = cs[0];
			nlp.com_xy[1] = cs[1];
		} else {
			nlp.objective = HL_OBJ_LIGHTWEIGHT;
		}
		t0 = progress_now_s();
		rc = hl_solve_round(vv, nvv, &nlp, c->threads, prog, f0 + 0.2 * (f1 - f0), f1, e);
		res.s_solve += progress_now_s() - t0;
		res.budget_spent |= nlp.deadline_s > 0 && progress_now_s() >= nlp.deadline_s;
		if (rc) {
			voids_fini(vv, nvv);
			goto out;
		}
		t0 = progress_now_s();
		/* larger voids first: a void too close to a kept one is dropped
		 * (no void: vv may be NULL, which qsort must not see) */
		if (nvv > 1)
			qsort(vv, nvv, sizeof *vv, cmp_void_volume_desc);
		kept_mask = mem_calloc(nvv + 1, 1);
		if (!kept_mask) {
			voids_fini(vv, nvv);
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			goto out;
		}
		for (size_t i = 0; i < nvv; i++) {
			res.iterations += vv[i].iterations;
			if (vv[i].status < 0) {
				res.groups_failed++;
				continue;
			}
			if (vv[i].volume_mm3 < c->min_void_mm3) {
				res.groups_small++;
				continue;
			}
			{
				int close = 0;
				for (size_t j = 0; j < i && !close; j++)
					close = kept_mask[j] &&
						voids_too_close(&vv[i], &vv[j], c->wall_next_mm);
				if (close) {
					res.voids_too_close++;
					continue;
				}
			}
			/* stability: a void (solved jointly, or a fallback start) is
			 * kept only if it does not move the centre of mass away from
			 * the target (distance to it, 0 inside) */
			if (nlp.objective == HL_OBJ_STABILITY) {
				double p[2], vn = nlp.vol_mm3 - vv[i].volume_mm3, d0, d1;
				struct hull_pt q0 = {nlp.com_xy[0], nlp.com_xy[1]}, q1, t;
				int edge, vertex;
				if (void_centroid(&vv[i], p) || !(vn > 0)) {
					res.voids_against_com++;
					continue;
				}
				q1.x = (nlp.vol_mm3 * q0.x - vv[i].volume_mm3 * p[0]) / vn;
				q1.y = (nlp.vol_mm3 * q0.y - vv[i].volume_mm3 * p[1]) / vn;
				d0 = hull_closest_mm(target, ntarget, q0, &t, &edge, &vertex);
				d1 = hull_closest_mm(target, ntarget, q1, &t, &edge, &vertex);
				if (d1 > d0 + 1e-9) {
					res.voids_against_com++;
					continue;
				}
				nlp.vol_mm3 = vn;
				nlp.com_xy[0] = q1.x;
				nlp.com_xy[1] = q1.y;
			}
			rc = append_void(res.mesh, &vv[i], e);
			if (rc) {
				voids_fini(vv, nvv);
				mem_free(kept_mask);
				goto out;
			}
			res.voids_fallback += vv[i].status == HL_STATUS_FALLBACK;
			res.void_volume_mm3 += vv[i].volume_mm3;
			kept_mask[i] = 1;
			kept++;
		}
		mem_free(kept_mask);
		kept_mask = NULL;
		res.s_mesh += progress_now_s() - t0;
		voids_fini(vv, nvv);
		if (!kept)
			break;
		res.voids += kept;
		res.rounds = r;
	}
	res.voids_optimised = res.voids;
	res.opt_volume_mm3 = res.void_volume_mm3;
	if (c->fill && (c->objective == HL_OBJ_LIGHTWEIGHT || ntarget >= 3)) {
		double t0 = progress_now_s();
		int both = res.voids_optimised > 0 && c->objective == HL_OBJ_LIGHTWEIGHT;
		struct alone_job *aj = NULL;
		pthread_t th;
		if (both && c->threads >= 2 && (aj = mem_calloc(1, sizeof *aj)) != NULL) {
			struct progress_hooks hk = {NULL, alone_cancelled, aj};
			aj->part = part;
			aj->c = c;
			err_clear(&aj->e);
			atomic_init(&aj->stop, 0);
			progress_init(&aj->prog, &hk);
			if (pthread_create(&th, NULL, alone_main, aj) != 0) {
				mem_free(aj); /* no thread: the fill alone runs after, here */
				aj = NULL;
			}
		}
		rc = fill_run(part, c, target, ntarget, hull, nhull, res.hull_offset_mm, prog, &res, e);
		if (aj) {
			if (rc)
				atomic_store(&aj->stop, 1);
			pthread_join(th, NULL);
			if (!rc && aj->rc) {
				*e = aj->e;
				rc = aj->rc;
			}
			if (rc)
				hl_fill_fini(&aj->fill);
		}
		if (rc) {
			mem_free(aj);
			goto out;
		}
		res.voids += res.fill.voids;
		res.void_volume_mm3 += res.fill.volume_mm3;
		/* lightweight: the fill keeps wall_next_mm from the optimised
		 * voids, and where they are smaller than what the fill alone
		 * would carve there the pair hollows less; keep the larger */
		if (!rc && res.voids_optimised > 0 && c->objective == HL_OBJ_LIGHTWEIGHT) {
			struct hl_fill alone;
			if (aj) {
				alone = aj->fill;
				mem_free(aj);
				aj = NULL;
			} else {
				memset(&alone, 0, sizeof alone);
				rc = hl_fill_build(part, NULL, c, prog, 0.95, 1.0, &alone, e);
				if (rc)
					goto out;
			}
			res.fill_alone_mm3 = alone.volume_mm3;
			res.opt_fill_mm3 = res.void_volume_mm3;
			if (alone.volume_mm3 > res.void_volume_mm3) {
				struct mesh *pm = mesh_clone(part);
				if (!pm) {
					hl_fill_fini(&alone);
					rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
					goto out;
				}
				mesh_free(res.mesh);
				res.mesh = pm;
				hl_fill_fini(&res.fill);
				res.fill = alone;
				res.voids_dropped_for_fill = res.voids_optimised;
				res.rounds = 0; /* no optimised round is in the output */
				res.voids = alone.voids;
				res.voids_optimised = res.voids_fallback = 0;
				res.void_volume_mm3 = alone.volume_mm3;
			} else {
				hl_fill_fini(&alone);
			}
		}
		if (aj) { /* not taken above (cannot happen: same condition) */
			hl_fill_fini(&aj->fill);
			mem_free(aj);
		}
		res.s_fill = progress_now_s() - t0;
	}
	if (!res.voids && !res.note[0] && c->fill_map_set && c->rounds == 0) {
		/* the pixel fill alone: its pixels are whole squares, so with
		 * a reach under one pixel no solid pixel may hang over a void */
		const struct raster_map *fm = &c->fill_map;
		double pitch = 1 / sqrt(fabs(fm->a[0][0] * fm->a[1][1] - fm->a[0][1] * fm->a[1][0]));
		double reach = c->print_layer_mm * tan(c->alpha_rad);
		if (reach < pitch)
			snprintf(res.note, sizeof res.note,
				 "no support-free void: at this alpha a layer may overhang %.3f mm, less "
				 "than the %.3f mm pixel, and the pixel fill cannot hang a pixel over a "
				 "void; the optimiser's voids (rounds > 0) or a larger alpha can hollow it",
				 reach, pitch);
	}
	if (!res.voids && !res.note[0])
		snprintf(res.note, sizeof res.note,
			 "too thin to hollow: no support-free void of at least %g mm3 fits inside a "
			 "%g mm wall; the part is returned unchanged",
			 c->min_void_mm3, c->wall_mm);
	if (res.has_com) {
		struct hull_pt q = com_after(&res);
		res.com_after_mm = hull_signed_distance_mm(hull, nhull, q);
		{
			struct hull_pt *hr = NULL;
			size_t nhr = 0;
			rc = hull_offset_in(hull, nhull, res.hull_offset_mm, &hr, &nhr, e);
			if (rc)
				goto out;
			res.com_inside = nhr >= 3 && hull_signed_distance_mm(hr, nhr, q) > 0;
			mem_free(hr);
		}
	}
	*o = res;
	memset(&res, 0, sizeof res);
out:
	hl_outcome_fini(&res);
	for (int k = 0; base && k < nslices; k++)
		paths_fini(&base[k]);
	mem_free(base);
	mem_free(hull);
	mem_free(target);
	return rc;
}
