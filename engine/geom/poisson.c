/* poisson.c - near-maximal 2D Poisson-disk sampling by square refinement
 * (poisson.h).
 *
 * Level 0: the rectangle's squares of edge r / sqrt 2 in a seeded random
 * order, each given LEVEL0_TRIES darts; a dart is accepted when no sample
 * is closer than r (pointgrid) and inside() holds.  A square with a
 * sample is covered (its diagonal is r).  Level L > 0: every uncovered
 * square of level L - 1 is split in four; a quarter is kept when no single
 * sample's disc holds its four corners (then it may have room for a
 * point) and, with a region callback, when it is wholly in the region as
 * far as its 3 x 3 probe points tell, or one of those probes is inside and
 * farther than r from every sample.  The probe rule stops the squares that
 * straddle the region's boundary from doubling every level once the
 * inside part is covered.  Kept squares get DEEP_TRIES darts each, in a
 * fresh random order.  MAX_LEVELS levels at most (squares down to
 * r / (sqrt 2 * 2^MAX_LEVELS)), and a budget on the squares handled.
 */
#include "engine/geom/poisson.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/rng.h"
#include "engine/geom/pointgrid.h"

#include <math.h>
#include <string.h>

#define LEVEL0_TRIES 8
#define DEEP_TRIES 4
#define MAX_LEVELS 8
#define MAX_SQUARES (1u << 24)       /* level-0 squares of the rectangle */
#define GRID_MAX_CELLS (16u << 20)   /* hash grid cells (cell r, grown if needed) */

struct square {
	double x0, y0, x1, y1; /* mm, clipped to the rectangle */
};

struct sampler {
	double r, r2;
	int (*inside)(void *ctx, double x, double y);
	void *ctx;
	size_t max_points;
	struct pointgrid g;
	struct rng rg;
};

/* One dart uniformly in q: 1 accepted, 0 rejected (*in: inside() held),
 * < 0 an error. */
static int dart(struct sampler *s, const struct square *q, int *in, struct err *e)
{
	double x = q->x0 + (q->x1 - q->x0) * rng_uniform(&s->rg);
	double y = q->y0 + (q->y1 - q->y0) * rng_uniform(&s->rg);
	struct vec3 p = v3(x, y, 0);

	if (!pointgrid_far_from_all(&s->g, p, s->r))
		return 0;
	if (s->inside && !s->inside(s->ctx, x, y))
		return 0;
	*in = 1;
	if (s->g.np >= s->max_points)
		return ERR_SET(e, ERR_LIMIT, "more than %zu Poisson-disk points", s->max_points);
	{
		int rc = pointgrid_insert(&s->g, p, e);
		return rc ? rc : 1;
	}
}

struct cover_ctx {
	const struct pointgrid *g;
	const struct square *q;
	double r2;
};

static int covers(void *ctx, int32_t k)
{
	const struct cover_ctx *c = ctx;
	struct vec3 p = c->g->pts[k];
	double dx0 = c->q->x0 - p.x, dx1 = c->q->x1 - p.x;
	double dy0 = c->q->y0 - p.y, dy1 = c->q->y1 - p.y;
	double mx = fmax(dx0 * dx0, dx1 * dx1), my = fmax(dy0 * dy0, dy1 * dy1);

	/* the farthest corner from p is within r: the disc holds the square */
	return mx + my < c->r2;
}

static int covered(const struct sampler *s, const struct square *q)
{
	struct cover_ctx c = {&s->g, q, s->r2};
	double hx = 0.5 * (q->x1 - q->x0), hy = 0.5 * (q->y1 - q->y0);

	return pointgrid_visit(&s->g, v3(q->x0 + hx, q->y0 + hy, 0), s->r + hypot(hx, hy),
			       covers, &c);
}

/* Keep q for darts at the next level (see the file comment). */
static int worth_keeping(const struct sampler *s, const struct square *q)
{
	int all_in = 1, open_in = 0;

	if (covered(s, q))
		return 0;
	if (!s->inside)
		return 1;
	for (int j = 0; j < 3; j++)
		for (int i = 0; i < 3; i++) {
			double x = q->x0 + 0.5 * i * (q->x1 - q->x0);
			double y = q->y0 + 0.5 * j * (q->y1 - q->y0);
			if (!s->inside(s->ctx, x, y))
				all_in = 0;
			else if (pointgrid_far_from_all(&s->g, v3(x, y, 0), s->r))
				open_in = 1;
		}
	return all_in || open_in;
}

static void shuffle_squares(struct rng *rg, struct square *q, size_t n)
{
	for (size_t i = n; i > 1; i--) {
		size_t j = (size_t)rng_below(rg, i);
		struct square t = q[i - 1];
		q[i - 1] = q[j];
		q[j] = t;
	}
}

