/* capsule.c - capsule sections along pixel rows, and their union raster
 * (capsule.h).
 *
 * Row quadratics.  With W = o - a, the row point P(u) = o + u s satisfies
 *   ball at a:    |W + u s|^2 < r^2
 *                 s2 u^2 + 2 (W.s) u + (|W|^2 - r^2) < 0
 *   ball at b:    the same with W_b = W - l t: |W_b|^2 = |W|^2 - 2 l h0 + l^2,
 *                 W_b.s = W.s - l hs   (h0 = W.t, hs = s.t, |t| = 1)
 *   cylinder:     rho^2 = |W + u s|^2 - h(u)^2 < r^2 with h(u) = h0 + u hs
 *                 (s2 - hs^2) u^2 + 2 (W.s - h0 hs) u + (|W|^2 - h0^2 - r^2) < 0
 *                 and 0 <= h(u) <= l  (u between -h0/hs and (l - h0)/hs)
 * The capsule is convex, so the union of the three intervals is one
 * interval.  Roots are taken in the cancellation-free form
 * q = -(B + sign(B) sqrt(B^2 - 4AC)) / 2, roots q/A and C/q.  A row
 * parallel to the axis (s2 - hs^2 ~ 0) makes the cylinder's quadratic
 * constant: all of the row or none of it, cut by the caps' planes.
 *
 * These are the operations the lattice slicer has always performed (same
 * order, same thresholds), so its images are unchanged by the move here.
 */
#include "engine/geom/capsule.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/geom/raster.h"

#include <math.h>
#include <string.h>

/* Rows per parallel band of capsule_union_raster. */
#define UNION_BAND_ROWS 16
/* Slabs of a capsule_zindex at most (the slab height grows to fit). */
#define ZINDEX_MAX_SLABS (1u << 20)

/* min / max of numbers that are never NaN here: plain comparisons the
 * compiler inlines (libm's fmin / fmax are calls at -O2); on such inputs
 * they give the same values. */
static inline double dmin(double a, double b)
{
	return b < a ? b : a;
}
static inline double dmax(double a, double b)
{
	return b > a ? b : a;
}

/* Solve A u^2 + B u + C < 0 (A >= 0): interval (lo, hi); 0 if empty.
 * scale2 (the |s|^2 of the row) sets what counts as A = 0. */
static inline int quad_below(double A, double B, double C, double scale2, double *lo, double *hi)
{
	if (A <= 1e-14 * scale2) {
		/* constant along the row (the row runs parallel to the axis) */
		if (C < 0) {
			*lo = -INFINITY;
			*hi = INFINITY;
			return 1;
		}
		return 0;
	}
	{
		double disc = B * B - 4 * A * C, sq, q;
		if (!(disc > 0))
			return 0;
		sq = sqrt(disc);
		/* numerically stable roots */
		q = -0.5 * (B + (B >= 0 ? sq : -sq));
		*lo = q / A;
		*hi = q != 0 ? C / q : -*lo;
		if (*lo > *hi) {
			double t = *lo;
			*lo = *hi;
			*hi = t;
		}
		return 1;
	}
}

void capsule_rows_init(struct capsule_rows *cr, struct vec3 a, struct vec3 t, double l_mm,
		       double r_mm, struct vec3 s)
{
	cr->a = a;
	cr->t = l_mm > 0 ? t : v3(0, 0, 1);
	cr->l_mm = l_mm > 0 ? l_mm : 0;
	cr->r_mm = r_mm;
	cr->r2_mm2 = r_mm * r_mm;
	cr->s = s;
	cr->s2 = v3_dot(s, s);
	cr->hs = v3_dot(s, cr->t);
	cr->acyl = cr->s2 - cr->hs * cr->hs;
}

