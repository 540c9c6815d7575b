/* test_delaunay.c - Delaunay triangulation, convex hull, ear clipping.
 *
 * Invariants checked independently of the code under test: the empty
 * circumcircle property by brute force, triangle areas summing to the
 * convex hull's area, Euler's count 2n - 2 - h, symmetric adjacency, hull
 * containment of every point, inradius of known shapes, and ear-clipped
 * areas summing to the polygon's area.
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/delaunay.h"
#include "engine/geom/hull.h"
#include "engine/geom/polytri.h"
#include "engine/geom/predicates.h"

static uint64_t rng = 88172645463325252ULL;
static uint64_t xs(void)
{
	return harness_xorshift64(&rng);
}

static __int128 area2(struct pt2 a, struct pt2 b, struct pt2 c)
{
	return (__int128)(b.x - a.x) * (c.y - a.y) - (__int128)(b.y - a.y) * (c.x - a.x);
}

/* Check every invariant of a triangulation of p[0..n). */
static void check_dt(const struct pt2 *p, size_t n)
{
	struct delaunay dt;
	struct err e;
	struct hull_pt *h = NULL;
	size_t nh = 0, onhull = 0, uniq = 0;
	__int128 sum = 0;
	double hull_a;

	delaunay_init(&dt);
	err_clear(&e);
	REQUIRE_OK(delaunay_build(p, n, &dt, &e), &e);
	REQUIRE_OK(hull_convex(p, n, &h, &nh, &e), &e);
	for (size_t t = 0; t < dt.nt; t++) {
		const struct dt_tri *T = &dt.tri[t];
		CHECK(area2(p[T->v[0]], p[T->v[1]], p[T->v[2]]) > 0);
		sum += area2(p[T->v[0]], p[T->v[1]], p[T->v[2]]);
		for (int i = 0; i < 3; i++) {
			uint32_t o = T->nb[i];
			if (o == DT_NONE)
				continue;
			/* neighbour shares the edge reversed and points back */
			int back = 0;
			for (int j = 0; j < 3; j++)
				back += dt.tri[o].nb[j] == t;
			CHECK_EQ_INT(back, 1);
		}
		for (size_t k = 0; k < n; k++)
			if (dt.dup[k] == k)
				CHECK(geom_incircle(p[T->v[0]], p[T->v[1]], p[T->v[2]], p[k]) <= 0);
	}
	for (size_t k = 0; k < n; k++) {
		if (dt.dup[k] != k) {
			CHECK(p[dt.dup[k]].x == p[k].x && p[dt.dup[k]].y == p[k].y);
			continue;
		}
		uniq++;
		if (nh >= 3 && dt.nt) {
			struct hull_pt q = {geom_nm_to_mm(p[k].x), geom_nm_to_mm(p[k].y)};
			double d = hull_signed_distance_mm(h, nh, q);
			CHECK(d > -1e-9);
			if (fabs(d) < 1e-9)
				onhull++;
		}
	}
	hull_a = nh >= 3 ? hull_area_mm2(h, nh) : 0;
	CHECK_NEAR((double)sum / 2 / 1e12, hull_a, 1e-6 * (hull_a + 1));
	if (dt.nt)
		CHECK_EQ_INT(dt.nt, 2 * uniq - 2 - onhull);
	mem_free(h);
	delaunay_fini(&dt);
}

static void test_random(void)
{
	enum { N = 800 };
	static struct pt2 p[N];
	for (size_t i = 0; i < N; i++) {
		p[i].x = (int64_t)(xs() % 100000000) - 50000000; /* +-50 mm */
		p[i].y = (int64_t)(xs() % 100000000) - 50000000;
	}
	check_dt(p, N);
}

static void test_grid_cocircular(void)
{
	/* a regular grid: every unit square is cocircular */
	static struct pt2 p[31 * 17];
	size_t n = 0;
	for (int i = 0; i < 31; i++)
		for (int j = 0; j < 17; j++)
			p[n++] = (struct pt2){i * 250000LL, j * 250000LL};
	check_dt(p, n);
}

