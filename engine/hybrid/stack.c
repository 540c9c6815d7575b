/* stack.c - the hybrid engine's designed layer stack (hybrid.h): the
 * part and its interior on the design grid, the structures of sections
 * 5-6 composed into every layer, and the support rule that keeps every
 * layer resting on the one below (docs/hybrid.md "Printability").
 *
 * Passes.  (1) hy_stack_init: the mesh sliced and eroded in 3D by the
 * shell (slice/erode.h), bottom-up, stored as bit planes.  (2)
 * hy_stack_columns: the extended support columns of every interface
 * (section 6.2).  (3) hy_stack_compose: every layer's voids from the
 * partition and the structures, with the transient layers (section 6.1);
 * then top-down, layer k from the top, the support rule: a void pixel q
 * of layer k becomes material when q lies deeper than r(q) inside the
 * material of layer k + 1 (roofs grow cones down at alpha), and when a
 * material pixel of layer k + 1 still has no material of layer k within
 * r(q), q itself is filled.  r(q) = h tan(alpha) on the MFS side and
 * h tan(alpha_tcs) on the crystal's, whose sticks lean 54.74 deg.
 * Distances are exact Euclidean between pixel centres (geom/edt.h).
 */
#include "engine/hybrid/stack.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/progress.h"
#include "engine/fea/fea.h"
#include "engine/geom/edt.h"
#include "engine/geom/label.h"
#include "engine/geom/poisson.h"
#include "engine/mesh/isosurface.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/erode.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static inline int bit_get(const uint64_t *p, size_t i)
{
	return (int)((p[i >> 6] >> (i & 63)) & 1u);
}

static inline void bit_set(uint64_t *p, size_t i, int v)
{
	if (v)
		p[i >> 6] |= (uint64_t)1 << (i & 63);
	else
		p[i >> 6] &= ~((uint64_t)1 << (i & 63));
}

static const uint64_t *plane(const uint64_t *base, const struct hy_stack *st, int k)
{
	return base + (size_t)k * st->words;
}

static uint64_t *plane_w(uint64_t *base, const struct hy_stack *st, int k)
{
	return base + (size_t)k * st->words;
}

/* Progress of the prepare stage (NULL = none): hy_stack_init spans
 * [0.15, 0.3] of it, hy_stack_compose [0.3, 0.85] (hybrid_engine.c owns
 * the rest). */
static int tick(struct progress *pg, double lo, double hi, double f, struct err *e)
{
	return pg ? progress_update(pg, lo + (hi - lo) * f, e) : 0;
}

/* Centre of design pixel (i, j) in the printer frame. */
static void pixel_xy(const struct hy_stack *st, int i, int j, double *x, double *y)
{
	raster_map_invert(&st->map, i + 0.5, j + 0.5, x, y);
}

/* ---- pass 1: part and interior ---- */

int hy_stack_init(struct hy_stack *st, const struct mesh *m, struct box3 box, double pitch_mm,
		  double layer_mm, int layers, double shell_mm, struct progress *pg,
		  struct err *e)
{
	struct slice_erode_info info;
	struct slice_eroder *er = NULL;
	struct slice_mid_source sc = {NULL, layer_mm};
	struct slicer *own = NULL;
	struct raster *img = NULL;
	struct paths region;
	size_t bytes;
	int rc;