int capsule_rows_interval(const struct capsule_rows *cr, struct vec3 o, double *lo_out,
			  double *hi_out)
{
	struct vec3 W = v3_sub(o, cr->a);
	double S2 = cr->s2, hs = cr->hs, l = cr->l_mm, R2 = cr->r2_mm2;
	double WS = v3_dot(W, cr->s), W2 = v3_dot(W, W), h0 = v3_dot(W, cr->t);
	double lo = INFINITY, hi = -INFINITY, a0, a1;

	if (!(S2 > 0)) {
		/* no step: the row is the point o */
		double hc = dmin(dmax(h0, 0), l);
		if (W2 - 2 * hc * h0 + hc * hc < R2) {
			*lo_out = -INFINITY;
			*hi_out = INFINITY;
			return 1;
		}
		return 0;
	}
	/* end balls */
	if (quad_below(S2, 2 * WS, W2 - R2, S2, &a0, &a1)) {
		lo = dmin(lo, a0);
		hi = dmax(hi, a1);
	}
	if (l > 0) {
		double Wb2 = W2 - 2 * l * h0 + l * l, WbS = WS - l * hs;
		if (quad_below(S2, 2 * WbS, Wb2 - R2, S2, &a0, &a1)) {
			lo = dmin(lo, a0);
			hi = dmax(hi, a1);
		}
		/* cylinder part: rho^2 < R^2 and 0 <= h <= l */
		if (quad_below(cr->acyl, 2 * (WS - h0 * hs), W2 - h0 * h0 - R2, S2, &a0, &a1)) {
			double b0 = -INFINITY, b1 = INFINITY;
			if (fabs(hs) > 1e-12) {
				b0 = -h0 / hs;
				b1 = (l - h0) / hs;
				if (b0 > b1) {
					double tt = b0;
					b0 = b1;
					b1 = tt;
				}
			} else if (!(h0 >= 0 && h0 <= l)) {
				b0 = INFINITY; /* empty */
			}
			b0 = dmax(b0, a0);
			b1 = dmin(b1, a1);
			if (b0 < b1) {
				lo = dmin(lo, b0);
				hi = dmax(hi, b1);
			}
		}
	}
	if (!(lo < hi))
		return 0;
	*lo_out = lo;
	*hi_out = hi;
	return 1;
}

int capsule_rows_run(const struct capsule_rows *cr, struct vec3 o, int umin, int umax, int *i0,
		     int *i1)
{
	double lo, hi;

	if (!capsule_rows_interval(cr, o, &lo, &hi))
		return 0;
	/* centres i + 0.5 in [lo, hi] */
	lo = ceil(lo - 0.5);
	hi = floor(hi - 0.5);
	if (lo < umin)
		lo = umin;
	if (hi > umax)
		hi = umax;
	if (!(lo <= hi))
		return 0;
	*i0 = (int)lo;
	*i1 = (int)hi;
	return 1;
}

int capsule_rows_rect(const struct capsule_rows *cr, double z_mm, const struct raster_map *m,
		      int w, int h, int *u0, int *u1, int *v0, int *v1)
{
	double t0 = 0, t1 = 1, dz = cr->t.z * cr->l_mm, z = z_mm, R = cr->r_mm;
	double x0, y0, x1, y1, xmin, xmax, ymin, ymax;
	double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;

	if (dz > 0) {
		t0 = fmax(0, fmin(1, (z - R - cr->a.z) / dz));
		t1 = fmax(0, fmin(1, (z + R - cr->a.z) / dz));
	} else if (dz < 0) { /* a above b: the slab's ends swap */
		t0 = fmax(0, fmin(1, (z + R - cr->a.z) / dz));
		t1 = fmax(0, fmin(1, (z - R - cr->a.z) / dz));
	}
	x0 = cr->a.x + t0 * cr->t.x * cr->l_mm;
	y0 = cr->a.y + t0 * cr->t.y * cr->l_mm;
	x1 = cr->a.x + t1 * cr->t.x * cr->l_mm;
	y1 = cr->a.y + t1 * cr->t.y * cr->l_mm;
	xmin = fmin(x0, x1) - R;
	xmax = fmax(x0, x1) + R;
	ymin = fmin(y0, y1) - R;
	ymax = fmax(y0, y1) + R;
	for (int c = 0; c < 4; c++) {
		double u, v;
		raster_map_apply(m, (c & 1) ? xmax : xmin, (c & 2) ? ymax : ymin, &u, &v);
		umin = fmin(umin, u);
		umax = fmax(umax, u);
		vmin = fmin(vmin, v);
		vmax = fmax(vmax, v);
	}
	/* pixel i's centre i + 0.5 inside [umin, umax] */
	umin = fmax(ceil(umin - 0.5), 0);
	umax = fmin(floor(umax - 0.5), w - 1);
	vmin = fmax(ceil(vmin - 0.5), 0);
	vmax = fmin(floor(vmax - 0.5), h - 1);
	if (!(umin <= umax && vmin <= vmax))
		return 0;
	*u0 = (int)umin;
	*u1 = (int)umax;
	*v0 = (int)vmin;
	*v1 = (int)vmax;
	return 1;
}

