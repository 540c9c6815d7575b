/* topdown.c - the top-down support-free fill: the void a greedy top-down
 * construction fits inside the offset stack, one stack layer at a time,
 * exact in integer nm (Clipper offsets); the hollow engine's fallback where
 * the optimiser (nlp.c) leaves space unhollowed.  Derivation and why it is
 * a deviation from paper 004: docs/hollow.md "Top-down fill".
 */
#include "engine/hollow/topdown.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/clip.h"
#include "engine/hollow/rounds.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/slice.h"

void hl_fill_fini(struct hl_fill *f)
{
	for (int k = 0; f->layer && k < f->n; k++)
		paths_fini(&f->layer[k]);
	mem_free(f->layer);
	memset(f, 0, sizeof *f);
}

const struct paths *hl_fill_at(const struct hl_fill *f, double z_mm)
{
	int j;

	if (!f->layer || f->n < 1 || !(f->layer_mm > 0))
		return NULL;
	/* a print layer's mid-plane lies inside exactly one stack slab (the
	 * 1e-9 keeps a mid-plane that falls on a slab boundary in the upper
	 * one, whatever the rounding) */
	j = (int)floor(z_mm / f->layer_mm + 1e-9);
	if (j < 0 || j >= f->n || !f->layer[j].n)
		return NULL;
	return &f->layer[j];
}

/* ---- the offset stack C(k) ---- */

int hl_src_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	struct hl_src_ctx *c = ctx;

	return slice_at(c->s, (k + 0.5) * c->layer_mm, region, NULL, e);
}

struct eroded {
	struct slicer *s;
	struct hl_src_ctx sc;
	struct slice_eroder *er;
};

static int eroded_open(struct eroded *x, const struct mesh *m, double r_mm,
		       const struct hl_config *c, int stack_count, const struct box3 *bb,
		       struct err *e)
{
	struct slice_erode_params ep;
	struct slice_erode_source src;
	int rc;

	memset(x, 0, sizeof *x);
	rc = slice_new(m, &x->s, e);
	if (rc)
		return rc;
	x->sc.s = x->s;
	x->sc.layer_mm = c->stack_layer_mm;
	src.layer = hl_src_layer;
	src.ctx = &x->sc; /* x outlives the eroder */
	memset(&ep, 0, sizeof ep);
	ep.r_mm = r_mm;
	ep.pixel_mm = c->pixel_mm;
	ep.layer_mm = c->stack_layer_mm;
	ep.layer_count = stack_count;
	ep.x0_mm = bb->lo.x;
	ep.y0_mm = bb->lo.y;
	ep.x1_mm = bb->hi.x;
	ep.y1_mm = bb->hi.y;
	return slice_erode_new(&ep, &src, &x->er, e);
}

static void eroded_close(struct eroded *x)
{
	slice_erode_free(x->er);
	slice_free(x->s);
	memset(x, 0, sizeof *x);
}

/* C[k] for every stack layer, bottom-up (the eroders stream upward). */
static int offset_stack(const struct mesh *part, const struct mesh *solid,
			const struct hl_config *c, int n, struct paths *C, struct err *e)
{
	struct eroded ep, es;
	struct box3 bb = box3_empty();
	struct paths tmp;
	int rc;

	memset(&es, 0, sizeof es);
	paths_init(&tmp);
	for (size_t i = 0; i < part->nv; i++)
		box3_add(&bb, part->v[i]);
	rc = eroded_open(&ep, part, c->wall_mm, c, n, &bb, e);
	if (!rc && solid)
		rc = eroded_open(&es, solid, c->wall_next_mm, c, n, &bb, e);
	for (int k = 0; !rc && k < n; k++) {
		rc = slice_erode_layer(ep.er, k, &C[k], e);
		if (rc || !solid || !C[k].n)
			continue;
		rc = slice_erode_layer(es.er, k, &tmp, e);
		if (!rc)
			rc = clip_boolean(CLIP_INTERSECTION, &C[k], &tmp, CLIP_FILL_NONZERO, &C[k], e);
	}
	paths_fini(&tmp);
	eroded_close(&ep);
	eroded_close(&es);
	return rc;
}

