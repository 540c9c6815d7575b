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
#include "engine/hollow/opt/opt.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/clip.h"
#include "engine/geom/polytri.h"
#include "engine/hollow/opt/opt_int.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

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
	const struct hl_opt_params *c;
	const struct mesh *solid; /* S_r */
	double wall;              /* t_r */
	int *sj;                  /* stack layer of each optimisation slice; round 1
				   * with plan_tmax > 0 chooses them (slices.c) */
	int *nslices;             /* optimisation slices (set by round 1's plan) */
	int m;                    /* stack layers per candidate slice */
	double thin_mm;           /* thinnest slab allowed (mm): a lone slice's sampling */
	size_t plan_tmax;         /* > 0: adaptive, at most this many candidates a slab */
	int stack_count;
	struct paths *base;       /* round 1 offset per slice (rounds >= 2), or NULL */
	struct paths *keep;       /* round 1: receives the offset per slice */
	const struct hl_nlp_opts *nlp;
	struct progress *prog;    /* polled for cancellation while voids are built */
	double f;                 /* its fraction meanwhile */
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

/* Voids of chain[a, b) (loops bottom to top): void.c builds upward until
 * a pair of loops has no strip at offset 0 (the rest is the next void);
 * restrip.c may then end a void higher up, and the loops below it, up to
 * the highest loop at least gap_mm under its floor (so the wall between
 * the two voids is at least wall_next_mm), are a chain of their own. */
struct chain_ctx {
	const struct hl_block *blk;
	double reach_slope;       /* reach over a slab's rise (hl_reach_slope) */
	double gap_mm;            /* wall_next_mm: floor of a void to the next below */
	int smooth_passes;        /* > 0: a void that ends early is tried smoothed */
	struct hl_void *vv;
	size_t nvv, vcap;
	size_t unbuilt;           /* runs of loops no void could be made of */
	double deadline_s;        /* optimise_s's end (progress_now_s), 0: none */
	struct progress *prog;    /* polled for cancellation (may be NULL) */
	double f;                 /* prog's fraction meanwhile */
	int spent;                /* the deadline passed: no more voids built */
};

/* Section 6's P -> P~ where the paper applies it, at contours whose
 * constraints are hard to satisfy: the void of loops[0..n) ended early
 * (*first > 0) or could not be made (*rc0 == 1).  It is built again from
 * copies of the loops smoothed by smooth_passes (hl_loop_smooth: corners
 * cut inward only), and that void replaces *V (with its *first) when it
 * joins all n loops at offset 0 and its support-free start encloses more.
 * Returns 0 or a negative err_code. */
static int try_smoothed(struct chain_ctx *x, const struct hl_loop **loops, size_t n,
			struct hl_void *V, int *rc0, size_t *first, struct err *e)
{
	struct hl_loop *cp = mem_calloc(n + 1, sizeof *cp);
	const struct hl_loop **lp = mem_calloc(n + 1, sizeof *lp);
	struct hl_void W;
	size_t used = 0, f2 = 0;
	int rc = 0;

	hl_void_init(&W);
	if (!cp || !lp) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	for (size_t i = 0; i < n; i++) {
		cp[i] = *loops[i];
		cp[i].xy = mem_alloc(2 * loops[i]->n * sizeof *cp[i].xy);
		if (!cp[i].xy) {
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			goto out;
		}
		memcpy(cp[i].xy, loops[i]->xy, 2 * loops[i]->n * sizeof *cp[i].xy);
		lp[i] = &cp[i];
		rc = hl_loop_smooth(&cp[i], x->smooth_passes, e);
		if (rc)
			goto out;
	}
	rc = hl_void_build(lp, n, x->blk, &W, &used, e);
	if (rc == 0)
		rc = hl_void_restrip(&W, x->reach_slope, x->blk, &f2, e);
	if (rc < 0)
		goto out;
	if (rc == 0 && used == n) {
		double v0 = *rc0 == 0 ? hl_void_volume(V, V->start) : 0;
		double v1 = hl_void_volume(&W, W.start);
		if (v1 > v0) {
			hl_void_fini(V);
			*V = W;
			hl_void_init(&W);
			*first = f2;
			*rc0 = 0;
		}
	}
	rc = 0;
out:
	hl_void_fini(&W);
	for (size_t i = 0; cp && i < n; i++)
		hl_loop_fini(&cp[i]);
	mem_free(cp);
	mem_free(lp);
	return rc;
}