	memset(st, 0, sizeof *st);
	paths_init(&region);
	if ((rc = slice_erode_mesh_new(m, shell_mm, pitch_mm, layer_mm, layers, &box, &sc, &er,
				       e)) != 0) {
		if (rc == ERR_LIMIT)
			snprintf(e->field, sizeof e->field, "grid_mm");
		goto out;
	}
	slice_erode_info(er, &info);
	st->w = info.w;
	st->h = info.h;
	st->map = info.map;
	st->layers = layers;
	st->pitch_mm = pitch_mm;
	st->layer_mm = layer_mm;
	st->words = ((size_t)st->w * st->h + 63) / 64;
	bytes = st->words * sizeof(uint64_t) * (size_t)layers;
	if (bytes / 8 * 4 > ((size_t)3 << 30)) {
		rc = ERR_FIELD(e, "grid_mm",
			       "the design grid of %d x %d pixels x %d layers needs %.1f GB of bit "
			       "planes (at most 3): choose a larger grid_mm",
			       st->w, st->h, layers, 4.0 * bytes / 1e9);
		goto out;
	}
	st->part = mem_calloc(1, bytes);
	st->interior = mem_calloc(1, bytes);
	st->voids = mem_calloc(1, bytes);
	st->tcsr = mem_calloc(1, bytes);
	if (!st->part || !st->interior || !st->voids || !st->tcsr) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu MB of layer bit planes",
			     4 * bytes >> 20);
		goto out;
	}
	/* the part: pixel centres inside the exact slice (its own slicer: the
	 * eroder's runs ahead); the interior: the eroder's clearance >= 0 */
	if ((rc = slice_new(m, &own, e)) != 0)
		goto out;
	if (!(img = raster_new(st->w, st->h))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a %d x %d layer", st->w, st->h);
		goto out;
	}
	for (int k = 0; k < layers; k++) {
		const float *f;
		uint64_t *pp = plane_w(st->part, st, k), *pi = plane_w(st->interior, st, k);
		if ((rc = slice_erode_field(er, k, &f, e)) != 0 ||
		    (rc = slice_at(own, (k + 0.5) * layer_mm, &region, NULL, e)) != 0)
			goto out;
		raster_clear(img);
		if ((rc = slice_rasterize(&region, &st->map, 0, img, e)) != 0)
			goto out;
		for (int j = 0; j < st->h; j++)
			for (int i = 0; i < st->w; i++) {
				size_t b = (size_t)j * st->w + i;
				int in = img->px[(size_t)j * img->stride + i] != 0;
				if (in)
					bit_set(pp, b, 1);
				if (in && f[b] >= 0)
					bit_set(pi, b, 1);
			}
		if ((k & 31) == 0 && (rc = tick(pg, 0.15, 0.3, (k + 1.0) / layers, e)) != 0)
			goto out;
	}
out:
	paths_fini(&region);
	raster_free(img);
	slice_free(own);
	slice_erode_free(er);
	slice_free(sc.slicer);
	if (rc)
		hy_stack_fini(st);
	return rc;
}

void hy_stack_fini(struct hy_stack *st)
{
	mem_free(st->part);
	mem_free(st->interior);
	mem_free(st->voids);
	mem_free(st->tcsr);
	memset(st, 0, sizeof *st);
}

int hy_stack_material(const struct hy_stack *st, int k, int i, int j)
{
	size_t b = (size_t)j * st->w + i;

	if (k < 0 || k >= st->layers || i < 0 || j < 0 || i >= st->w || j >= st->h)
		return 0;
	return bit_get(plane(st->part, st, k), b) && !bit_get(plane(st->voids, st, k), b);
}

int hy_stack_void(const struct hy_stack *st, int k, int i, int j)
{
	if (k < 0 || k >= st->layers || i < 0 || j < 0 || i >= st->w || j >= st->h)
		return 0;
	return bit_get(plane(st->voids, st, k), (size_t)j * st->w + i);
}

/* ---- per-layer structure images ---- */

/* Transient pixel of VCol part c: labelled c or its neighbour, within
 * transient_mm / 2 of c's base plane and within radius_mm (+ the
 * transient half thickness) of its axis. */
static int transient_of(const struct hy_design *d, int label, struct vec3 p)
{
	const struct hy_parts *ps = d->parts;

	for (size_t c = 0; c < ps->n; c++) {
		const struct hy_part *q = &ps->p[c];
		struct vec3 r;
		double t, rad2, lim;
		if (q->cls != HY_VCOL || q->neighbour < 0 ||
		    (label != (int)c && label != q->neighbour))
			continue;
		r = v3_sub(p, q->base_mm);
		t = v3_dot(r, q->axis);
		if (fabs(t) > d->transient_mm / 2)
			continue;
		rad2 = v3_dot(r, r) - t * t;
		lim = q->radius_mm + d->transient_mm / 2;
		if (rad2 <= lim * lim)
			return (int)c;
	}
	return -1;
}

struct compose_ctx {
	const struct hy_stack *st;
	const struct hy_design *d;
	double z_mm;
	const uint8_t *interior; /* w x h bytes */
	const uint8_t *tcs;      /* w x h bytes, NULL when no TCS */
	uint8_t *mat;            /* out: material */
	uint8_t *istcs;          /* out: crystal side */
	uint8_t *trans;          /* out: transient part + 1, 0 */
	uint8_t *mfs_img;        /* out: MFS of the transient part at its pixels */
};