/* ---- the greedy top-down construction ---- */

/* Raster safety margins in pixels (see hl_fill_build): the written void
 * is the designed one eroded by W; the design's reach is layer tan(alpha)
 * less D.  The bound needs W + 0.71 - D <= 1 and W >= 0.71 + the round
 * joins' arc tolerance (0.05 W: the eroded void may reach that much
 * closer to the solid); cleaning moves vertices by 0.01 px and the
 * covering test of layer_below is generous by 0.02 px. */
#define HL_FILL_W_PX 0.78
#define HL_FILL_D_PX 0.52

/* Drop the outer loops of void region ps whose area is below min_mm2
 * (in place; void turns solid, the safe direction), with every hole
 * their holes orphaned (negative winding): callers renormalise with the
 * positive fill rule, which drops them.  Holes are never dropped: a small
 * hole is solid holding something up. */
static void drop_small(struct paths *ps, double min_mm2)
{
	size_t w = 0;

	for (size_t i = 0; i < ps->n; i++) {
		double a = path_area_mm2(&ps->v[i]);
		if (a > 0 && a < min_mm2) {
			path_fini(&ps->v[i]);
			continue;
		}
		ps->v[w++] = ps->v[i];
	}
	ps->n = w;
}

/*
 * Layer k's void V(k) from V(k + 1) (empty above the part), with C = C(k),
 * d = layer_mm tan(alpha), Q(k) the non-void of layer k (solid or outside):
 * the rule is Q(k + 1) within d of Q(k).  Q(k) must contain the complement
 * of C; of Q(k + 1), that covers dilate(not C, d), leaving
 *   U = erode(C, d) \ V(k + 1),
 * which the solid T = Q(k) inside C must cover within d.  The smallest
 * such T we build is
 *   T = erode(U, d)  united with  R = U \ dilate(erode(U, d), d),
 * (R: the parts of U thinner than 2 d and its sharp convex corners, which
 * the opening loses; they are kept whole, so dilate(T, d) contains U),
 * and V(k) = C \ T.  Going down, every wall of solid thus retreats by d
 * per layer: the void's ceiling rises at exactly the overhang limit.
 * Clipper's round joins place their vertices on the arc, so every
 * approximation makes T larger (the void smaller): safe.  Pieces of R
 * under min_mm2 (a quarter pixel: numerical slivers of the round joins)
 * are dropped; the raster tolerance of one pixel covers them.
 */
static int layer_below(const struct paths *C, const struct paths *Vup, double d_nm,
		       double arc_nm, double min_mm2, double clean_nm, struct paths *V,
		       struct err *e)
{
	struct paths U, E, O, R;
	int rc;

	paths_init(&U);
	paths_init(&E);
	paths_init(&O);
	paths_init(&R);
	rc = clip_offset(C, -d_nm, CLIP_JOIN_ROUND, 0, arc_nm, &U, e);
	if (!rc && Vup->n)
		rc = clip_boolean(CLIP_DIFFERENCE, &U, Vup, CLIP_FILL_NONZERO, &U, e);
	if (!rc)
		rc = clip_offset(&U, -d_nm, CLIP_JOIN_ROUND, 0, arc_nm, &E, e);
	/* O by d + arc_nm with arc tolerance arc_nm / 2: the chords then lie
	 * outside the true d-disc, so R holds no slivers of the round joins
	 * (they would persist as hair-thin pillars); points between d and
	 * d + arc_nm count as covered: HL_FILL_D_PX allows for it */
	if (!rc)
		rc = clip_offset(&E, d_nm + arc_nm, CLIP_JOIN_ROUND, 0, 0.5 * arc_nm, &O, e);
	if (!rc)
		rc = clip_boolean(CLIP_DIFFERENCE, &U, &O, CLIP_FILL_NONZERO, &R, e);
	if (rc)
		goto out;
	rc = paths_append_move(&E, &R);
	if (rc) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	rc = clip_boolean(CLIP_DIFFERENCE, C, &E, CLIP_FILL_NONZERO, V, e);
	if (!rc) {
		drop_small(V, min_mm2);
		rc = clip_union(V, CLIP_FILL_POSITIVE, V, e);
	}
	/* bound the vertex count: round joins add vertices at every layer */
	if (!rc && V->n)
		rc = clip_clean(V, clean_nm, e);
out:
	paths_fini(&U);
	paths_fini(&E);
	paths_fini(&O);
	paths_fini(&R);
	return rc;
}

