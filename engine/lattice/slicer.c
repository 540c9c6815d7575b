/* slicer.c - streaming plane sweep and direct pixel rendering (slicer.h).
 *
 * Per plane: (1) activate struts from the sorted source whose lower end
 * is within R below the plane, drop those whose upper end is R or more
 * below it (paper 000 section 4, steps 1-6); (2) per active strut, the
 * pixel rectangle of its capsule's cross-section (clip the segment to the
 * slab |z' - z| < R, inflate by R); (3) bin struts to bands of rows; (4)
 * threads take bands: for each strut and row, the exact run of pixel
 * centres inside the capsule (union of the cylinder and the two end
 * spheres, convex, so one interval: engine/geom/capsule.c, shared with the
 * hybrid engine) is accumulated by rowkern.c; then
 * the band is thresholded (binary) or converted to coverage (antialias:
 * signed distance (F - C) / |grad F| from central differences, one halo
 * row above and below the band).
 */
#include "engine/lattice/slicer.h"
#include "engine/lattice/kernel.h"
#include "engine/lattice/rowkern.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/capsule.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>

#define BAND_ROWS 16

struct act {
	float a[3]; /* lower end, mm */
	float t[3]; /* unit direction a -> b */
	float l;    /* length, mm */
	float k;    /* LATTICE_FIX_ONE * w / (C R^4) */
	float zhi;  /* upper end z */
	float pad;
};

struct rect {
	int u0, u1, v0, v1; /* inclusive pixel ranges; u0 > u1 = empty */
};

struct worker {
	struct lattice_slicer *s;
	uint32_t *acc;
	size_t acc_cap; /* elements */
	uint64_t pairs;
	pthread_t th;
	int started;
};

struct lattice_slicer {
	struct lattice_source src;
	struct lattice_slicer_opts o;
	double R, R2;
	rowkern_fn kern;

	struct act *act;
	size_t nact, act_cap;
	struct lattice_strut pending;
	int has_pending, eof;
	double last_z;

	struct rect *rect;
	size_t rect_cap;
	uint32_t *bin_start, *bin_fill, *bin;
	size_t bin_start_cap, bin_cap;

	/* per-render state */
	struct raster *r;
	float *field;
	int w, h, halo, nbands;
	double z;
	double ix0, iy0, iux, iuy, ivx, ivy; /* x = ix0 + iux u + ivx v (same for y) */
	atomic_int next_band;

	struct worker *wk;
	int nwk;
	struct lattice_slicer_stats st;
};

int lattice_slicer_new(struct lattice_source src, const struct lattice_slicer_opts *o,
		       struct lattice_slicer **out, struct err *e)
{
	struct lattice_slicer *s;

	if (!(o->support_mm > 0) || !isfinite(o->support_mm))
		return ERR_SET(e, ERR_PARAM, "support R must be > 0 (got %g mm)", o->support_mm);
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->src = src;
	s->o = *o;
	if (s->o.threads < 1)
		s->o.threads = 1;
	if (s->o.threads > 256)
		s->o.threads = 256;
	s->R = o->support_mm;
	s->R2 = s->R * s->R;
	s->kern = lattice_rowkern_pick();
	s->last_z = -INFINITY;
	s->nwk = s->o.threads;
	s->wk = mem_calloc((size_t)s->nwk, sizeof *s->wk);
	if (!s->wk) {
		mem_free(s);
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	}
	for (int i = 0; i < s->nwk; i++)
		s->wk[i].s = s;
	*out = s;
	return 0;
}

void lattice_slicer_free(struct lattice_slicer *s)
{
	if (!s)
		return;
	for (int i = 0; i < s->nwk; i++)
		mem_free(s->wk[i].acc);
	mem_free(s->wk);
	mem_free(s->act);
	mem_free(s->rect);
	mem_free(s->bin_start);
	mem_free(s->bin_fill);
	mem_free(s->bin);
	mem_free(s);
}

void lattice_slicer_get_stats(const struct lattice_slicer *s, struct lattice_slicer_stats *st)
{
	*st = s->st;
	st->bytes = s->act_cap * sizeof(struct act) + s->rect_cap * sizeof(struct rect) +
		    s->bin_cap * sizeof(uint32_t) + 2 * s->bin_start_cap * sizeof(uint32_t);
	for (int i = 0; i < s->nwk; i++)
		st->bytes += s->wk[i].acc_cap * sizeof(uint32_t);
}

/* ---- active list ---- */