static void compose_row(void *ctx, size_t jj, int tid)
{
	struct compose_ctx *c = ctx;
	const struct hy_stack *st = c->st;
	const struct hy_design *d = c->d;
	int j = (int)jj, w = st->w;

	(void)tid;
	for (int i = 0; i < w; i++) {
		size_t b = (size_t)j * w + i;
		struct vec3 p;
		int lab = -1, tr;
		c->mat[b] = 0;
		c->istcs[b] = 0;
		c->trans[b] = 0;
		c->mfs_img[b] = 0;
		if (!c->interior[b])
			continue;
		pixel_xy(st, i, j, &p.x, &p.y);
		p.z = c->z_mm;
		if (d->structure == HY_STRUCT_TCS) {
			c->mat[b] = c->tcs[b];
			c->istcs[b] = 1;
			continue;
		}
		if (d->structure == HY_STRUCT_MFS) {
			c->mat[b] = (uint8_t)hy_mfs_solid(d->mfs[0], p);
			continue;
		}
		lab = hy_label_at(d->labels, p);
		if (lab >= 0 && d->parts->p[lab].cls == HY_VCOL && d->mfs[lab]) {
			c->mat[b] = (uint8_t)hy_mfs_solid(d->mfs[lab], p);
		} else {
			c->mat[b] = c->tcs[b];
			c->istcs[b] = 1;
		}
		tr = transient_of(d, lab, p);
		if (tr >= 0) {
			c->trans[b] = (uint8_t)(tr + 1);
			c->mfs_img[b] = d->mfs[tr] ? (uint8_t)hy_mfs_solid(d->mfs[tr], p) : 0;
			c->istcs[b] = 0;
		}
	}
}

struct images {
	uint8_t *interior, *tcs, *mat, *istcs, *trans, *mfs_img, *mask, *us, *tmp;
	float *d1, *d2;
	size_t n;
};

static void images_fini(struct images *im)
{
	mem_free(im->interior);
	mem_free(im->tcs);
	mem_free(im->mat);
	mem_free(im->istcs);
	mem_free(im->trans);
	mem_free(im->mfs_img);
	mem_free(im->mask);
	mem_free(im->us);
	mem_free(im->tmp);
	mem_free(im->d1);
	mem_free(im->d2);
	memset(im, 0, sizeof *im);
}

static int images_init(struct images *im, size_t n, struct err *e)
{
	memset(im, 0, sizeof *im);
	im->n = n;
	im->interior = mem_alloc(n);
	im->tcs = mem_calloc(1, n);
	im->mat = mem_alloc(n);
	im->istcs = mem_alloc(n);
	im->trans = mem_alloc(n);
	im->mfs_img = mem_alloc(n);
	im->mask = mem_alloc(n);
	im->us = mem_alloc(n);
	im->tmp = mem_alloc(n);
	im->d1 = mem_alloc(n * sizeof(float));
	im->d2 = mem_alloc(n * sizeof(float));
	if (!im->interior || !im->tcs || !im->mat || !im->istcs || !im->trans || !im->mfs_img ||
	    !im->mask || !im->us || !im->tmp || !im->d1 || !im->d2) {
		images_fini(im);
		return ERR_SET(e, ERR_NOMEM, "out of memory for layer images of %zu pixels", n);
	}
	return 0;
}

static void unpack(const uint64_t *bits, size_t n, uint8_t *out)
{
	for (size_t i = 0; i < n; i++)
		out[i] = (uint8_t)bit_get(bits, i);
}

/* The structures of layer k into im (mat, istcs, trans, mfs_img), with
 * the transient layers joined (section 6.1). */
static int compose_layer(const struct hy_stack *st, const struct hy_design *d,
			 const struct capsule_zindex *ix, int k, struct images *im,
			 size_t *transient_px, struct err *e)
{
	struct compose_ctx c;
	int w = st->w, h = st->h, rc = 0;
	size_t n = im->n;
	double z = (k + 0.5) * st->layer_mm;

	unpack(plane(st->interior, st, k), n, im->interior);
	if (d->structure != HY_STRUCT_MFS) {
		memset(im->tcs, 0, n);
		if (ix)
			rc = capsule_zindex_raster(ix, z, &st->map, w, h, im->tcs, d->threads, e);
		else if (d->ncaps)
			rc = capsule_union_raster(d->caps, d->ncaps, z, &st->map, w, h, im->tcs,
						  d->threads, e);
		if (rc)
			return rc;
	}
	c.st = st;
	c.d = d;
	c.z_mm = z;
	c.interior = im->interior;
	c.tcs = im->tcs;
	c.mat = im->mat;
	c.istcs = im->istcs;
	c.trans = im->trans;
	c.mfs_img = im->mfs_img;
	parfor_run((size_t)h, d->threads, 8, compose_row, &c);
	if (d->structure != HY_STRUCT_HYBRID)
		return 0;
	/* transient layers: per VCol part present in this layer */
	for (size_t p = 0; p < d->parts->n; p++) {
		size_t cnt = 0;
		if (d->parts->p[p].cls != HY_VCOL)
			continue;
		for (size_t i = 0; i < n; i++) {
			im->mask[i] = im->trans[i] == p + 1;
			cnt += im->mask[i];
		}
		if (!cnt)
			continue;
		*transient_px += cnt;
		if ((rc = hy_transient_layer(im->mfs_img, im->tcs, im->mask, w, h,
					     d->bridge_mm / st->pitch_mm, im->us, e)) != 0)
			return rc;
		for (size_t i = 0; i < n; i++)
			if (im->mask[i])
				im->mat[i] = im->us[i];
	}
	return 0;
}

