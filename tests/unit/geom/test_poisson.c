/* test_poisson.c - 2D Poisson-disk sampling (geom/poisson.h): pairwise
 * distances >= r (brute force), near-maximality on a fine probe grid
 * (the farthest probe point of the region from every sample, and the
 * fraction of the region left farther than r), the region callback,
 * determinism for a seed, limits and allocation failures.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/poisson.h"

/* Smallest pairwise distance, O(n^2). */
static double min_pair(const double *xy, size_t n)
{
	double best = INFINITY;

	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			double d = hypot(xy[2 * i] - xy[2 * j], xy[2 * i + 1] - xy[2 * j + 1]);
			best = fmin(best, d);
		}
	return best;
}

struct ring {
	double cx, cy, r_out, r_in;
	long calls;
};

static int in_ring(void *ctx, double x, double y)
{
	struct ring *g = ctx;
	double d = hypot(x - g->cx, y - g->cy);

	g->calls++;
	return d < g->r_out && d > g->r_in;
}

/* Samples binned in square bins of edge r (the test's own index). */
struct bins {
	double x0, y0, r;
	int nx, ny;
	size_t *start, *item; /* CSR */
};

static void bins_build(struct bins *b, const double *xy, size_t n, double x0, double y0,
		       double x1, double y1, double r)
{
	b->x0 = x0;
	b->y0 = y0;
	b->r = r;
	b->nx = (int)((x1 - x0) / r) + 1;
	b->ny = (int)((y1 - y0) / r) + 1;
	b->start = calloc((size_t)b->nx * b->ny + 1, sizeof *b->start);
	b->item = malloc((n ? n : 1) * sizeof *b->item);
	for (int pass = 0; pass < 2; pass++) {
		for (size_t i = 0; i < n; i++) {
			int bx = (int)((xy[2 * i] - x0) / r), by = (int)((xy[2 * i + 1] - y0) / r);
			size_t c = (size_t)by * b->nx + bx;
			if (pass == 0)
				b->start[c + 1]++;
			else
				b->item[b->start[c]++] = i;
		}
		if (pass == 0)
			for (size_t c = 0; c < (size_t)b->nx * b->ny; c++)
				b->start[c + 1] += b->start[c];
		else /* start[c] now holds the end of c: shift back */
			for (size_t c = (size_t)b->nx * b->ny; c > 0; c--)
				b->start[c] = b->start[c - 1];
	}
	b->start[0] = 0;
}

/* Distance to the nearest sample when it is within 2 r, else INFINITY. */
static double bins_nearest(const struct bins *b, const double *xy, double x, double y)
{
	int bx = (int)floor((x - b->x0) / b->r), by = (int)floor((y - b->y0) / b->r);
	double d = INFINITY;

	for (int j = by - 2; j <= by + 2; j++)
		for (int i = bx - 2; i <= bx + 2; i++) {
			size_t c;
			if (i < 0 || j < 0 || i >= b->nx || j >= b->ny)
				continue;
			c = (size_t)j * b->nx + i;
			for (size_t k = b->start[c]; k < b->start[c + 1]; k++) {
				size_t q = b->item[k];
				d = fmin(d, hypot(x - xy[2 * q], y - xy[2 * q + 1]));
			}
		}
	return d <= 2 * b->r ? d : INFINITY;
}

/* Over probe points of pitch h in the rectangle (and in the ring when
 * given): the largest distance to the nearest sample, and the fraction of
 * probes farther than r. */
static void coverage(const double *xy, size_t n, double x0, double y0, double x1, double y1,
		     double h, double r, struct ring *g, double *worst, double *open_frac)
{
	size_t probes = 0, open = 0;
	struct bins b;

	bins_build(&b, xy, n, x0, y0, x1, y1, r);
	*worst = 0;
	for (double y = y0 + 0.5 * h; y < y1; y += h)
		for (double x = x0 + 0.5 * h; x < x1; x += h) {
			double d;
			if (g) {
				long c = g->calls;
				int in = in_ring(g, x, y);
				g->calls = c;
				if (!in)
					continue;
			}
			d = bins_nearest(&b, xy, x, y);
			probes++;
			open += d > r;
			*worst = fmax(*worst, d);
		}
	*open_frac = probes ? (double)open / (double)probes : 1;
	free(b.start);
	free(b.item);
}

static void test_rectangle(void)
{
	double *xy = NULL, worst, open;
	size_t n = 0;
	struct err e;

	REQUIRE_OK(poisson2_sample(-20, -15, 30, 25, 1.0, NULL, NULL, 7, 1000000, &xy, &n, &e),
		   &e);
	CHECK_NUM(min_pair(xy, n), >=, 1.0);
	for (size_t i = 0; i < n; i++) {
		CHECK(xy[2 * i] >= -20 && xy[2 * i] <= 30);
		CHECK(xy[2 * i + 1] >= -15 && xy[2 * i + 1] <= 25);
	}
	coverage(xy, n, -20, -15, 30, 25, 0.05, 1.0, NULL, &worst, &open);
	/* maximal: no point of the rectangle is farther than r from a sample */
	CHECK_NUM(worst, <, 1.02);
	CHECK_NUM(open, <, 1e-4);
	/* maximal Poisson-disk density is about 0.69 / r^2 (Ebeida et al.) */
	CHECK_NEAR(n / (50.0 * 40.0), 0.69, 0.06);
	fprintf(stderr, "rectangle: %zu points (%.3f / r^2), farthest probe %.4f r, open %.2e\n",
		n, n / 2000.0, worst, open);
	mem_free(xy);
}