/* Axis form of a capsule: a, unit t, length l (0 for a ball). */
static void capsule_axis(const struct capsule *c, struct vec3 *t, double *l)
{
	struct vec3 d = v3_sub(c->b, c->a);

	*l = v3_len(d);
	*t = *l > 0 ? v3(d.x / *l, d.y / *l, d.z / *l) : v3(0, 0, 1);
}

int capsule_row_interval(const struct capsule *c, struct vec3 o, struct vec3 s, double *lo,
			 double *hi)
{
	struct capsule_rows cr;
	struct vec3 t;
	double l;

	if (!(c->r_mm > 0))
		return 0;
	capsule_axis(c, &t, &l);
	capsule_rows_init(&cr, c->a, t, l, c->r_mm, s);
	return capsule_rows_interval(&cr, o, lo, hi);
}

/* ---- union raster ---- */

/* z extent of the capsule's solid; 0 when the capsule is unusable. */
static int capsule_zrange(const struct capsule *c, double *zlo, double *zhi)
{
	if (!(c->r_mm > 0) || !isfinite(c->r_mm) || !isfinite(c->a.x) || !isfinite(c->a.y) ||
	    !isfinite(c->a.z) || !isfinite(c->b.x) || !isfinite(c->b.y) || !isfinite(c->b.z))
		return 0;
	*zlo = fmin(c->a.z, c->b.z) - c->r_mm;
	*zhi = fmax(c->a.z, c->b.z) + c->r_mm;
	return 1;
}

struct section {
	struct capsule_rows cr;
	int u0, u1, v0, v1; /* inclusive pixel rectangle */
};

struct union_job {
	const struct section *sec;
	const uint32_t *bin_start, *bin; /* CSR: sections touching each band */
	int w, h;
	uint8_t *img;
	double z, ix0, iy0, ivx, ivy; /* printer point of pixel coords (0, v) */
};

static void union_band(void *ctx, size_t band, int tid)
{
	const struct union_job *j = ctx;
	int r0 = (int)band * UNION_BAND_ROWS, r1 = r0 + UNION_BAND_ROWS;

	(void)tid;
	if (r1 > j->h)
		r1 = j->h;
	for (uint32_t k = j->bin_start[band]; k < j->bin_start[band + 1]; k++) {
		const struct section *sc = &j->sec[j->bin[k]];
		int v0 = sc->v0 > r0 ? sc->v0 : r0, v1 = sc->v1 < r1 - 1 ? sc->v1 : r1 - 1;

		for (int v = v0; v <= v1; v++) {
			struct vec3 o = v3(j->ix0 + j->ivx * (v + 0.5), j->iy0 + j->ivy * (v + 0.5),
					   j->z);
			int i0, i1;
			if (capsule_rows_run(&sc->cr, o, sc->u0, sc->u1, &i0, &i1))
				memset(j->img + (size_t)v * j->w + i0, 1, (size_t)(i1 - i0 + 1));
		}
	}
}

/* Render the capsules caps[cand[k]] (k < ncand; cand NULL: caps[0..ncand))
 * that meet plane z.  Two passes over the candidates (count, fill), then
 * one over the band bins in parallel. */