/* ---- section 6.2: extended support columns ---- */

struct support_img {
	const struct hy_stack *st;
	const uint8_t *img;
};

static int support_inside(void *ctx, double x, double y)
{
	const struct support_img *s = ctx;
	double u, v;
	int i, j;

	raster_map_apply(&s->st->map, x, y, &u, &v);
	i = (int)floor(u);
	j = (int)floor(v);
	if (i < 0 || j < 0 || i >= s->st->w || j >= s->st->h)
		return 0;
	return s->img[(size_t)j * s->st->w + i] != 0;
}

/* Capsule c clipped to the slab between z0 and z1 and laid flat at z0:
 * its shadow on the plane.  0 when it misses the slab. */
static int flatten(const struct capsule *c, double z0, double z1, struct capsule *out)
{
	double lo = fmin(z0, z1) - c->r_mm, hi = fmax(z0, z1) + c->r_mm;
	struct vec3 a = c->a, b = c->b, dv;
	double ta = 0, tb = 1;

	if (fmax(a.z, b.z) < lo || fmin(a.z, b.z) > hi)
		return 0;
	dv = v3_sub(b, a);
	if (fabs(dv.z) > 1e-12) {
		double t0 = (lo - a.z) / dv.z, t1 = (hi - a.z) / dv.z;
		if (t0 > t1) {
			double t = t0;
			t0 = t1;
			t1 = t;
		}
		ta = fmax(ta, t0);
		tb = fmin(tb, t1);
		if (ta > tb)
			return 0;
	}
	out->a = v3_add(a, v3_scale(dv, ta));
	out->b = v3_add(a, v3_scale(dv, tb));
	out->a.z = out->b.z = z0;
	out->r_mm = c->r_mm;
	return 1;
}

int hy_stack_columns(const struct hy_stack *st, struct hy_design *d, size_t *ncolumns,
		     struct err *e)
{
	struct images im;
	struct capsule *flat = NULL;
	size_t n = (size_t)st->w * st->h, tpx = 0, nflat = 0;
	int rc = 0;

	*ncolumns = 0;
	if (d->structure != HY_STRUCT_HYBRID || !(d->column_mm > 0))
		return 0;
	if ((rc = images_init(&im, n, e)) != 0)
		return rc;
	if (d->ncaps && !(flat = mem_alloc(d->ncaps * sizeof *flat))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu capsules", d->ncaps);
		goto out;
	}
	for (size_t p = 0; p < d->parts->n && rc == 0; p++) {
		const struct hy_part *q = &d->parts->p[p];
		double zb = q->base_mm.z, dir = q->axis.z < 0 ? 1 : -1, z1;
		int kb = (int)floor(zb / st->layer_mm);
		struct support_img si = {st, im.tmp};
		double *xy = NULL;
		size_t npts = 0, px = 0;
		if (q->cls != HY_VCOL || q->neighbour < 0 || fabs(q->axis.z) < 0.5 || kb < 0 ||
		    kb >= st->layers)
			continue;
		/* the transient layer at the base plane */
		if ((rc = compose_layer(st, d, NULL, kb, &im, &tpx, e)) != 0)
			break;
		for (size_t i = 0; i < n; i++)
			im.us[i] = im.trans[i] == p + 1 ? im.mat[i] : 0;
		/* the crystal's shadow on it from one cell on the NCol side */
		z1 = (kb + 0.5) * st->layer_mm + dir * d->tcs_cell_mm;
		nflat = 0;
		for (size_t c = 0; c < d->ncaps; c++)
			nflat += flatten(&d->caps[c], (kb + 0.5) * st->layer_mm, z1, &flat[nflat]);
		memset(im.mask, 0, n);
		if (nflat && (rc = capsule_union_raster(flat, nflat, (kb + 0.5) * st->layer_mm,
							&st->map, st->w, st->h, im.mask, d->threads,
							e)) != 0)
			break;
		px = (size_t)ceil(M_PI * d->column_mm * d->column_mm / 4 /
				  (st->pitch_mm * st->pitch_mm));
		if ((rc = hy_support_region(im.mask, im.us, st->w, st->h, px, im.tmp, e)) != 0)
			break;
		{
			double x0, y0, x1, y1;
			pixel_xy(st, 0, 0, &x0, &y0);
			pixel_xy(st, st->w - 1, st->h - 1, &x1, &y1);
			rc = poisson2_sample(fmin(x0, x1), fmin(y0, y1), fmax(x0, x1), fmax(y0, y1),
					     d->column_spacing_mm, support_inside, &si,
					     d->seed + p, 1u << 20, &xy, &npts, e);
		}
		if (rc)
			break;
		if (d->ncaps + npts > d->caps_cap) {
			size_t cap = d->ncaps + npts;
			struct capsule *nc = realloc(d->caps, cap * sizeof *nc);
			if (!nc) {
				free(xy);
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu columns", npts);
				break;
			}
			d->caps = nc;
			d->caps_cap = cap;
		}
		for (size_t i = 0; i < npts; i++) {
			struct capsule *c = &d->caps[d->ncaps++];
			c->a = v3(xy[2 * i], xy[2 * i + 1], (kb + 0.5) * st->layer_mm);
			c->b = v3(xy[2 * i], xy[2 * i + 1], z1);
			if (c->b.z < c->a.z) {
				struct vec3 t = c->a;
				c->a = c->b;
				c->b = t;
			}
			c->r_mm = d->column_mm / 2;
		}
		*ncolumns += npts;
		free(xy);
	}
out:
	mem_free(flat);
	images_fini(&im);
	return rc;
}