static int chain_voids(struct chain_ctx *x, const struct hl_loop **chain, size_t a, size_t b,
		       struct err *e)
{
	while (a + 1 < b) {
		size_t used = 0, first = 0;
		struct hl_void V;
		void *arr;
		int rc;
		/* each void can take seconds on long loops: the wall-clock guard
		 * and a cancelled job are heard between them */
		if (x->deadline_s > 0 && progress_now_s() >= x->deadline_s)
			x->spent = 1;
		if (x->spent)
			return 0;
		if (x->prog && (rc = progress_update(x->prog, x->f, e)) != 0)
			return rc;
		hl_void_init(&V);
		rc = hl_void_build(chain + a, b - a, x->blk, &V, &used, e);
		if (rc < 0)
			return rc;
		if (rc == 0)
			rc = hl_void_restrip(&V, x->reach_slope, x->blk, &first, e);
		if (rc < 0) {
			hl_void_fini(&V);
			return rc;
		}
		if (x->smooth_passes > 0 && (rc == 1 || first > 0) && used >= 2) {
			int r2 = try_smoothed(x, chain + a, used, &V, &rc, &first, e);
			if (r2 < 0) {
				hl_void_fini(&V);
				return r2;
			}
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
			x->unbuilt++;
		}
		if (first > 0) {
			/* the chain below ends at the highest loop at least
			 * gap_mm under the floor, chain[a + first] */
			size_t end = a + first;
			while (end > a && chain[a + first]->z_mm - chain[end - 1]->z_mm <
						  x->gap_mm - 1e-9)
				end--;
			if (end >= a + 2) {
				rc = chain_voids(x, chain, a, end, e);
				if (rc)
					return rc;
			}
		}
		a += used > 0 ? used : 1;
	}
	return 0;
}

double hl_sample_mm(double h_mm, double alpha_rad, double margin_rad)
{
	return fmin(0.5, fmax(0.1, 0.5 * h_mm * tan(alpha_rad - margin_rad)));
}

/* Sample spacing s of slice k: the user's, or hl_sample_mm of the thinner
 * of the slabs below and above it (adaptive slices: a loop between thick
 * slabs needs no finer sampling than they do), of thin_mm (the thinnest
 * slab allowed) for a lone slice. */
static double slice_spacing_mm(const struct hl_opt_params *c, const int *sj, int n, int k,
			       double thin_mm)
{
	double h = INFINITY;

	if (c->sample_mm > 0)
		return c->sample_mm;
	if (k > 0)
		h = fmin(h, (sj[k] - sj[k - 1]) * c->stack_layer_mm);
	if (k + 1 < n)
		h = fmin(h, (sj[k + 1] - sj[k]) * c->stack_layer_mm);
	return hl_sample_mm(isfinite(h) ? h : thin_mm, c->alpha_rad, c->margin_rad);
}

/* Round 1, adaptive: erode every candidate layer j = m i + m / 2 (the
 * uniform plan's layers at the thinnest slab), choose the slices among
 * them (slices.c) and hand their regions back in *pre (*in->nslices
 * entries, caller frees); in->sj receives their stack layers. */
static int plan_slices(const struct round_in *in, struct slice_eroder *er, struct paths **pre,
		       struct err *e)
{
	int m = in->m, nc = (in->stack_count - 1 - m / 2) / m + 1;
	struct paths *cand = mem_calloc((size_t)nc + 1, sizeof *cand);
	size_t *pick = mem_alloc(((size_t)nc + 1) * sizeof *pick), np = 0;
	int rc = 0;