static void test_duplicates_collinear(void)
{
	struct pt2 line[10];
	struct delaunay dt;
	struct err e;

	for (int i = 0; i < 10; i++)
		line[i] = (struct pt2){i * 1000LL, 2 * i * 1000LL};
	delaunay_init(&dt);
	REQUIRE_OK(delaunay_build(line, 10, &dt, &e), &e);
	CHECK_EQ_INT(dt.nt, 0); /* all collinear */
	delaunay_fini(&dt);

	/* a square's boundary resampled (many collinear points) plus repeats */
	struct pt2 p[90];
	size_t n = 0;
	for (int i = 0; i < 20; i++) {
		p[n++] = (struct pt2){i * 500000LL, 0};
		p[n++] = (struct pt2){10000000, i * 500000LL};
		p[n++] = (struct pt2){10000000 - i * 500000LL, 10000000};
		p[n++] = (struct pt2){0, 10000000 - i * 500000LL};
	}
	for (int i = 0; i < 10; i++)
		p[n++] = p[i * 7]; /* duplicates */
	check_dt(p, n);
}

static void test_circle_and_fan(void)
{
	/* points on a circle (rounded to nm: nearly cocircular) plus the centre */
	struct pt2 p[201];
	struct delaunay dt;
	struct err e;
	uint32_t fan[256];
	int closed;
	size_t nf;

	for (int i = 0; i < 200; i++) {
		double a = 2 * M_PI * i / 200;
		p[i] = (struct pt2){geom_mm_to_nm(10 * cos(a)), geom_mm_to_nm(10 * sin(a))};
	}
	p[200] = (struct pt2){0, 0};
	check_dt(p, 201);
	delaunay_init(&dt);
	REQUIRE_OK(delaunay_build(p, 201, &dt, &e), &e);
	nf = delaunay_fan(&dt, 200, fan, 256, &closed);
	CHECK_EQ_INT(closed, 1);
	CHECK_EQ_INT(nf, 200); /* the centre sees every rim point */
	nf = delaunay_fan(&dt, 0, fan, 256, &closed);
	CHECK_EQ_INT(closed, 0);
	CHECK(nf >= 1);
	/* circumcentres of the centre's fan lie near radius 5 (half way) */
	for (size_t k = 0; k < nf; k++) {
		double x, y;
		delaunay_circumcenter_mm(&dt, p, fan[k], &x, &y);
		CHECK(hypot(x, y) < 10);
	}
	delaunay_fini(&dt);
}

static void test_range_limit(void)
{
	struct pt2 p[3] = {{0, 0}, {(int64_t)1 << 31, 0}, {0, 5}};
	struct delaunay dt;
	struct err e;

	delaunay_init(&dt);
	CHECK_EQ_INT(delaunay_build(p, 3, &dt, &e), ERR_LIMIT);
	delaunay_fini(&dt);
}