/* ---- compose and the support rule ---- */

struct edt_job {
	const uint8_t *seed;
	const struct hy_stack *st;
	float *out;
	struct edt_scratch *scratch;
	int rc;
};

static void edt_one(void *ctx, size_t i, int tid)
{
	struct edt_job *j = (struct edt_job *)ctx + i;
	struct err e;

	(void)tid;
	j->rc = edt_sq(j->seed, (size_t)j->st->w, j->st->w, j->st->h, j->st->pitch_mm,
		       j->st->pitch_mm, j->out, j->scratch, &e);
}

/* Pixel i is a ridge of the clearance field d (squared mm): inside (> 0)
 * and at least as far from the outside as each of its 8 neighbours. */
static int ridge(const float *d, int w, int h, size_t i)
{
	int x = (int)(i % w), y = (int)(i / w);

	if (!(d[i] > 0))
		return 0;
	for (int dy = -1; dy <= 1; dy++)
		for (int dx = -1; dx <= 1; dx++) {
			int xx = x + dx, yy = y + dy;
			if ((dx || dy) && xx >= 0 && yy >= 0 && xx < w && yy < h &&
			    d[(size_t)yy * w + xx] > d[i])
				return 0;
		}
	return 1;
}

int hy_stack_compose(struct hy_stack *st, const struct hy_design *d, struct progress *pg,
		     struct hy_stack_report *rep, struct err *e)
{
	struct images im;
	struct edt_scratch es;
	size_t n = (size_t)st->w * st->h;
	double t0 = progress_now_s(), px_area = st->pitch_mm * st->pitch_mm;
	double ra2 = d->r_alpha_mm * d->r_alpha_mm, rt2 = d->r_tcs_mm * d->r_tcs_mm;
	uint8_t *above = NULL, *vabove = NULL;
	int32_t *lab = NULL;
	struct edt_scratch es2;
	struct capsule_zindex *ix = NULL;
	size_t over_px = 0;
	int rc;