	if (!cand || !pick) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory planning slices");
		goto out;
	}
	for (int i = 0; i < nc; i++) {
		paths_init(&cand[i]);
		rc = slice_erode_layer(er, m * i + m / 2, &cand[i], e);
		if (rc)
			goto out;
	}
	/* a slab may deviate by one pixel of the erosion grid: finer than
	 * that the offset itself is not known */
	rc = hl_slices_adaptive(cand, (size_t)nc, in->plan_tmax, in->c->pixel_mm, pick, &np, e);
	if (rc)
		goto out;
	for (size_t k = 0; k < np; k++) {
		in->sj[k] = m * (int)pick[k] + m / 2;
		if (pick[k] != k) { /* pick[k] > k: candidate k is not needed */
			paths_fini(&cand[k]);
			cand[k] = cand[pick[k]];
			paths_init(&cand[pick[k]]);
		}
	}
	for (size_t k = np; k < (size_t)nc; k++)
		paths_fini(&cand[k]);
	*in->nslices = (int)np;
	*pre = cand;
	cand = NULL;
out:
	for (int i = 0; cand && i < nc; i++)
		paths_fini(&cand[i]);
	mem_free(cand);
	mem_free(pick);
	return rc;
}

static int round_voids(const struct round_in *in, struct hl_opt_stats *o, struct hl_void **vout,
		       size_t *nvout, struct err *e)
{
	const struct hl_opt_params *c = in->c;
	struct slice_mid_source sc = {NULL, 0}; /* the eroder's slices (its slicer owned) */
	struct slice_eroder *er = NULL;
	struct mesh_bvh *bvh = NULL;
	struct hl_slice *sl = NULL;
	struct hl_void *vv = NULL;
	size_t nvv = 0, vcap = 0;
	int **up = NULL, **down = NULL;
	struct paths reg, tmp;
	struct box3 bb = box3_empty();
	double t0 = progress_now_s();
	struct paths *pre = NULL; /* adaptive: the chosen slices' regions */
	int rc, nslices = 0;

	paths_init(&reg);
	paths_init(&tmp);
	for (size_t i = 0; i < in->solid->nv; i++)
		box3_add(&bb, in->solid->v[i]);
	{
		/* sc lives on this stack frame for the whole erosion below */
		rc = slice_erode_mesh_new(in->solid, in->wall, c->pixel_mm, c->stack_layer_mm,
					  in->stack_count, &bb, &sc, &er, e);
		if (rc)
			goto out;
		if (in->plan_tmax > 0) {
			rc = plan_slices(in, er, &pre, e);
			if (rc)
				goto out;
		}
		nslices = *in->nslices;
		sl = mem_calloc((size_t)nslices + 1, sizeof *sl);
		if (!sl)
			goto nomem;
		for (int k = 0; k < nslices; k++) {
			int j = in->sj[k];
			double sp = slice_spacing_mm(c, in->sj, nslices, k, in->thin_mm);
			struct hl_contour_params cp = {sp, c->wall_next_mm, 4 * sp * sp};
			if (pre) {
				paths_fini(&reg);
				reg = pre[k];
				paths_init(&pre[k]);
			} else {
				rc = slice_erode_layer(er, j, &reg, e);
				if (rc)
					goto out;
			}
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
			o->loops += sl[k].n;
		}
	}
	o->s_offset += progress_now_s() - t0;
	t0 = progress_now_s();
	/* groups: chains of mutually best links */
	rc = hl_group_links(sl, (size_t)nslices, 0.5, &up, e);
	if (rc)
		goto out;
	down = mem_calloc((size_t)nslices + 1, sizeof *down);
	if (!down)
		goto nomem;
	for (int k = 0; k < nslices; k++) {
		down[k] = mem_alloc((sl[k].n + 1) * sizeof **down);
		if (!down[k])
			goto nomem;
		for (size_t a = 0; a < sl[k].n; a++)
			down[k][a] = -1;
	}
	for (int k = 0; k + 1 < nslices; k++)
		for (size_t a = 0; a < sl[k].n; a++)
			if (up[k][a] >= 0)
				down[k + 1][up[k][a]] = (int)a;
	rc = mesh_bvh_new(in->solid, &bvh, e);
	if (rc)
		goto out;
	{
		struct block_ctx bx = {bvh, in->wall, c->pixel_mm, 0.5 * in->wall};
		struct hl_block blk = {blocked, &bx};
		const struct hl_loop **chain = mem_alloc(((size_t)nslices + 1) * sizeof *chain);
		struct chain_ctx cx = {&blk, hl_reach_slope(in->nlp->alpha_rad), c->wall_next_mm,
				       c->smooth_passes, vv, nvv, vcap, 0, in->nlp->deadline_s,
				       in->prog, in->f, 0};
		if (!chain)
			goto nomem;
		for (int k = 0; k < nslices && !rc && !cx.spent; k++)
			for (size_t a = 0; a < sl[k].n; a++) {
				size_t len = 0;
				if (down[k][a] >= 0)
					continue; /* not the bottom of a chain */
				for (int kk = k, aa = (int)a; aa >= 0 && kk < nslices;
				     aa = kk + 1 < nslices ? up[kk][aa] : -1, kk++)
					chain[len++] = &sl[kk].loop[aa];
				rc = chain_voids(&cx, chain, 0, len, e);
				if (rc || cx.spent)
					break;
			}
		vv = cx.vv;
		nvv = cx.nvv;
		vcap = cx.vcap;
		o->groups_unbuilt += cx.unbuilt;
		o->budget_spent |= cx.spent;
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
	hl_links_free(up, (size_t)nslices);
	hl_links_free(down, (size_t)nslices);
	slices_fini(sl, (size_t)nslices);
	for (int k = 0; pre && k < *in->nslices; k++)
		paths_fini(&pre[k]);
	mem_free(pre);
	mesh_bvh_free(bvh);
	slice_erode_free(er);
	slice_free(sc.slicer);
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
		double a, mx, my, h = hl_void_loop_h(v, k); /* eq. 12's slab per loop */
		hl_loop_moments(v, k, v->l, &a, &mx, &my);
		A += h * a;
		Mx += h * mx;
		My += h * my;
	}
	if (!(fabs(A) > 0))
		return -1;
	cxy[0] = Mx / A;
	cxy[1] = My / A;
	return 0;
}