/* ---- components (3D connectivity through consecutive layers) ---- */

struct piece {
	int k;          /* layer */
	size_t outer;   /* path index of its outer loop */
	struct pt2 lo, hi;
	double area_mm2; /* outer minus its holes */
	size_t comp;    /* union-find parent */
};

static size_t uf_find(struct piece *p, size_t i)
{
	while (p[i].comp != i) {
		p[i].comp = p[p[i].comp].comp;
		i = p[i].comp;
	}
	return i;
}

static int path_contains(const struct path *p, struct pt2 q)
{
	int w = 0, on = 0;

	for (size_t i = 0; i < p->n; i++)
		w += path_edge_winding(p->pts[i], p->pts[(i + 1) % p->n], q, &on);
	return w != 0 || on;
}

/* Which outer loop of layer ps holds hole h: the smallest containing one
 * (Clipper's output has no overlaps), or SIZE_MAX. */
static size_t hole_owner(const struct paths *ps, size_t h)
{
	size_t best = SIZE_MAX;
	double ba = INFINITY;

	for (size_t i = 0; i < ps->n; i++) {
		double a = path_area_mm2(&ps->v[i]);
		if (a > 0 && a < ba && path_contains(&ps->v[i], ps->v[h].pts[0])) {
			best = i;
			ba = a;
		}
	}
	return best;
}

static void bbox_of(const struct path *p, struct pt2 *lo, struct pt2 *hi)
{
	*lo = *hi = p->pts[0];
	for (size_t i = 1; i < p->n; i++) {
		lo->x = p->pts[i].x < lo->x ? p->pts[i].x : lo->x;
		lo->y = p->pts[i].y < lo->y ? p->pts[i].y : lo->y;
		hi->x = p->pts[i].x > hi->x ? p->pts[i].x : hi->x;
		hi->y = p->pts[i].y > hi->y ? p->pts[i].y : hi->y;
	}
}

/* Do outer loops a and b overlap (positive area)? */
static int outers_overlap(const struct path *a, const struct path *b, int *yes, struct err *e)
{
	struct paths pa, pb, x;
	int rc;

	paths_init(&pa);
	paths_init(&pb);
	paths_init(&x);
	*yes = 0;
	rc = paths_add_pts(&pa, a->pts, a->n) || paths_add_pts(&pb, b->pts, b->n)
		     ? ERR_SET(e, ERR_NOMEM, "hollow: out of memory")
		     : 0;
	if (!rc)
		rc = clip_boolean(CLIP_INTERSECTION, &pa, &pb, CLIP_FILL_NONZERO, &x, e);
	if (!rc)
		*yes = paths_area_mm2(&x) > 1e-9;
	paths_fini(&pa);
	paths_fini(&pb);
	paths_fini(&x);
	return rc;
}

/* Group the fill's pieces into 3D components, drop those under
 * min_mm3, count the rest.  O(pieces^2 per layer pair) overlap tests,
 * bounding boxes first. */