	memset(rep, 0, sizeof *rep);
	edt_scratch_init(&es);
	edt_scratch_init(&es2);
	if (d->ncaps && (rc = capsule_zindex_new(d->caps, d->ncaps, 0, &ix, e)) != 0)
		return rc;
	if ((rc = images_init(&im, n, e)) != 0) {
		capsule_zindex_free(ix);
		return rc;
	}
	if (!(above = mem_alloc(n)) || !(vabove = mem_alloc(n)) ||
	    !(lab = mem_alloc(n * sizeof *lab))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a layer image");
		goto out;
	}
	for (int k = 0; k < st->layers; k++) {
		uint64_t *pv = plane_w(st->voids, st, k), *pt = plane_w(st->tcsr, st, k);
		if ((rc = compose_layer(st, d, ix, k, &im, &rep->transient_px, e)) != 0)
			goto out;
		memset(pv, 0, st->words * sizeof *pv);
		memset(pt, 0, st->words * sizeof *pt);
		for (size_t i = 0; i < n; i++) {
			if (im.interior[i] && !im.mat[i])
				bit_set(pv, i, 1);
			if (im.istcs[i])
				bit_set(pt, i, 1);
		}
		if ((k & 15) == 0 && (rc = tick(pg, 0.3, 0.85, 0.5 * (k + 1) / st->layers, e)) != 0)
			goto out;
	}
	rep->seconds_compose = progress_now_s() - t0;
	t0 = progress_now_s();
	/* top-down support rule; above = material of layer k + 1, vabove its voids */
	memset(vabove, 0, n);
	for (int k = st->layers - 1; k >= 0 && !d->raw; k--) {
		uint64_t *pv = plane_w(st->voids, st, k);
		const uint64_t *pp = plane(st->part, st, k), *pt = plane(st->tcsr, st, k);
		uint8_t *cur = im.mat, *cand = im.mask;
		for (size_t i = 0; i < n; i++) {
			cand[i] = (uint8_t)bit_get(pv, i);
			cur[i] = (uint8_t)(bit_get(pp, i) && !cand[i]);
		}
		if (k + 1 < st->layers) {
			struct edt_job jobs[2] = {
				{NULL, st, im.d1, &es, 0},   /* d1: clearance inside the candidates */
				{vabove, st, im.d2, &es2, 0}, /* d2: distance to the voids above */
			};
			/* the candidates' complement is exactly cur | outside: seeds !cand */
			for (size_t i = 0; i < n; i++)
				im.tmp[i] = !cand[i];
			jobs[0].seed = im.tmp;
			parfor_run(2, d->threads, 1, edt_one, jobs);
			if (jobs[0].rc || jobs[1].rc) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for distance transforms");
				goto out;
			}
			/* a candidate stays void within r of a void above (the cavity
			 * grows down by r per layer) or on its own ridge (a local
			 * maximum of the clearance: where a cavity may start under a
			 * roof, one pixel wide) */
			for (size_t i = 0; i < n; i++) {
				double r2 = bit_get(pt, i) ? rt2 : ra2;
				if (!cand[i] || im.d2[i] <= r2 || ridge(im.d1, st->w, st->h, i))
					continue;
				cand[i] = 0;
				cur[i] = 1;
				bit_set(pv, i, 0);
				rep->filled_px++;
			}
			/* every material pixel of k + 1 within r of material of k, else
			 * filled below itself */
			if ((rc = edt_sq(cur, (size_t)st->w, st->w, st->h, st->pitch_mm, st->pitch_mm,
					 im.d2, &es, e)) != 0)
				goto out;
			for (size_t i = 0; i < n; i++) {
				double r2 = bit_get(pt, i) ? rt2 : ra2;
				if (!above[i] || !bit_get(pp, i))
					continue;
				if (im.d2[i] > r2 && cand[i]) {
					cand[i] = 0;
					cur[i] = 1;
					bit_set(pv, i, 0);
					rep->filled_px++;
				} else if (im.d2[i] > ra2 && bit_get(plane(st->interior, st, k), i)) {
					over_px++;
				}
			}
		}
		/* every 8-connected region of k + 1 rests on material of k; one that
		 * does not (a fragment cut loose by the voids) is copied below */
		if (k + 1 < st->layers) {
			int32_t count = 0;
			if ((rc = label_components8(above, st->w, st->h, lab, &count, e)) != 0)
				goto out;
			if (count > 0) {
				uint8_t *rests = mem_calloc((size_t)count + 1, 1);
				if (!rests) {
					rc = ERR_SET(e, ERR_NOMEM, "out of memory for %d regions", count);
					goto out;
				}
				for (size_t i = 0; i < n; i++)
					if (lab[i] && cur[i])
						rests[lab[i]] = 1;
				for (size_t i = 0; i < n; i++)
					if (lab[i] && !rests[lab[i]] && cand[i]) {
						cand[i] = 0;
						cur[i] = 1;
						bit_set(pv, i, 0);
						rep->filled_px++;
					}
				mem_free(rests);
			}
		}
		memcpy(vabove, cand, n);
		for (size_t i = 0; i < n; i++) {
			if (bit_get(pp, i)) {
				rep->part_mm3 += px_area * st->layer_mm;
				rep->material_mm3 += cur[i] ? px_area * st->layer_mm : 0;
			}
		}
		memcpy(above, cur, n);
		if ((k & 15) == 0 &&
		    (rc = tick(pg, 0.3, 0.85, 0.5 + 0.5 * (st->layers - k) / st->layers, e)) != 0)
			goto out;
	}
	rep->overhang_mm2 = (double)over_px * px_area;
	rep->seconds_support = progress_now_s() - t0;
out:
	capsule_zindex_free(ix);
	mem_free(above);
	mem_free(vabove);
	mem_free(lab);
	edt_scratch_fini(&es);
	edt_scratch_fini(&es2);
	images_fini(&im);
	return rc;
}

/* ---- FEA densities and the mesh ---- */

