/* test_tcs.c - the diamond ball-and-stick lattice (hybrid.h, tcs.c):
 * 4 bonds per interior atom, bond length sqrt(3)/4 a, every stick at
 * 54.7356 deg from the vertical, no duplicate bonds, the atoms' density,
 * the solid fraction of the union by Monte Carlo (brute-force point in
 * capsules) and by rendered layers (capsule_zindex_raster) against the
 * exact ball-and-stick volume, balls left out when inside the sticks,
 * limits and parameters.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"
#include "engine/hybrid/structure.h"

static int same(struct vec3 p, struct vec3 q)
{
	return v3_dist(p, q) < 1e-9;
}

static int in_union(const struct capsule *c, size_t n, struct vec3 p)
{
	for (size_t i = 0; i < n; i++) {
		struct vec3 d = v3_sub(c[i].b, c[i].a), w = v3_sub(p, c[i].a);
		double l2 = v3_len2(d), t = l2 > 0 ? fmin(fmax(v3_dot(w, d) / l2, 0), 1) : 0;
		if (v3_dist(p, v3_madd(c[i].a, d, t)) < c[i].r_mm)
			return 1;
	}
	return 0;
}

/* Exact solid volume of one cubic cell (8 atoms, 16 bonds) when every
 * stick-stick overlap is inside a ball (rb >= rs / sin(54.7 deg)) and
 * balls do not touch: balls + the sticks' cylinders less the parts of
 * them inside the two balls, (2 pi / 3)(rb^3 - (rb^2 - rs^2)^(3/2)) each. */
static double cell_volume(double a, double rb, double rs)
{
	double L = sqrt(3.0) / 4 * a;
	double in_ball = 2 * M_PI / 3 * (pow(rb, 3) - pow(rb * rb - rs * rs, 1.5));

	return 8 * 4.0 / 3 * M_PI * pow(rb, 3) + 16 * (M_PI * rs * rs * L - 2 * in_ball);
}

static void test_structure(void)
{
	const double a = 5, rb = 0.8, stick = 1.0;
	struct vec3 lo = v3(0, 0, 0), hi = v3(4 * a, 4 * a, 4 * a), shift = v3(0.3, -0.2, 0.1);
	struct capsule *c = NULL;
	size_t n = 0, atoms = 0, sticks = 0, interior = 0, bad_deg = 0, dup = 0, inner_atoms = 0;
	double steep = 0, L = sqrt(3.0) / 4 * a, worst_len = 0, worst_ang = 0;
	struct err e;

	REQUIRE_OK(hy_tcs_build(lo, hi, a, rb, stick, shift, 100000, &c, &n, &steep, &e), &e);
	CHECK_NEAR(steep, 54.7356103172, 1e-8);
	for (size_t i = 0; i < n; i++) {
		if (same(c[i].a, c[i].b)) {
			atoms++;
			CHECK_NEAR(c[i].r_mm, rb, 0);
			continue;
		}
		sticks++;
		CHECK_NEAR(c[i].r_mm, stick / 2, 0);
		CHECK(c[i].a.z <= c[i].b.z);
		worst_len = fmax(worst_len, fabs(v3_dist(c[i].a, c[i].b) - L));
		{
			double len = v3_dist(c[i].a, c[i].b);
			double deg = acos((c[i].b.z - c[i].a.z) / len) * 180 / M_PI;
			worst_ang = fmax(worst_ang, fabs(deg - 54.7356103172));
		}
		for (size_t j = i + 1; j < n; j++)
			if ((same(c[i].a, c[j].a) && same(c[i].b, c[j].b)) ||
			    (same(c[i].a, c[j].b) && same(c[i].b, c[j].a)))
				dup++;
	}
	CHECK_NUM(worst_len, <, 1e-9);
	CHECK_NUM(worst_ang, <, 1e-7);
	CHECK_EQ_INT(dup, 0);
	/* atoms at least a bond length inside the box: 4 bonds each */
	for (size_t i = 0; i < n; i++) {
		struct vec3 p = c[i].a;
		size_t deg = 0;
		if (!same(c[i].a, c[i].b))
			continue;
		if (p.x >= 0.5 && p.x < 15.5 && p.y >= 2.5 && p.y < 17.5 && p.z >= 2.5 &&
		    p.z < 17.5)
			inner_atoms++;
		if (p.x < L || p.x > 4 * a - L || p.y < L || p.y > 4 * a - L || p.z < L ||
		    p.z > 4 * a - L)
			continue;
		interior++;
		for (size_t j = 0; j < n; j++)
			if (!same(c[j].a, c[j].b) && (same(c[j].a, p) || same(c[j].b, p)))
				deg++;
		bad_deg += deg != 4;
	}
	CHECK_INT(interior, >, 200);
	CHECK_EQ_INT(bad_deg, 0);
	/* 8 atoms per a^3: a box of 3 x 3 x 3 periods holds 216 */
	CHECK_EQ_INT(inner_atoms, 216);
	/* 2 bonds per atom overall (each atom has 4, each bond 2 atoms), less the
	 * ones cut at the grown box's faces */
	CHECK_NUM(sticks, <=, 2 * atoms);
	CHECK_NUM(sticks, >, 1.5 * atoms);
	/* atom positions: shift + a (lattice site); quarter coordinates are
	 * integers of one parity on all three axes */
	for (size_t i = 0; i < n; i++) {
		double q[3] = {4 * (c[i].a.x - shift.x) / a, 4 * (c[i].a.y - shift.y) / a,
			       4 * (c[i].a.z - shift.z) / a};
		long r[3];
		for (int k = 0; k < 3; k++) {
			r[k] = lround(q[k]);
			CHECK_NEAR(q[k], (double)r[k], 1e-9);
		}
		CHECK((r[0] - r[1]) % 2 == 0 && (r[1] - r[2]) % 2 == 0);
	}
	mem_free(c);
}