/* Step 5 of one round: its solved voids vv[0..nvv) sorted larger first
 * (a void too close to a kept one is dropped), failed, small, too-close
 * and (stability) centre-of-mass-worsening ones dropped, the rest
 * appended to mesh; *kept counts them.  nlp's stability state (vol_mm3,
 * com_xy) follows the kept voids.  0, ERR_NOMEM or ERR_LIMIT. */
static int keep_voids(const struct hl_opt_params *c, struct hl_void *vv, size_t nvv,
		      struct hl_nlp_opts *nlp, struct mesh *mesh, struct hl_opt_stats *st,
		      size_t *kept, struct err *e)
{
	unsigned char *kept_mask;

	*kept = 0;
	/* no void: vv may be NULL, which qsort must not see */
	if (nvv > 1)
		qsort(vv, nvv, sizeof *vv, cmp_void_volume_desc);
	kept_mask = mem_calloc(nvv + 1, 1);
	if (!kept_mask)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	for (size_t i = 0; i < nvv; i++) {
		int close = 0, rc;
		/* stability solved them as one problem: its iterations once */
		if (i == 0 || nlp->objective != HL_OBJ_STABILITY)
			st->iterations += vv[i].iterations;
		if (vv[i].status < 0) {
			st->groups_failed++;
			continue;
		}
		if (vv[i].volume_mm3 < c->min_void_mm3) {
			st->groups_small++;
			continue;
		}
		/* a flat top wider than a printer pixel beyond the print layer's
		 * reach hangs (thinner slivers are the pixel model's, "11", 2) */
		if (c->print_layer_mm > 0) {
			double a;
			rc = hl_void_top_overhang_mm2(&vv[i], vv[i].l, c->print_layer_mm * tan(c->alpha_rad),
							&a, e);
			if (rc) {
				mem_free(kept_mask);
				return rc;
			}
			if (a > c->pixel_mm * c->pixel_mm) {
				st->groups_failed++;
				continue;
			}
		}
		for (size_t j = 0; j < i && !close; j++)
			close = kept_mask[j] && voids_too_close(&vv[i], &vv[j], c->wall_next_mm);
		if (close) {
			st->voids_too_close++;
			continue;
		}
		/* stability: a void (solved jointly, or a fallback start) is kept
		 * only if it does not move the centre of mass away from the
		 * target (distance to it, 0 inside) */
		if (nlp->objective == HL_OBJ_STABILITY) {
			double p[2], vn = nlp->vol_mm3 - vv[i].volume_mm3, d0, d1;
			struct hull_pt q0 = {nlp->com_xy[0], nlp->com_xy[1]}, q1, t;
			int edge, vertex;
			if (void_centroid(&vv[i], p) || !(vn > 0)) {
				st->voids_against_com++;
				continue;
			}
			q1.x = (nlp->vol_mm3 * q0.x - vv[i].volume_mm3 * p[0]) / vn;
			q1.y = (nlp->vol_mm3 * q0.y - vv[i].volume_mm3 * p[1]) / vn;
			d0 = hull_closest_mm(c->target, c->ntarget, q0, &t, &edge, &vertex);
			d1 = hull_closest_mm(c->target, c->ntarget, q1, &t, &edge, &vertex);
			if (d1 > d0 + 1e-9) {
				st->voids_against_com++;
				continue;
			}
			nlp->vol_mm3 = vn;
			nlp->com_xy[0] = q1.x;
			nlp->com_xy[1] = q1.y;
		}
		rc = append_void(mesh, &vv[i], e);
		if (rc) {
			mem_free(kept_mask);
			return rc;
		}
		st->voids_fallback += vv[i].status == HL_STATUS_FALLBACK;
		st->volume_mm3 += vv[i].volume_mm3;
		kept_mask[i] = 1;
		(*kept)++;
	}
	mem_free(kept_mask);
	return 0;
}