static int activate(struct lattice_slicer *s, const struct lattice_strut *p, struct err *e)
{
	double d[3], l;
	struct act *a;

	if (!((double)p->radius_mm < s->R))
		return ERR_SET(e, ERR_PARAM,
			       "strut %llu has radius %g mm, not below the kernel support %g mm",
			       (unsigned long long)s->st.struts_read - 1, (double)p->radius_mm, s->R);
	if ((double)p->b[2] + s->R <= s->z)
		return 0; /* entirely below the plane already */
	for (int i = 0; i < 3; i++)
		d[i] = (double)p->b[i] - (double)p->a[i];
	l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
	if (!(l > 0))
		return 0; /* a point has no length to integrate: contributes nothing */
	if (mem_grow((void **)&s->act, &s->act_cap, s->nact + 1, sizeof *s->act))
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu active struts", s->nact + 1);
	a = &s->act[s->nact++];
	for (int i = 0; i < 3; i++) {
		a->a[i] = p->a[i];
		a->t[i] = (float)(d[i] / l);
	}
	a->l = (float)l;
	/* w / (C R^4) = 15 / (16 (R^2 - r^2)^(5/2)): kernel.h's weight map */
	a->k = (float)(LATTICE_FIX_ONE * lattice_weight_for_radius(p->radius_mm, 1.0, s->R) /
		       (s->R2 * s->R2));
	a->zhi = p->b[2];
	a->pad = 0;
	return 0;
}

static int advance(struct lattice_slicer *s, double z, struct err *e)
{
	size_t k = 0;
	int rc;

	s->z = z;
	for (;;) {
		if (!s->has_pending) {
			if (s->eof)
				break;
			rc = s->src.next(s->src.ctx, &s->pending, e);
			if (rc < 0)
				return rc;
			if (rc == 0) {
				s->eof = 1;
				break;
			}
			if (!isfinite(s->pending.a[0]) || !isfinite(s->pending.a[1]) ||
			    !isfinite(s->pending.a[2]) || !isfinite(s->pending.b[0]) ||
			    !isfinite(s->pending.b[1]) || !isfinite(s->pending.b[2]) ||
			    s->pending.b[2] < s->pending.a[2] || !(s->pending.radius_mm > 0))
				return ERR_SET(e, ERR_PARAM, "strut %llu is malformed",
					       (unsigned long long)s->st.struts_read);
			s->st.struts_read++;
			s->has_pending = 1;
		}
		if (!((double)s->pending.a[2] - s->R < z))
			break;
		if ((rc = activate(s, &s->pending, e)) != 0)
			return rc;
		s->has_pending = 0;
	}
	/* drop struts whose swept sphere is entirely below the plane */
	for (size_t i = 0; i < s->nact; i++)
		if ((double)s->act[i].zhi + s->R > z)
			s->act[k++] = s->act[i];
	s->nact = k;
	s->st.active = k;
	if (k > s->st.max_active)
		s->st.max_active = k;
	return 0;
}

/* ---- culling ---- */

/* The strut's capsule of radius R, prepared for rows of the current map. */
static void strut_rows(const struct lattice_slicer *s, const struct act *a,
		       struct capsule_rows *cr)
{
	capsule_rows_init(cr, v3(a->a[0], a->a[1], a->a[2]), v3(a->t[0], a->t[1], a->t[2]),
			  a->l, s->R, v3(s->iux, s->iuy, 0));
}

static void strut_rect(struct lattice_slicer *s, const struct raster_map *m,
		       const struct act *a, struct rect *r)
{
	struct capsule_rows cr;

	strut_rows(s, a, &cr);
	if (!capsule_rows_rect(&cr, s->z, m, s->w, s->h, &r->u0, &r->u1, &r->v0, &r->v1)) {
		r->u0 = 1;
		r->u1 = 0;
		r->v0 = 1;
		r->v1 = 0;
	}
}

/* ---- band rendering ---- */