static void test_region(void)
{
	struct ring g = {5, 5, 12, 4, 0};
	double *xy = NULL, worst, open;
	size_t n = 0;
	struct err e;

	REQUIRE_OK(poisson2_sample(-8, -8, 18, 18, 0.8, in_ring, &g, 3, 1000000, &xy, &n, &e),
		   &e);
	CHECK_NUM(min_pair(xy, n), >=, 0.8);
	for (size_t i = 0; i < n; i++) {
		long c = g.calls;
		CHECK(in_ring(&g, xy[2 * i], xy[2 * i + 1]));
		g.calls = c;
	}
	coverage(xy, n, -8, -8, 18, 18, 0.04, 0.8, &g, &worst, &open);
	CHECK_NUM(worst, <, 1.1 * 0.8);
	CHECK_NUM(open, <, 1e-3);
	fprintf(stderr,
		"ring: %zu points, farthest probe %.4f r, open %.2e, %.1f inside calls per "
		"square\n",
		n, worst / 0.8, open, g.calls / (26.0 * 26.0 / (0.32)));
	mem_free(xy);
}

static void test_determinism(void)
{
	double *a = NULL, *b = NULL, *c = NULL;
	size_t na = 0, nb = 0, nc = 0;
	struct err e;

	REQUIRE_OK(poisson2_sample(0, 0, 20, 10, 0.7, NULL, NULL, 42, 100000, &a, &na, &e), &e);
	REQUIRE_OK(poisson2_sample(0, 0, 20, 10, 0.7, NULL, NULL, 42, 100000, &b, &nb, &e), &e);
	REQUIRE_OK(poisson2_sample(0, 0, 20, 10, 0.7, NULL, NULL, 43, 100000, &c, &nc, &e), &e);
	CHECK_EQ_INT(na, nb);
	CHECK(na == nb && memcmp(a, b, na * 2 * sizeof *a) == 0);
	CHECK(na != nc || memcmp(a, c, na * 2 * sizeof *a) != 0);
	mem_free(a);
	mem_free(b);
	mem_free(c);
}

static int never(void *ctx, double x, double y)
{
	(void)ctx;
	(void)x;
	(void)y;
	return 0;
}

static void test_limits(void)
{
	double *xy = NULL;
	size_t n = 99;
	struct err e;

	CHECK_EQ_INT(poisson2_sample(0, 0, 1, 1, 0, NULL, NULL, 1, 10, &xy, &n, &e), ERR_PARAM);
	CHECK_EQ_INT(poisson2_sample(0, 0, 1, 1, NAN, NULL, NULL, 1, 10, &xy, &n, &e), ERR_PARAM);
	CHECK_EQ_INT(poisson2_sample(0, 0, 0, 1, 0.1, NULL, NULL, 1, 10, &xy, &n, &e), ERR_PARAM);
	CHECK_EQ_INT(poisson2_sample(0, 0, 1, INFINITY, 0.1, NULL, NULL, 1, 10, &xy, &n, &e),
		     ERR_PARAM);
	CHECK_EQ_INT(poisson2_sample(0, 0, 10, 10, 0.1, NULL, NULL, 1, 10, &xy, &n, &e), ERR_LIMIT);
	CHECK_EQ_INT(poisson2_sample(0, 0, 1e6, 1e6, 0.1, NULL, NULL, 1, 10, &xy, &n, &e),
		     ERR_LIMIT);
	CHECK(xy == NULL && n == 99); /* outputs untouched on failure */
	/* an empty region: no points, no error */
	REQUIRE_OK(poisson2_sample(0, 0, 5, 5, 0.5, never, NULL, 1, 10, &xy, &n, &e), &e);
	CHECK_EQ_INT(n, 0);
	mem_free(xy);
	/* a rectangle smaller than r: one point */
	REQUIRE_OK(poisson2_sample(0, 0, 0.1, 0.1, 0.5, NULL, NULL, 1, 10, &xy, &n, &e), &e);
	CHECK_EQ_INT(n, 1);
	mem_free(xy);
	for (long k = 1; k < 12; k++) {
		int rc;
		xy = NULL;
		mem_fail_after(k);
		rc = poisson2_sample(0, 0, 30, 30, 0.3, NULL, NULL, 1, 100000, &xy, &n, &e);
		mem_fail_after(-1);
		CHECK(rc == 0 || rc == ERR_NOMEM);
		if (rc == 0)
			mem_free(xy);
	}
}

int main(void)
{
	RUN(test_rectangle);
	RUN(test_region);
	RUN(test_determinism);
	RUN(test_limits);
	return harness_report();
}