/* A round's solves get fewer iterations than this from the work budget:
 * none start (an interior-point solve this short ends far from its
 * optimum: the box takes about 30 from the start, bench groups 50-400). */
#define HL_WORK_MIN_ITER 20

/* The work budget's price of one Ipopt iteration of a problem of nv
 * offsets, in reference seconds: a nv + b nv^2 fitted to two solves on
 * the project's 2-core machine (docs/hollow.md "3.4": the femur's void,
 * 3154 offsets, 51.7 ms an iteration; the letter P's stability problem at
 * 100 mm, 39,322 offsets, 1.86 s).  A fixed formula of the problem's
 * size, not a clock: the same on every machine. */
static double iter_cost_s(double nv)
{
	return 1.37e-5 * nv + 8.53e-10 * nv * nv;
}

/* The round's problems and their price per iteration (reference s):
 * lightweight solves each void on its own, stability all of them as one
 * problem (hl_solve_round). */
static double round_cost_s(const struct hl_nlp_opts *nlp, const struct hl_void *vv, size_t nvv)
{
	double nv = 0, sum = 0;

	for (size_t i = 0; i < nvv; i++) {
		nv += (double)vv[i].nv;
		sum += iter_cost_s((double)vv[i].nv);
	}
	return nlp->objective == HL_OBJ_STABILITY ? iter_cost_s(nv) : sum;
}