int poisson2_sample(double x0, double y0, double x1, double y1, double r_mm,
		    int (*inside)(void *ctx, double x, double y), void *ctx, uint64_t seed,
		    size_t max_points, double **xy_out, size_t *n_out, struct err *e)
{
	struct sampler s;
	struct square *cur = NULL, *nxt = NULL;
	size_t ncur = 0, cap_cur = 0, nnxt = 0, cap_nxt = 0, budget, handled = 0;
	double c0 = r_mm / sqrt(2.0), *xy = NULL;
	double nxd, nyd;
	int rc = 0;

	memset(&s, 0, sizeof s);
	if (!(r_mm > 0) || !isfinite(r_mm))
		return ERR_FIELD(e, "r_mm", "Poisson-disk radius must be > 0 (got %g mm)", r_mm);
	if (!isfinite(x0) || !isfinite(y0) || !isfinite(x1) || !isfinite(y1) || !(x1 > x0) ||
	    !(y1 > y0))
		return ERR_SET(e, ERR_PARAM, "empty sampling rectangle [%g, %g] x [%g, %g] mm", x0,
			       x1, y0, y1);
	nxd = ceil((x1 - x0) / c0);
	nyd = ceil((y1 - y0) / c0);
	if (!(nxd * nyd <= MAX_SQUARES))
		return ERR_SET(e, ERR_LIMIT,
			       "a %g x %g mm rectangle holds %.3g squares of %g mm (at most %u)",
			       x1 - x0, y1 - y0, nxd * nyd, c0, MAX_SQUARES);
	s.r = r_mm;
	s.r2 = r_mm * r_mm;
	s.inside = inside;
	s.ctx = ctx;
	s.max_points = max_points;
	rng_seed(&s.rg, seed);
	{
		struct box3 b = {{x0, y0, 0}, {x1, y1, 0}};
		if ((rc = pointgrid_init(&s.g, b, r_mm, GRID_MAX_CELLS, e)) != 0)
			goto out;
	}

	/* level 0 */
	{
		size_t nx = (size_t)nxd, ny = (size_t)nyd;
		ncur = nx * ny;
		budget = 8 * ncur + 4096;
		if (mem_grow((void **)&cur, &cap_cur, ncur, sizeof *cur)) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu squares", ncur);
			goto out;
		}
		for (size_t j = 0; j < ny; j++)
			for (size_t i = 0; i < nx; i++) {
				struct square *q = &cur[j * nx + i];
				q->x0 = x0 + (double)i * c0;
				q->y0 = y0 + (double)j * c0;
				q->x1 = fmin(x0 + (double)(i + 1) * c0, x1);
				q->y1 = fmin(y0 + (double)(j + 1) * c0, y1);
			}
	}
	for (int level = 0; level <= MAX_LEVELS && ncur > 0; level++) {
		int tries = level == 0 ? LEVEL0_TRIES : DEEP_TRIES;
		size_t kept = 0;

		shuffle_squares(&s.rg, cur, ncur);
		if (handled + ncur > budget)
			ncur = budget - handled; /* the budget's last squares, at random */
		for (size_t k = 0; k < ncur; k++) {
			int got = 0, in = 0;
			for (int t = 0; t < tries && !got; t++) {
				if ((rc = dart(&s, &cur[k], &in, e)) < 0)
					goto out;
				got = rc;
			}
			rc = 0;
			if (!got)
				cur[kept++] = cur[k]; /* no sample: may still have room */
		}
		handled += ncur;
		if (level == MAX_LEVELS || handled >= budget)
			break;
		/* split the squares left into quarters worth another try */
		nnxt = 0;
		for (size_t k = 0; k < kept; k++) {
			const struct square *q = &cur[k];
			double xm = 0.5 * (q->x0 + q->x1), ym = 0.5 * (q->y0 + q->y1);
			struct square ch[4] = {{q->x0, q->y0, xm, ym},
					       {xm, q->y0, q->x1, ym},
					       {q->x0, ym, xm, q->y1},
					       {xm, ym, q->x1, q->y1}};
			if (covered(&s, q))
				continue;
			for (int c = 0; c < 4; c++) {
				if (!worth_keeping(&s, &ch[c]))
					continue;
				if (mem_grow((void **)&nxt, &cap_nxt, nnxt + 1, sizeof *nxt)) {
					rc = ERR_SET(e, ERR_NOMEM, "out of memory for squares");
					goto out;
				}
				nxt[nnxt++] = ch[c];
			}
		}
		{
			struct square *t = cur;
			size_t tc = cap_cur;
			cur = nxt;
			cap_cur = cap_nxt;
			ncur = nnxt;
			nxt = t;
			cap_nxt = tc;
		}
	}

	xy = mem_alloc((s.g.np ? s.g.np : 1) * 2 * sizeof *xy);
	if (!xy) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu points", s.g.np);
		goto out;
	}
	for (size_t i = 0; i < s.g.np; i++) {
		xy[2 * i] = s.g.pts[i].x;
		xy[2 * i + 1] = s.g.pts[i].y;
	}
	*xy_out = xy;
	*n_out = s.g.np;
out:
	pointgrid_fini(&s.g);
	mem_free(cur);
	mem_free(nxt);
	return rc;
}