static int render_union(const struct capsule *caps, const uint32_t *cand, size_t ncand,
			double z_mm, const struct raster_map *map, int w, int h, uint8_t *img,
			int threads, struct err *e)
{
	struct section *sec = NULL;
	uint32_t *bin_start = NULL, *bin_fill = NULL, *bin = NULL;
	size_t nsec = 0, nhit = 0, total = 0, nb;
	double det, iux, iuy;
	struct union_job j;
	int rc = 0;

	if (w < 1 || h < 1)
		return ERR_SET(e, ERR_PARAM, "empty image %dx%d", w, h);
	det = map->a[0][0] * map->a[1][1] - map->a[0][1] * map->a[1][0];
	if (!(fabs(det) > 0) || !isfinite(det))
		return ERR_SET(e, ERR_PARAM, "singular pixel map");
	if (!isfinite(z_mm))
		return ERR_SET(e, ERR_PARAM, "plane z is not finite");
	/* inverse map: (x, y) = A^-1 ((u, v) - b) */
	iux = map->a[1][1] / det;
	iuy = -map->a[1][0] / det;
	j.ivx = -map->a[0][1] / det;
	j.ivy = map->a[0][0] / det;
	j.ix0 = -(iux * map->b[0] + j.ivx * map->b[1]);
	j.iy0 = -(iuy * map->b[0] + j.ivy * map->b[1]);
	j.z = z_mm;
	j.w = w;
	j.h = h;
	j.img = img;

	for (size_t k = 0; k < ncand; k++) {
		double zlo, zhi;
		if (capsule_zrange(&caps[cand ? cand[k] : k], &zlo, &zhi) && zlo < z_mm &&
		    z_mm < zhi)
			nhit++;
	}
	if (nhit == 0)
		return 0;
	if (nhit > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "%zu capsules meet one plane", nhit);
	nb = ((size_t)h + UNION_BAND_ROWS - 1) / UNION_BAND_ROWS;
	sec = mem_alloc(nhit * sizeof *sec);
	bin_start = mem_calloc(nb + 1, sizeof *bin_start);
	bin_fill = mem_alloc(nb * sizeof *bin_fill);
	if (!sec || !bin_start || !bin_fill) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu capsule sections", nhit);
		goto out;
	}
	for (size_t k = 0; k < ncand; k++) {
		const struct capsule *c = &caps[cand ? cand[k] : k];
		struct section *sc = &sec[nsec];
		struct vec3 t;
		double l, zlo, zhi;

		if (!capsule_zrange(c, &zlo, &zhi) || !(zlo < z_mm && z_mm < zhi))
			continue;
		capsule_axis(c, &t, &l);
		capsule_rows_init(&sc->cr, c->a, t, l, c->r_mm, v3(iux, iuy, 0));
		if (!capsule_rows_rect(&sc->cr, z_mm, map, w, h, &sc->u0, &sc->u1, &sc->v0,
				       &sc->v1))
			continue;
		for (size_t b = (size_t)sc->v0 / UNION_BAND_ROWS;
		     b <= (size_t)sc->v1 / UNION_BAND_ROWS; b++)
			bin_start[b + 1]++;
		total += (size_t)(sc->v1 / UNION_BAND_ROWS - sc->v0 / UNION_BAND_ROWS + 1);
		nsec++;
	}
	if (total > UINT32_MAX) {
		rc = ERR_SET(e, ERR_LIMIT, "too many capsule/band pairs in one plane");
		goto out;
	}
	for (size_t b = 0; b < nb; b++)
		bin_start[b + 1] += bin_start[b];
	bin = mem_alloc((total ? total : 1) * sizeof *bin);
	if (!bin) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu capsule/band pairs", total);
		goto out;
	}
	memcpy(bin_fill, bin_start, nb * sizeof *bin_fill);
	for (size_t k = 0; k < nsec; k++)
		for (size_t b = (size_t)sec[k].v0 / UNION_BAND_ROWS;
		     b <= (size_t)sec[k].v1 / UNION_BAND_ROWS; b++)
			bin[bin_fill[b]++] = (uint32_t)k;
	j.sec = sec;
	j.bin_start = bin_start;
	j.bin = bin;
	parfor_run(nb, threads, 1, union_band, &j);
out:
	mem_free(sec);
	mem_free(bin_start);
	mem_free(bin_fill);
	mem_free(bin);
	return rc;
}

int capsule_union_raster(const struct capsule *caps, size_t n, double z_mm,
			 const struct raster_map *map, int w, int h, uint8_t *img, int threads,
			 struct err *e)
{
	return render_union(caps, NULL, n, z_mm, map, w, h, img, threads, e);
}

/* ---- z index ---- */

struct capsule_zindex {
	const struct capsule *caps; /* borrowed */
	double z0_mm, slab_mm;      /* slab k covers [z0 + k slab, z0 + (k + 1) slab) */
	size_t nslab;
	uint32_t *start; /* nslab + 1 offsets into item */
	uint32_t *item;  /* capsule indices, ascending within a slab */
};

void capsule_zindex_free(struct capsule_zindex *ix)
{
	if (!ix)
		return;
	mem_free(ix->start);
	mem_free(ix->item);
	mem_free(ix);
}