/* The work budget's share for the round's voids vv[0..nvv): every solve
 * the same iteration cap, work_left_s (reference seconds) over the
 * round's price per iteration (nlp->iter_cap; 0 = none where that is at
 * least the most callbacks the solver makes uncapped, (max_iter + 1) x
 * max_outer); under HL_WORK_MIN_ITER none solves (nlp->iter_cap < 0: the
 * voids keep their start).  Deterministic: the cap depends on the voids'
 * sizes and the work done before, not on time or the order solves
 * finish. */
static void work_cap(struct hl_nlp_opts *nlp, const struct hl_void *vv, size_t nvv,
		     double work_left_s)
{
	double per = round_cost_s(nlp, vv, nvv), cap,
	       most = (nlp->max_iter + 1.0) * nlp->max_outer;

	cap = per > 0 ? floor(work_left_s / per) : most;
	nlp->iter_cap = cap >= most ? 0 : cap < HL_WORK_MIN_ITER ? -1 : (int)cap;
}

/* The work the round's solves did (reference seconds): each problem's
 * iterations at its price (stability: one problem, the same iterations
 * on every void). */
static double work_done_s(const struct hl_nlp_opts *nlp, const struct hl_void *vv, size_t nvv)
{
	double w = 0;

	if (nvv == 0)
		return 0;
	if (nlp->objective == HL_OBJ_STABILITY)
		return round_cost_s(nlp, vv, nvv) * vv[0].iterations;
	for (size_t i = 0; i < nvv; i++)
		w += iter_cost_s((double)vv[i].nv) * vv[i].iterations;
	return w;
}

/* The round's solves met the work budget's cap: none could start, or
 * the cap cut one (hl_nlp_solve's record). */
static int work_capped(const struct hl_nlp_opts *nlp, const struct hl_void *vv, size_t nvv)
{
	if (nlp->iter_cap < 0)
		return nvv > 0;
	for (size_t i = 0; nlp->iter_cap > 0 && i < nvv; i++)
		if (vv[i].capped)
			return 1;
	return 0;
}

int hl_opt_run(const struct mesh *part, const struct hl_opt_params *c, struct progress *prog,
	       struct mesh **out, struct hl_opt_stats *st, struct err *e)
{
	struct hl_nlp_opts nlp;
	struct paths *base = NULL;
	struct mesh *res = NULL;
	struct box3 bb = box3_empty();
	int stab = c->objective == HL_OBJ_STABILITY && c->target && c->ntarget >= 3;
	int *sj = NULL;
	int rc = 0, m, mmax, stack_count, nslices, ncand;
	size_t tmax = 0;
	double thin_mm, work_left_s = 0;

	*out = NULL;
	memset(st, 0, sizeof *st);
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	mmax = (int)lround(c->opt_layer_mm / c->stack_layer_mm);
	if (mmax < 1)
		mmax = 1;
	m = mmax;
	if (c->opt_layer_min_mm > 0) {
		/* adaptive: candidates every thinnest slab, slabs of whole candidates */
		m = (int)lround(c->opt_layer_min_mm / c->stack_layer_mm);
		m = m < 1 ? 1 : m > mmax ? mmax : m;
		tmax = (size_t)(mmax / m);
	}
	thin_mm = m * c->stack_layer_mm; /* zigzag edges must meet eq. 5 on it */
	if (c->opt_layer_min_mm > 0 && tmax < 2) { /* one candidate a slab: nothing to choose */
		tmax = 0;
		m = mmax;
	}
	stack_count = layer_count_for(bb.hi.z, c->stack_layer_mm);
	if (stack_count < 1)
		return ERR_SET(e, ERR_LIMIT, "hollow: %.2f mm at %g mm stack layers is too many layers",
			       bb.hi.z, c->stack_layer_mm);
	ncand = nslices = (stack_count - 1 - m / 2) / m + 1;
	st->opt_layer_mm = (tmax ? (int)tmax * m : m) * c->stack_layer_mm;
	st->sample_mm = c->sample_mm > 0 ? c->sample_mm
					 : hl_sample_mm(thin_mm, c->alpha_rad, c->margin_rad);
	sj = mem_alloc(((size_t)ncand + 1) * sizeof *sj);
	res = sj ? mesh_clone(part) : NULL;
	if (!res) {
		mem_free(sj);
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory copying the part");
	}
	for (int k = 0; k < nslices; k++)
		sj[k] = m * k + m / 2;