int hy_stack_fea_grid(const struct hy_stack *st, struct box3 box, double h_mm, int solid_part,
		      size_t max_elements, struct fea_grid *g, struct err *e)
{
	struct vec3 sz = box3_size(box);
	size_t ne;
	uint32_t *cnt = NULL;
	uint32_t per;
	int *exs = NULL, *eys = NULL;

	memset(g, 0, sizeof *g);
	if (!(h_mm > 0))
		return ERR_FIELD(e, "fea_voxel_mm", "fea_voxel_mm must be > 0, not %g", h_mm);
	if (st->map.a[0][1] != 0 || st->map.a[1][0] != 0)
		return ERR_SET(e, ERR_INTERNAL, "hybrid: the design grid is not axis-aligned");
	g->h_mm = h_mm;
	g->nx = (int)ceil(sz.x / h_mm) + 2;
	g->ny = (int)ceil(sz.y / h_mm) + 2;
	g->nz = (int)ceil(sz.z / h_mm) + 2;
	ne = (size_t)g->nx * g->ny * g->nz;
	if (ne > max_elements)
		return ERR_FIELD(e, "fea_voxel_mm",
				 "fea_voxel_mm = %g mm gives %zu elements (at most %zu)", h_mm, ne,
				 max_elements);
	g->lo_mm = v3(box.lo.x - h_mm, box.lo.y - h_mm, box.lo.z - h_mm);
	g->part_lo_mm = box.lo;
	g->part_hi_mm = box.hi;
	g->rho = mem_calloc(ne, sizeof *g->rho);
	cnt = mem_calloc(ne, sizeof *cnt);
	if (!g->rho || !cnt) {
		mem_free(cnt);
		fea_grid_fini(g);
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu elements", ne);
	}
	/* samples per element: design pixels x layers whose centres fall in it
	 * (the design grid is axis-aligned: x by column, y by row) */
	if (!(exs = mem_alloc((size_t)st->w * sizeof *exs)) ||
	    !(eys = mem_alloc((size_t)st->h * sizeof *eys))) {
		mem_free(exs);
		mem_free(cnt);
		fea_grid_fini(g);
		return ERR_SET(e, ERR_NOMEM, "out of memory for element indices");
	}
	for (int i = 0; i < st->w; i++) {
		double x, y;
		pixel_xy(st, i, 0, &x, &y);
		exs[i] = (int)floor((x - g->lo_mm.x) / h_mm);
	}
	for (int j = 0; j < st->h; j++) {
		double x, y;
		pixel_xy(st, 0, j, &x, &y);
		eys[j] = (int)floor((y - g->lo_mm.y) / h_mm);
	}
	/* an element takes the layers whose middle lies in its z range, or the
	 * layer through its own middle when it is thinner than a layer */
	for (int ez = 0; ez < g->nz; ez++) {
		double z0 = g->lo_mm.z + ez * h_mm, z1 = z0 + h_mm;
		int k0 = (int)ceil(z0 / st->layer_mm - 0.5), k1 = (int)ceil(z1 / st->layer_mm - 0.5);
		if (k1 <= k0) {
			k0 = (int)floor((z0 + z1) / 2 / st->layer_mm);
			k1 = k0 + 1;
		}
		k0 = k0 < 0 ? 0 : k0;
		k1 = k1 > st->layers ? st->layers : k1;
		for (int k = k0; k < k1; k++) {
			const uint64_t *pp = plane(st->part, st, k), *pv = plane(st->voids, st, k);
			for (int j = 0; j < st->h; j++) {
				int ey = eys[j];
				if (ey < 0 || ey >= g->ny)
					continue;
				for (int i = 0; i < st->w; i++) {
					int ex = exs[i];
					size_t b = (size_t)j * st->w + i, id;
					if (ex < 0 || ex >= g->nx)
						continue;
					id = ((size_t)ez * g->ny + ey) * g->nx + ex;
					cnt[id]++;
					if (bit_get(pp, b) && (solid_part || !bit_get(pv, b)))
						g->rho[id] += 1;
				}
			}
		}
	}
	mem_free(exs);
	mem_free(eys);
	/* border elements see fewer samples: normalise by the full count of
	 * their slab (slabs may hold different numbers of layers) */
	for (int ez = 0; ez < g->nz; ez++) {
		size_t s0 = (size_t)ez * g->nx * g->ny, s1 = s0 + (size_t)g->nx * g->ny;
		per = 0;
		for (size_t i = s0; i < s1; i++)
			per = cnt[i] > per ? cnt[i] : per;
		for (size_t i = s0; i < s1; i++) {
			float r = per ? g->rho[i] / (float)per : 0;
			g->rho[i] = r > 1 ? 1 : r;
		}
	}
	mem_free(cnt);
	return 0;
}

/* The mesh's iso level (hy_stack_mesh): at most this many extractions,
 * levels within [LO, HI], volume within REL of the material's. */