static int components(struct hl_fill *f, double min_mm3, struct err *e)
{
	struct piece *p = NULL;
	size_t np = 0, cap = 0, *first = NULL;
	double *vol = NULL;
	unsigned char *drop = NULL;
	int rc = 0;

	first = mem_alloc(((size_t)f->n + 1) * sizeof *first);
	if (!first)
		goto nomem;
	for (int k = 0; k < f->n; k++) {
		const struct paths *L = &f->layer[k];
		first[k] = np;
		for (size_t i = 0; i < L->n; i++) {
			double a = path_area_mm2(&L->v[i]);
			void *arr = p;
			if (a <= 0)
				continue;
			if (mem_grow(&arr, &cap, np + 1, sizeof *p))
				goto nomem;
			p = arr;
			p[np].k = k;
			p[np].outer = i;
			p[np].area_mm2 = a;
			p[np].comp = np;
			bbox_of(&L->v[i], &p[np].lo, &p[np].hi);
			np++;
		}
		for (size_t i = 0; i < L->n; i++) {
			size_t o;
			if (path_area_mm2(&L->v[i]) >= 0)
				continue;
			o = hole_owner(L, i);
			for (size_t q = first[k]; o != SIZE_MAX && q < np; q++)
				if (p[q].outer == o)
					p[q].area_mm2 += path_area_mm2(&L->v[i]);
		}
	}
	first[f->n] = np;
	for (int k = 0; k + 1 < f->n; k++)
		for (size_t a = first[k]; a < first[k + 1]; a++)
			for (size_t b = first[k + 1]; b < first[k + 2]; b++) {
				int yes;
				if (p[a].lo.x > p[b].hi.x || p[b].lo.x > p[a].hi.x ||
				    p[a].lo.y > p[b].hi.y || p[b].lo.y > p[a].hi.y)
					continue;
				if (uf_find(p, a) == uf_find(p, b))
					continue;
				rc = outers_overlap(&f->layer[k].v[p[a].outer],
						    &f->layer[k + 1].v[p[b].outer], &yes, e);
				if (rc)
					goto out;
				if (yes)
					p[uf_find(p, a)].comp = uf_find(p, b);
			}
	vol = mem_calloc(np + 1, sizeof *vol);
	drop = mem_calloc(np + 1, 1);
	if (!vol || !drop)
		goto nomem;
	for (size_t i = 0; i < np; i++)
		vol[uf_find(p, i)] += p[i].area_mm2 * f->layer_mm;
	f->voids = f->voids_small = 0;
	f->volume_mm3 = 0;
	for (size_t i = 0; i < np; i++) {
		if (uf_find(p, i) != i)
			continue;
		if (vol[i] < min_mm3) {
			drop[i] = 1;
			f->voids_small++;
		} else {
			f->voids++;
			f->volume_mm3 += vol[i];
		}
	}
	/* remove dropped components: their outers and the holes they own */
	for (int k = 0; k < f->n; k++) {
		struct paths *L = &f->layer[k];
		unsigned char *gone;
		size_t w = 0;
		int any = 0;
		for (size_t q = first[k]; q < first[k + 1]; q++)
			any |= drop[uf_find(p, q)];
		if (!any)
			continue;
		gone = mem_calloc(L->n + 1, 1);
		if (!gone)
			goto nomem;
		for (size_t q = first[k]; q < first[k + 1]; q++)
			if (drop[uf_find(p, q)])
				gone[p[q].outer] = 1;
		for (size_t i = 0; i < L->n; i++)
			if (path_area_mm2(&L->v[i]) < 0) {
				size_t o = hole_owner(L, i);
				gone[i] = o == SIZE_MAX || gone[o];
			}
		for (size_t i = 0; i < L->n; i++) {
			if (gone[i]) {
				path_fini(&L->v[i]);
				continue;
			}
			L->v[w++] = L->v[i];
		}
		L->n = w;
		mem_free(gone);
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory grouping the fill");
out:
	mem_free(p);
	mem_free(first);
	mem_free(vol);
	mem_free(drop);
	return rc;
}

/* ---- keeping voids apart ---- */

/* Split region ps into its components (an outer loop and the holes it
 * owns), appended to *out (n, caller frees each with paths_fini and the
 * array with mem_free), with their bounding boxes. */
struct comp {
	struct paths p;
	struct pt2 lo, hi;
};

static int split_components(const struct paths *ps, struct comp **out, size_t *n, struct err *e)
{
	struct comp *c = NULL;
	size_t nc = 0, *idx = NULL;
	int rc = 0;

	idx = mem_alloc((ps->n + 1) * sizeof *idx);
	c = mem_calloc(ps->n + 1, sizeof *c);
	if (!idx || !c)
		goto nomem;
	for (size_t i = 0; i < ps->n; i++) {
		idx[i] = SIZE_MAX;
		if (path_area_mm2(&ps->v[i]) <= 0)
			continue;
		idx[i] = nc;
		paths_init(&c[nc].p);
		bbox_of(&ps->v[i], &c[nc].lo, &c[nc].hi);
		if (paths_add_pts(&c[nc].p, ps->v[i].pts, ps->v[i].n))
			goto nomem;
		nc++;
	}
	for (size_t i = 0; i < ps->n; i++) {
		size_t o;
		if (path_area_mm2(&ps->v[i]) > 0)
			continue;
		o = hole_owner(ps, i);
		if (o != SIZE_MAX && idx[o] != SIZE_MAX &&
		    paths_add_pts(&c[idx[o]].p, ps->v[i].pts, ps->v[i].n))
			goto nomem;
	}
	*out = c;
	*n = nc;
	c = NULL;
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
out:
	for (size_t i = 0; c && i < nc; i++)
		paths_fini(&c[i].p);
	mem_free(c);
	mem_free(idx);
	return rc;
}

/*
 * Vf (layer_below's void for layer k) cut so that voids stay apart: the
 * part of Vf within d of component P_i of V(k + 1) belongs to P_i unless
 * it comes within wall + d of another component (then it stays solid), and
 * new voids (seeds) only start at >= wall + d from every component of
 * V(k + 1).  So components that meet at layer k + 1 apart by >= wall stay
 * >= wall apart (a point of P_i's growth is >= wall + d from P_j, P_j's
 * growth within d of P_j); without this the greedy void grows into a foam
 * of cells split by walls thinner than a pixel (docs/hollow.md).
 * The result is a subset of Vf: turning void into solid never breaks the
 * overhang rule for the layer above, and the layer below is built from
 * the result.  Bounding boxes skip far components.
 */
static int keep_apart(const struct paths *Vf, const struct paths *Vup, double d_nm,
		      double wall_nm, struct paths *V, struct err *e)
{
	struct comp *c = NULL;
	size_t nc = 0;
	struct paths acc, X, G, others;
	double reach = wall_nm + 2 * d_nm;
	int rc;

	paths_init(&acc);
	paths_init(&X);
	paths_init(&G);
	paths_init(&others);
	rc = split_components(Vup, &c, &nc, e);
	/* seeds: Vf beyond wall + d of everything above */
	if (!rc)
		rc = clip_offset(Vup, wall_nm + d_nm, CLIP_JOIN_ROUND, 0, 0, &X, e);
	if (!rc)
		rc = clip_boolean(CLIP_DIFFERENCE, Vf, &X, CLIP_FILL_NONZERO, &acc, e);
	for (size_t i = 0; !rc && i < nc; i++) {
		paths_clear(&others);
		for (size_t j = 0; j < nc && !rc; j++) {
			if (j == i || c[j].lo.x > c[i].hi.x + reach || c[i].lo.x > c[j].hi.x + reach ||
			    c[j].lo.y > c[i].hi.y + reach || c[i].lo.y > c[j].hi.y + reach)
				continue;
			for (size_t q = 0; q < c[j].p.n && !rc; q++)
				if (paths_add_pts(&others, c[j].p.v[q].pts, c[j].p.v[q].n))
					rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		}
		if (!rc)
			rc = clip_offset(&c[i].p, d_nm, CLIP_JOIN_ROUND, 0, 0, &G, e);
		if (!rc)
			rc = clip_boolean(CLIP_INTERSECTION, &G, Vf, CLIP_FILL_NONZERO, &G, e);
		if (!rc && others.n) {
			rc = clip_offset(&others, wall_nm + d_nm, CLIP_JOIN_ROUND, 0, 0, &X, e);
			if (!rc)
				rc = clip_boolean(CLIP_DIFFERENCE, &G, &X, CLIP_FILL_NONZERO, &G, e);
		}
		if (!rc && paths_append_move(&acc, &G))
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	}
	if (!rc)
		rc = clip_union(&acc, CLIP_FILL_NONZERO, V, e);
	for (size_t i = 0; c && i < nc; i++)
		paths_fini(&c[i].p);
	mem_free(c);
	paths_fini(&acc);
	paths_fini(&X);
	paths_fini(&G);
	paths_fini(&others);
	return rc;
}

int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_config *c,
		  int stack_count, struct progress *prog, double f0, double f1, struct hl_fill *f,
		  struct err *e)
{
	struct hl_fill r;
	struct paths *C = NULL;
	double alpha = c->alpha_rad - c->margin_rad;
	double px2 = c->pixel_mm * c->pixel_mm;
	/* Raster safety (docs/hollow.md "Top-down fill"): the layers are
	 * pixel-centre samples of these regions, the checker allows
	 * layer tan(alpha) + 1 pixel between a solid pixel and the solid under
	 * it.  The void written is V eroded by w = HL_FILL_W_PX pixels and the
	 * construction uses d = layer tan(alpha) - HL_FILL_D_PX pixels: a solid
	 * pixel centre p lies within w of the design's solid, that within d of
	 * the solid of the layer below, and the pixel centre nearest to that
	 * point (<= 0.71 px away, solid because it is within w of it) is
	 * within w + d + 0.71 = layer tan(alpha) + 0.987 px of p: inside the
	 * checker's one pixel of tolerance.  Layers too thick for that (d <= 0)
	 * get no fill. */
	double d_nm = (double)geom_mm_to_nm(c->stack_layer_mm * tan(alpha) -
					    HL_FILL_D_PX * c->pixel_mm);
	double w_nm = (double)geom_mm_to_nm(HL_FILL_W_PX * c->pixel_mm);
	double wall_nm = (double)geom_mm_to_nm(c->wall_next_mm);
	double px_nm = (double)geom_mm_to_nm(c->pixel_mm);
	int rc = 0;