	memset(&nlp, 0, sizeof nlp);
	nlp.alpha_rad = c->alpha_rad - c->margin_rad;
	nlp.ceil_eps_mm2 = 1e-5;
	nlp.gate_tau = 1e-3;
	nlp.max_iter = 400;
	nlp.max_outer = 4;
	nlp.deadline_s = c->optimise_s > 0 ? progress_now_s() + c->optimise_s : 0;
	work_left_s = c->optimise_work;
	nlp.objective = stab ? HL_OBJ_STABILITY : HL_OBJ_LIGHTWEIGHT;
	nlp.light_weight = c->light_weight;
	if (stab) {
		nlp.target = c->target;
		nlp.ntarget = c->ntarget;
	}
	base = mem_calloc((size_t)ncand + 1, sizeof *base);
	if (!base) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	for (int k = 0; k < ncand; k++)
		paths_init(&base[k]);
	for (int r = 1; r <= c->rounds; r++) {
		struct round_in in = {c,     res, r == 1 ? c->wall_mm : c->wall_next_mm,
				      sj,    &nslices, m, thin_mm, r == 1 ? tmax : 0, stack_count,
				      r == 1 ? NULL : base, r == 1 ? base : NULL, &nlp,
				      prog, (double)(r - 1) / c->rounds};
		struct hl_void *vv = NULL;
		size_t nvv = 0, kept = 0;
		double f0 = (double)(r - 1) / c->rounds, f1 = (double)r / c->rounds, t0;

		if (nlp.deadline_s > 0 && progress_now_s() >= nlp.deadline_s) {
			st->budget_spent = 1;
			break;
		}
		if (prog) {
			rc = progress_update(prog, f0, e);
			if (rc)
				goto out;
		}
		rc = round_voids(&in, st, &vv, &nvv, e);
		if (rc)
			goto out;
		if (r == 1) {
			st->slices = (size_t)nslices;
			st->opt_layer_min_used_mm = nslices > 1 ? INFINITY : 0;
			for (int k = 0; k + 1 < nslices; k++)
				st->opt_layer_min_used_mm = fmin(st->opt_layer_min_used_mm,
								 (sj[k + 1] - sj[k]) * c->stack_layer_mm);
		}
		if (stab) {
			double vs, cs[3];
			hl_mesh_mass(res, &vs, cs);
			nlp.vol_mm3 = vs;
			nlp.com_xy[0] = cs[0];
			nlp.com_xy[1] = cs[1];
		}
		if (c->optimise_work > 0)
			work_cap(&nlp, vv, nvv, work_left_s);
		t0 = progress_now_s();
		rc = hl_solve_round(vv, nvv, &nlp, c->threads, prog, f0 + 0.2 * (f1 - f0), f1, e);
		st->s_solve += progress_now_s() - t0;
		st->budget_spent |= nlp.deadline_s > 0 && progress_now_s() >= nlp.deadline_s;
		st->work_spent |= work_capped(&nlp, vv, nvv);
		{
			double w = work_done_s(&nlp, vv, nvv);
			work_left_s -= w;
			st->work_s += w;
		}
		if (!rc) {
			t0 = progress_now_s();
			rc = keep_voids(c, vv, nvv, &nlp, res, st, &kept, e);
			st->s_mesh += progress_now_s() - t0;
		}
		voids_fini(vv, nvv);
		if (rc)
			goto out;
		if (!kept)
			break;
		st->voids += kept;
		st->rounds = r;
		if (st->work_spent)
			break; /* the budget cut this round: no later round starts */
	}
	*out = res;
	res = NULL;
out:
	mesh_free(res);
	for (int k = 0; base && k < ncand; k++)
		paths_fini(&base[k]);
	mem_free(base);
	mem_free(sj);
	return rc;
}