/* Slabs k0..k1 that the extent [zlo, zhi] overlaps. */
static void zindex_slabs(const struct capsule_zindex *ix, double zlo, double zhi, size_t *k0,
			 size_t *k1)
{
	double f0 = floor((zlo - ix->z0_mm) / ix->slab_mm);
	double f1 = floor((zhi - ix->z0_mm) / ix->slab_mm);
	double top = (double)(ix->nslab - 1);

	*k0 = (size_t)fmin(fmax(f0, 0), top);
	*k1 = (size_t)fmin(fmax(f1, 0), top);
}

int capsule_zindex_new(const struct capsule *caps, size_t n, double slab_mm,
		       struct capsule_zindex **out, struct err *e)
{
	struct capsule_zindex *ix;
	double zmin = INFINITY, zmax = -INFINITY, ext_sum = 0, zlo, zhi;
	size_t used = 0, total = 0;
	uint32_t *fill = NULL;
	int rc = 0;

	if (n > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "%zu capsules (at most %u)", n, UINT32_MAX);
	ix = mem_calloc(1, sizeof *ix);
	if (!ix)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	ix->caps = caps;
	for (size_t i = 0; i < n; i++)
		if (capsule_zrange(&caps[i], &zlo, &zhi)) {
			zmin = fmin(zmin, zlo);
			zmax = fmax(zmax, zhi);
			ext_sum += zhi - zlo;
			used++;
		}
	if (used == 0) {
		ix->nslab = 1;
		ix->z0_mm = 0;
		ix->slab_mm = 1;
	} else {
		double span = zmax - zmin;
		if (!(slab_mm > 0) || !isfinite(slab_mm))
			slab_mm = ext_sum / (double)used;
		if (!(slab_mm > 0))
			slab_mm = 1;
		if (span / slab_mm > ZINDEX_MAX_SLABS - 1)
			slab_mm = span / (ZINDEX_MAX_SLABS - 1);
		ix->z0_mm = zmin;
		ix->slab_mm = slab_mm;
		ix->nslab = (size_t)floor(span / slab_mm) + 1;
	}
	ix->start = mem_calloc(ix->nslab + 1, sizeof *ix->start);
	fill = mem_alloc(ix->nslab * sizeof *fill);
	if (!ix->start || !fill) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu z slabs", ix->nslab);
		goto out;
	}
	for (size_t i = 0; i < n; i++) {
		size_t k0, k1;
		if (!capsule_zrange(&caps[i], &zlo, &zhi))
			continue;
		zindex_slabs(ix, zlo, zhi, &k0, &k1);
		for (size_t k = k0; k <= k1; k++)
			ix->start[k + 1]++;
		total += k1 - k0 + 1;
	}
	if (total > INT32_MAX) {
		rc = ERR_SET(e, ERR_LIMIT, "%zu capsule/slab entries (at most 2^31)", total);
		goto out;
	}
	for (size_t k = 0; k < ix->nslab; k++)
		ix->start[k + 1] += ix->start[k];
	ix->item = mem_alloc((total ? total : 1) * sizeof *ix->item);
	if (!ix->item) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu capsule/slab entries", total);
		goto out;
	}
	memcpy(fill, ix->start, ix->nslab * sizeof *fill);
	for (size_t i = 0; i < n; i++) {
		size_t k0, k1;
		if (!capsule_zrange(&caps[i], &zlo, &zhi))
			continue;
		zindex_slabs(ix, zlo, zhi, &k0, &k1);
		for (size_t k = k0; k <= k1; k++)
			ix->item[fill[k]++] = (uint32_t)i;
	}
	*out = ix;
	ix = NULL;
out:
	mem_free(fill);
	capsule_zindex_free(ix);
	return rc;
}

int capsule_zindex_raster(const struct capsule_zindex *ix, double z_mm,
			  const struct raster_map *map, int w, int h, uint8_t *img, int threads,
			  struct err *e)
{
	size_t k;
	double f;

	if (!isfinite(z_mm))
		return ERR_SET(e, ERR_PARAM, "plane z is not finite");
	f = floor((z_mm - ix->z0_mm) / ix->slab_mm);
	if (f < 0 || f >= (double)ix->nslab) {
		/* no capsule reaches the plane; still check the map and size */
		return render_union(ix->caps, ix->item, 0, z_mm, map, w, h, img, threads, e);
	}
	k = (size_t)f;
	return render_union(ix->caps, ix->item + ix->start[k], ix->start[k + 1] - ix->start[k],
			    z_mm, map, w, h, img, threads, e);
}