static void test_volume_fraction(void)
{
	const double a = 5, rb = 0.8, rs = 0.5;
	struct vec3 lo = v3(-7, 2, 1), hi = v3(-7 + 3 * a, 2 + 3 * a, 1 + 3 * a);
	struct capsule *c = NULL;
	size_t n = 0, hit = 0, N = 40000;
	double steep, expect = cell_volume(a, rb, rs) / (a * a * a), mc;
	uint64_t s = 12345;
	struct err e;

	REQUIRE_OK(hy_tcs_build(lo, hi, a, rb, 2 * rs, v3(0.7, 1.1, -0.4), 100000, &c, &n, &steep,
				&e),
		   &e);
	/* the box spans 3 periods: its average is the periodic fraction */
	for (size_t k = 0; k < N; k++) {
		double u[3];
		for (int d = 0; d < 3; d++)
			u[d] = (double)(harness_xorshift64(&s) >> 11) / 9007199254740992.0;
		hit += in_union(c, n, v3(lo.x + 3 * a * u[0], lo.y + 3 * a * u[1],
					 lo.z + 3 * a * u[2]));
	}
	mc = (double)hit / (double)N;
	CHECK_NEAR(mc, expect, 0.012);
	/* the same by layers of the union raster: 0.05 mm pixels, 0.1 mm layers */
	{
		struct capsule_zindex *ix = NULL;
		const double p = 0.05;
		int w = (int)lround(3 * a / p), h = w;
		struct raster_map m = {{{1 / p, 0}, {0, 1 / p}}, {-lo.x / p, -lo.y / p}};
		uint8_t *img = mem_alloc((size_t)w * h);
		double px = 0, layers = 0;
		REQUIRE(img);
		REQUIRE_OK(capsule_zindex_new(c, n, 0, &ix, &e), &e);
		for (double z = lo.z + 0.05; z < hi.z; z += 0.1) {
			memset(img, 0, (size_t)w * h);
			REQUIRE_OK(capsule_zindex_raster(ix, z, &m, w, h, img, 2, &e), &e);
			for (size_t q = 0; q < (size_t)w * h; q++)
				px += img[q];
			layers++;
		}
		CHECK_NEAR(px / ((double)w * h * layers), expect, 0.004);
		fprintf(stderr, "TCS solid fraction: exact %.4f, Monte Carlo %.4f, layers %.4f\n",
			expect, mc, px / ((double)w * h * layers));
		capsule_zindex_free(ix);
		mem_free(img);
	}
	mem_free(c);
}

static void test_small_balls_and_limits(void)
{
	struct capsule *c = NULL;
	size_t n = 0, n2 = 0;
	double steep;
	struct err e;
	struct vec3 o = v3(0, 0, 0), b = v3(10, 10, 10);

	/* balls within the sticks' radius are left out */
	REQUIRE_OK(hy_tcs_build(o, b, 5, 0.4, 1.0, o, 100000, &c, &n, &steep, &e), &e);
	for (size_t i = 0; i < n; i++)
		CHECK(!same(c[i].a, c[i].b));
	mem_free(c);
	c = NULL;
	REQUIRE_OK(hy_tcs_build(o, b, 5, 0.6, 1.0, o, 100000, &c, &n2, &steep, &e), &e);
	CHECK_INT(n2, >, n);
	mem_free(c);
	c = NULL;
	/* max_caps */
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, 0.6, 1.0, o, n2 - 1, &c, &n, &steep, &e), ERR_LIMIT);
	CHECK(c == NULL);
	REQUIRE_OK(hy_tcs_build(o, b, 5, 0.6, 1.0, o, n2, &c, &n, &steep, &e), &e);
	CHECK_EQ_INT(n, n2);
	mem_free(c);
	c = NULL;
	/* refused before walking a huge grid */
	CHECK_EQ_INT(hy_tcs_build(o, v3(1e4, 1e4, 1e4), 0.01, 0, 0.002, o, 1000000, &c, &n, &steep,
				  &e),
		     ERR_LIMIT);
	/* a flat box (one layer's slab) works */
	REQUIRE_OK(hy_tcs_build(o, v3(10, 10, 0), 5, 0.6, 1.0, o, 100000, &c, &n, &steep, &e), &e);
	CHECK_INT(n, >, 0);
	mem_free(c);
	c = NULL;
	CHECK_EQ_INT(hy_tcs_build(o, b, 0, 0.6, 1.0, o, 100, &c, &n, &steep, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, 0.6, 0, o, 100, &c, &n, &steep, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, 0.6, 5, o, 100, &c, &n, &steep, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, -1, 1, o, 100, &c, &n, &steep, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_tcs_build(b, o, 5, 0.6, 1, o, 100, &c, &n, &steep, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, 0.6, 1, v3(NAN, 0, 0), 100, &c, &n, &steep, &e),
		     ERR_PARAM);
	mem_fail_after(1);
	CHECK_EQ_INT(hy_tcs_build(o, b, 5, 0.6, 1.0, o, 100000, &c, &n, &steep, &e), ERR_NOMEM);
	mem_fail_after(-1);
	CHECK(c == NULL);
}

int main(void)
{
	RUN(test_structure);
	RUN(test_volume_fraction);
	RUN(test_small_balls_and_limits);
	return harness_report();
}