static void render_band(struct worker *wk, int band)
{
	struct lattice_slicer *s = wk->s;
	int r0 = band * BAND_ROWS, r1 = r0 + BAND_ROWS, ar0, ar1, w = s->w;
	uint32_t *acc = wk->acc;
	const uint32_t one = (uint32_t)LATTICE_FIX_ONE;
	double sx = s->iux, sy = s->iuy;

	if (r1 > s->h)
		r1 = s->h;
	ar0 = r0 - s->halo < 0 ? 0 : r0 - s->halo;
	ar1 = r1 + s->halo > s->h ? s->h : r1 + s->halo;
	if (s->bin_start[band] == s->bin_start[band + 1]) {
		/* nothing reaches this band */
		for (int j = r0; j < r1; j++) {
			if (s->r)
				memset(s->r->px + (size_t)j * s->r->stride, 0, (size_t)w);
			if (s->field)
				memset(s->field + (size_t)j * w, 0, (size_t)w * sizeof(float));
		}
		return;
	}
	memset(acc, 0, (size_t)(ar1 - ar0) * w * sizeof *acc);
	for (uint32_t bi = s->bin_start[band]; bi < s->bin_start[band + 1]; bi++) {
		const struct act *a = &s->act[s->bin[bi]];
		const struct rect *rc = &s->rect[s->bin[bi]];
		int v0 = rc->v0 > ar0 ? rc->v0 : ar0, v1 = rc->v1 < ar1 - 1 ? rc->v1 : ar1 - 1;
		double t[3] = {a->t[0], a->t[1], a->t[2]};
		struct capsule_rows cr;
		double hs, Acyl;

		strut_rows(s, a, &cr);
		hs = cr.hs;
		Acyl = cr.acyl;
		for (int v = v0; v <= v1; v++) {
			/* row line: P(u) = O + u S (mm), z = plane */
			double ox = s->ix0 + s->ivx * (v + 0.5), oy = s->iy0 + s->ivy * (v + 0.5);
			int i0, i1;

			/* the exact run of pixel centres inside the capsule of radius R */
			if (!capsule_rows_run(&cr, v3(ox, oy, s->z), rc->u0, rc->u1, &i0, &i1))
				continue;
			{
				double W[3] = {ox - a->a[0], oy - a->a[1], s->z - a->a[2]};
				/* coefficients relative to the run's first pixel centre */
				double uref = i0 + 0.5;
				double Wr[3] = {W[0] + uref * sx, W[1] + uref * sy, W[2]};
				double hr = Wr[0] * t[0] + Wr[1] * t[1] + Wr[2] * t[2];
				double Wr2 = Wr[0] * Wr[0] + Wr[1] * Wr[1] + Wr[2] * Wr[2];
				double WrS = Wr[0] * sx + Wr[1] * sy;
				struct rowkern_args ka;

				ka.c0 = (float)(s->R2 - (Wr2 - hr * hr));
				ka.c1 = (float)(-2 * (WrS - hr * hs));
				ka.c2 = (float)(-Acyl);
				ka.h0 = (float)hr;
				ka.hs = (float)hs;
				ka.l = a->l;
				ka.k = a->k;
				s->kern(&ka, acc + (size_t)(v - ar0) * w + i0, i1 - i0 + 1);
				wk->pairs += (uint64_t)(i1 - i0 + 1);
			}
		}
	}
	/* output rows r0..r1-1 */
	for (int j = r0; j < r1; j++) {
		const uint32_t *row = acc + (size_t)(j - ar0) * w;
		const uint32_t *up = j > ar0 ? row - w : NULL;
		const uint32_t *dn = j + 1 < ar1 ? row + w : NULL;

		if (s->field) {
			float *f = s->field + (size_t)j * w;
			for (int i = 0; i < w; i++)
				f[i] = (float)row[i] / LATTICE_FIX_ONE;
		}
		if (!s->r)
			continue;
		{
			uint8_t *px = s->r->px + (size_t)j * s->r->stride;
			if (!s->o.antialias) {
				for (int i = 0; i < w; i++)
					px[i] = row[i] > one ? 255 : 0;
				continue;
			}
			for (int i = 0; i < w; i++) {
				double f, gx, gy, g, d;
				if (row[i] == 0) {
					px[i] = 0;
					continue;
				}
				f = (double)row[i] / LATTICE_FIX_ONE;
				gx = 0.5 * (((i + 1 < w) ? (double)row[i + 1] : 0) -
					    (i > 0 ? (double)row[i - 1] : 0)) / LATTICE_FIX_ONE;
				gy = 0.5 * ((dn ? (double)dn[i] : 0) - (up ? (double)up[i] : 0)) /
				     LATTICE_FIX_ONE;
				g = sqrt(gx * gx + gy * gy);
				if (g < 1e-9) {
					px[i] = f > 1 ? 255 : 0;
					continue;
				}
				d = 0.5 + (f - 1) / g; /* coverage of a straight edge */
				d = d < 0 ? 0 : d > 1 ? 1 : d;
				px[i] = (uint8_t)lrint(255 * d);
			}
		}
	}
}

static void *worker_main(void *arg)
{
	struct worker *wk = arg;
	struct lattice_slicer *s = wk->s;
	int b;

	while ((b = atomic_fetch_add(&s->next_band, 1)) < s->nbands)
		render_band(wk, b);
	return NULL;
}

/* Bands whose rows (plus the halo) a strut's rectangle touches. */
static void band_range(const struct lattice_slicer *s, const struct rect *r, int *b0, int *b1)
{
	*b0 = (r->v0 - s->halo) < 0 ? 0 : (r->v0 - s->halo) / BAND_ROWS;
	*b1 = (r->v1 + s->halo) / BAND_ROWS;
	if (*b1 >= s->nbands)
		*b1 = s->nbands - 1;
}