	memset(&r, 0, sizeof r);
	if (stack_count < 1)
		return ERR_SET(e, ERR_PARAM, "hollow: fill needs layers");
	if (!(d_nm > 0))
		return 0; /* layers too thick for this alpha and pixel: no safe fill */
	r.n = stack_count;
	r.layer_mm = c->stack_layer_mm;
	r.layer = mem_calloc((size_t)stack_count, sizeof *r.layer);
	C = mem_calloc((size_t)stack_count, sizeof *C);
	if (!r.layer || !C) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	for (int k = 0; k < stack_count; k++) {
		paths_init(&r.layer[k]);
		paths_init(&C[k]);
	}
	rc = offset_stack(part, solid, c, stack_count, C, e);
	for (int k = stack_count - 1; !rc && k >= 0; k--) {
		static const struct paths none;
		const struct paths *up = k + 1 < stack_count ? &r.layer[k + 1] : &none;
		if (!C[k].n)
			continue;
		if (prog && k % 16 == 0) {
			rc = progress_update(prog, f0 + (f1 - f0) * (stack_count - k) / stack_count, e);
			if (rc)
				break;
		}
		rc = layer_below(&C[k], up, d_nm, 0.02 * px_nm, 0.25 * px2,
				 (double)geom_mm_to_nm(0.01 * c->pixel_mm), &r.layer[k], e);
		if (!rc && up->n && r.layer[k].n)
			rc = keep_apart(&r.layer[k], up, d_nm, wall_nm, &r.layer[k], e);
		paths_fini(&C[k]);
	}
	/* the written void: V eroded by w (V itself drove the layers below) */
	for (int k = 0; !rc && k < stack_count; k++)
		if (r.layer[k].n) {
			rc = clip_offset(&r.layer[k], -w_nm, CLIP_JOIN_ROUND, 0, 0.05 * w_nm,
					 &r.layer[k], e);
			if (!rc) {
				drop_small(&r.layer[k], 0.25 * px2);
				rc = clip_union(&r.layer[k], CLIP_FILL_POSITIVE, &r.layer[k], e);
			}
		}
	if (!rc)
		rc = components(&r, c->min_void_mm3, e);
	if (!rc) {
		hl_fill_fini(f);
		*f = r;
		memset(&r, 0, sizeof r);
	}
out:
	for (int k = 0; C && k < stack_count; k++)
		paths_fini(&C[k]);
	mem_free(C);
	hl_fill_fini(&r);
	return rc;
}