#define HY_ISO_PASSES 6
#define HY_ISO_LO 0.25
#define HY_ISO_HI 0.75
#define HY_ISO_REL 0.002

int hy_stack_mesh(const struct hy_stack *st, int bx, int bz, size_t max_triangles,
		  struct mesh **out, struct hy_mesh_fit *fit, struct err *e)
{
	int nx, ny, nz;
	float *f;
	size_t nf;
	struct vec3 lo, step;
	double x0, y0, x1, y1;
	int rc;

	if (bx < 1 || bz < 1)
		return ERR_SET(e, ERR_PARAM, "mesh blocks must be >= 1");
	nx = (st->w + bx - 1) / bx;
	ny = (st->h + bx - 1) / bx;
	nz = (st->layers + bz - 1) / bz;
	nf = (size_t)nx * ny * nz;
	if (!(f = mem_calloc(nf, sizeof *f)))
		return ERR_SET(e, ERR_NOMEM, "out of memory for a %dx%dx%d mesh field", nx, ny, nz);
	for (int k = 0; k < st->layers; k++) {
		const uint64_t *pp = plane(st->part, st, k), *pv = plane(st->voids, st, k);
		float *fl = f + (size_t)(k / bz) * nx * ny;
		for (int j = 0; j < st->h; j++)
			for (int i = 0; i < st->w; i++) {
				size_t b = (size_t)j * st->w + i;
				if (bit_get(pp, b) && !bit_get(pv, b))
					fl[(size_t)(j / bx) * nx + i / bx] += 1;
			}
	}
	for (size_t i = 0; i < nf; i++)
		f[i] /= (float)(bx * bx * bz);
	/* sample (i, j, k) sits at the centre of its block */
	pixel_xy(st, 0, 0, &x0, &y0);
	pixel_xy(st, bx, bx, &x1, &y1);
	step = v3(x1 - x0, y1 - y0, bz * st->layer_mm);
	lo = v3(x0 + (x1 - x0) * (bx - 1) / (2.0 * bx), y0 + (y1 - y0) * (bx - 1) / (2.0 * bx),
		bz * st->layer_mm / 2);
	if (step.x < 0 || step.y < 0) {
		mem_free(f);
		return ERR_SET(e, ERR_INTERNAL, "hybrid: mirrored design grid");
	}
	/* the iso level that keeps the material's volume: block averages round
	 * the cells' void corners (solid gains there) and the part's convex
	 * edges (it loses), and marching at 1/2 keeps neither sum; the volume
	 * falls as the level rises, so a secant on the level (clamped to
	 * [HY_ISO_LO, HY_ISO_HI]) aims at it, stopping within HY_ISO_REL */
	{
		double want = 0, vol[2], iso[2] = {0.5, 0.55}, used = 0.5, used_vol = 0;
		struct vec3 mom;
		struct mesh *m = NULL;

		for (size_t i = 0; i < nf; i++)
			want += f[i];
		want *= step.x * step.y * step.z;
		for (int pass = 0; pass < HY_ISO_PASSES; pass++) {
			double t = pass < 2 ? iso[pass] : iso[1];
			struct mesh *cand = NULL;
			if (pass >= 2) {
				/* secant through the last two */
				double d = vol[1] - vol[0];
				t = fabs(d) > 1e-12 ? iso[1] + (want - vol[1]) * (iso[1] - iso[0]) / d
						    : iso[1];
				t = t < HY_ISO_LO ? HY_ISO_LO : t > HY_ISO_HI ? HY_ISO_HI : t;
				if (t == iso[1])
					break; /* clamped again: the same level */
				iso[0] = iso[1];
				vol[0] = vol[1];
				iso[1] = t;
			}
			rc = mesh_isosurface(f, nx, ny, nz, lo, step, (float)t, max_triangles, &cand, e);
			if (rc) {
				/* a level past the triangle cap: keep the last mesh made */
				if (rc == ERR_LIMIT && m) {
					rc = 0;
					err_clear(e);
				}
				break;
			}
			mesh_free(m);
			m = cand;
			used = t;
			mesh_mass(m, &used_vol, &mom);
			vol[pass < 2 ? pass : 1] = used_vol;
			if (fabs(used_vol - want) <= HY_ISO_REL * want)
				break;
		}
		/* the last mesh made is kept (the secant aims at the volume; after
		 * HY_ISO_PASSES it may still miss HY_ISO_REL: mesh.volume_mm3 says) */
		if (!rc) {
			*out = m;
			if (fit) {
				fit->iso = used;
				fit->volume_mm3 = used_vol;
			}
		} else {
			mesh_free(m);
		}
	}
	mem_free(f);
	return rc;
}