static int bin_struts(struct lattice_slicer *s, const struct raster_map *m, struct err *e)
{
	size_t total = 0;
	int nb = s->nbands;

	if (mem_grow((void **)&s->rect, &s->rect_cap, s->nact ? s->nact : 1, sizeof *s->rect) ||
	    mem_grow((void **)&s->bin_start, &s->bin_start_cap, (size_t)nb + 1, sizeof(uint32_t)))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	{
		size_t cap2 = s->bin_start_cap - 1;
		if (mem_grow((void **)&s->bin_fill, &cap2, s->bin_start_cap, sizeof(uint32_t)))
			return ERR_SET(e, ERR_NOMEM, "out of memory");
	}
	memset(s->bin_start, 0, ((size_t)nb + 1) * sizeof(uint32_t));
	for (size_t i = 0; i < s->nact; i++) {
		struct rect *r = &s->rect[i];
		strut_rect(s, m, &s->act[i], r);
		if (r->u0 > r->u1)
			continue;
		{
			int b0, b1;
			band_range(s, r, &b0, &b1);
			for (int b = b0; b <= b1; b++)
				s->bin_start[b + 1]++;
			total += (size_t)(b1 - b0 + 1);
		}
	}
	if (total > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "too many strut/band pairs in one plane");
	for (int b = 0; b < nb; b++)
		s->bin_start[b + 1] += s->bin_start[b];
	if (mem_grow((void **)&s->bin, &s->bin_cap, total ? total : 1, sizeof(uint32_t)))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	memcpy(s->bin_fill, s->bin_start, (size_t)nb * sizeof(uint32_t));
	for (size_t i = 0; i < s->nact; i++) {
		struct rect *r = &s->rect[i];
		if (r->u0 > r->u1)
			continue;
		{
			int b0, b1;
			band_range(s, r, &b0, &b1);
			for (int b = b0; b <= b1; b++)
				s->bin[s->bin_fill[b]++] = (uint32_t)i;
		}
	}
	return 0;
}

int lattice_slicer_render(struct lattice_slicer *s, double z_mm, const struct raster_map *map,
			  struct raster *r, float *field, int w, int h, struct err *e)
{
	double det;
	int rc;
	size_t need;

	if (r) {
		w = r->w;
		h = r->h;
	}
	if (w < 1 || h < 1)
		return ERR_SET(e, ERR_PARAM, "empty image %dx%d", w, h);
	if (!isfinite(z_mm) || z_mm < s->last_z)
		return ERR_SET(e, ERR_PARAM, "plane z %g mm below the previous plane %g mm", z_mm,
			       s->last_z);
	det = map->a[0][0] * map->a[1][1] - map->a[0][1] * map->a[1][0];
	if (!(fabs(det) > 0) || !isfinite(det))
		return ERR_SET(e, ERR_PARAM, "singular pixel map");
	s->last_z = z_mm;
	if ((rc = advance(s, z_mm, e)) != 0)
		return rc;

	s->r = r;
	s->field = field;
	s->w = w;
	s->h = h;
	s->halo = (r && s->o.antialias) ? 1 : 0;
	s->nbands = (h + BAND_ROWS - 1) / BAND_ROWS;
	/* inverse map: (x, y) = A^-1 ((u, v) - b) */
	s->iux = map->a[1][1] / det;
	s->iuy = -map->a[1][0] / det;
	s->ivx = -map->a[0][1] / det;
	s->ivy = map->a[0][0] / det;
	s->ix0 = -(s->iux * map->b[0] + s->ivx * map->b[1]);
	s->iy0 = -(s->iuy * map->b[0] + s->ivy * map->b[1]);
	if ((rc = bin_struts(s, map, e)) != 0)
		return rc;

	need = (size_t)(BAND_ROWS + 2 * s->halo) * (size_t)w;
	for (int i = 0; i < s->nwk; i++) {
		struct worker *wk = &s->wk[i];
		if (wk->acc_cap < need) {
			mem_free(wk->acc);
			wk->acc = mem_alloc(need * sizeof *wk->acc);
			wk->acc_cap = wk->acc ? need : 0;
			if (!wk->acc)
				return ERR_SET(e, ERR_NOMEM, "out of memory for row buffers");
		}
		wk->pairs = 0;
	}
	atomic_store(&s->next_band, 0);
	for (int i = 1; i < s->nwk && s->nact > 0; i++) {
		/* a thread that cannot start just leaves its share to the others */
		s->wk[i].started = pthread_create(&s->wk[i].th, NULL, worker_main, &s->wk[i]) == 0;
	}
	worker_main(&s->wk[0]);
	for (int i = 1; i < s->nwk; i++)
		if (s->wk[i].started) {
			pthread_join(s->wk[i].th, NULL);
			s->wk[i].started = 0;
		}
	for (int i = 0; i < s->nwk; i++)
		s->st.pairs += s->wk[i].pairs;
	return 0;
}