static void test_hull_ops(void)
{
	struct pt2 sq[5] = {{0, 0}, {10000000, 0}, {10000000, 10000000}, {0, 10000000},
			    {5000000, 5000000}};
	struct hull_pt *h, *o, c;
	size_t nh, no;
	struct err e;
	int edge, vertex;

	REQUIRE_OK(hull_convex(sq, 5, &h, &nh, &e), &e);
	CHECK_EQ_INT(nh, 4);
	CHECK_NEAR(hull_area_mm2(h, nh), 100, 1e-12);
	CHECK_NEAR(hull_inradius_mm(h, nh, &c), 5, 1e-6);
	CHECK_NEAR(c.x, 5, 1e-5);
	REQUIRE_OK(hull_offset_in(h, nh, 2, &o, &no, &e), &e);
	CHECK_EQ_INT(no, 4);
	CHECK_NEAR(hull_area_mm2(o, no), 36, 1e-9);
	mem_free(o);
	REQUIRE_OK(hull_offset_in(h, nh, 6, &o, &no, &e), &e);
	CHECK_EQ_INT(no, 0);
	CHECK_NEAR(hull_signed_distance_mm(h, nh, (struct hull_pt){1, 5}), 1, 1e-12);
	CHECK_NEAR(hull_signed_distance_mm(h, nh, (struct hull_pt){-3, 14}), -5, 1e-12);
	CHECK_NEAR(hull_closest_mm(h, nh, (struct hull_pt){13, 5}, &c, &edge, &vertex), 3, 1e-12);
	CHECK_EQ_INT(vertex, 0);
	CHECK_NEAR(c.x, 10, 1e-12);
	hull_closest_mm(h, nh, (struct hull_pt){12, 12}, &c, &edge, &vertex);
	CHECK_EQ_INT(vertex, 1);
	mem_free(h);
	/* right triangle 3-4-5: inradius (a + b - c) / 2 = 1 */
	struct pt2 tr[3] = {{0, 0}, {3000000, 0}, {0, 4000000}};
	REQUIRE_OK(hull_convex(tr, 3, &h, &nh, &e), &e);
	CHECK_NEAR(hull_inradius_mm(h, nh, NULL), 1, 1e-6);
	mem_free(h);
}

static double tri_area_sum(const double *xy, const uint32_t *t, size_t nt, double *minar)
{
	double s = 0;
	*minar = INFINITY;
	for (size_t i = 0; i < nt; i++) {
		const double *a = xy + 2 * t[3 * i], *b = xy + 2 * t[3 * i + 1],
			     *c = xy + 2 * t[3 * i + 2];
		double ar = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
		s += ar;
		*minar = fmin(*minar, ar);
	}
	return s;
}

static void test_polytri(void)
{
	/* a comb: 10 teeth, deeply non-convex */
	double xy[2 * 64];
	uint32_t t[3 * 62];
	size_t n = 0;
	double minar, area = 0;
	struct err e;

	for (int i = 0; i < 10; i++) {
		xy[2 * n] = i * 2.0, xy[2 * n + 1] = 0, n++;
		xy[2 * n] = i * 2.0 + 1, xy[2 * n + 1] = 0, n++;
		xy[2 * n] = i * 2.0 + 1, xy[2 * n + 1] = 5, n++;
		xy[2 * n] = i * 2.0 + 2, xy[2 * n + 1] = 5, n++;
	}
	/* close along the top: back from (20, 5) to (0, 8) */
	xy[2 * n] = 20, xy[2 * n + 1] = 8, n++;
	xy[2 * n] = 0, xy[2 * n + 1] = 8, n++;
	for (size_t i = 0; i < n; i++) {
		size_t j = (i + 1) % n;
		area += 0.5 * (xy[2 * i] * xy[2 * j + 1] - xy[2 * j] * xy[2 * i + 1]);
	}
	REQUIRE_OK(polytri_ears(xy, n, t, &e), &e);
	CHECK_NEAR(tri_area_sum(xy, t, n - 2, &minar), area, 1e-9);
	CHECK(minar > 0);
	/* a collapsed polygon (zero area, out and back along a segment) */
	double z[2 * 6] = {0, 0, 1, 0, 2, 0, 3, 0, 2, 0, 1, 0};
	REQUIRE_OK(polytri_ears(z, 6, t, &e), &e);
	CHECK_NEAR(tri_area_sum(z, t, 4, &minar), 0, 1e-12);
	CHECK_EQ_INT(polytri_ears(z, 2, t, &e), ERR_PARAM);
}

int main(void)
{
	RUN(test_random);
	RUN(test_grid_cocircular);
	RUN(test_duplicates_collinear);
	RUN(test_circle_and_fan);
	RUN(test_range_limit);
	RUN(test_hull_ops);
	RUN(test_polytri);
	return harness_report();
}
