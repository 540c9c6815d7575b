/* test_opt_slices.c - the optimiser's adaptive slices (slices.c) and
 * section 6's contour smoothing P -> P~ (contour.c hl_loop_smooth), on
 * synthetic input whose answer is known in closed form:
 *  - hl_slab_deviation_mm on discs (polygons of 720 sides): a cone's
 *    layers (radius linear in z) deviate 0 from the band between the
 *    ends; a ball's equator between layers d above and below deviates by
 *    the sagitta of the chord, d^2 / (2 R) (the annulus pi d^2 over the
 *    perimeter 2 pi R); a middle layer inside both ends by the area
 *    missing from their intersection over its own perimeter;
 *  - hl_slices_adaptive on a cylinder's layers takes the thickest slab
 *    everywhere; on a ball's, every chosen slab keeps every layer within
 *    the tolerance by the closed-form disc deviation (computed here, not by
 *    the code under test), and where a slab is thinner than the most
 *    allowed, one candidate more would break it: the choice is the
 *    farthest; slabs are thinner near the poles than at the equator;
 *  - hl_loop_smooth on an L-shaped loop: passes = 0 changes nothing; after
 *    1, 5 and 40 passes every vertex stays inside the L, the reflex corner
 *    stays where it is, the loop stays simple and counter-clockwise, and
 *    the area only decreases.
 * Frame: printer frame, mm; loops counter-clockwise.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/hollow/opt/opt_int.h"
#include "loopgen.h"

#define DISC_SIDES 720

/* Disc of radius r (mm) about the origin, a region of DISC_SIDES sides
 * (empty for r <= 0). */
static void disc(struct paths *ps, double r)
{
	struct pt2 p[DISC_SIDES];

	paths_clear(ps);
	if (!(r > 0))
		return;
	for (int i = 0; i < DISC_SIDES; i++) {
		double t = 2 * M_PI * i / DISC_SIDES;
		p[i].x = geom_mm_to_nm(r * cos(t));
		p[i].y = geom_mm_to_nm(r * sin(t));
	}
	CHECK_EQ_INT(paths_add_pts(ps, p, DISC_SIDES), 0);
}

/* The deviation of concentric discs in closed form: the area of the middle
 * disc outside the band [min, max] of the ends' radii over its perimeter. */
static double disc_dev(double r_lo, double r_mid, double r_hi)
{
	double a = fmin(r_lo, r_hi), b = fmax(r_lo, r_hi), out;

	out = r_mid > b ? M_PI * (r_mid * r_mid - b * b) : r_mid < a ? M_PI * (a * a - r_mid * r_mid) : 0;
	return out > 0 ? out / (2 * M_PI * r_mid) : 0;
}

static void test_deviation_discs(void)
{
	struct paths lo, mid, hi;
	struct err e;
	double d, R = 5, dz = 1;

	paths_init(&lo);
	paths_init(&mid);
	paths_init(&hi);
	err_clear(&e);
	/* cone: radius 4, 3.5, 3 at equal steps */
	disc(&lo, 4);
	disc(&mid, 3.5);
	disc(&hi, 3);
	REQUIRE_OK(hl_slab_deviation_mm(&lo, &mid, &hi, &d, &e), &e);
	CHECK_NEAR(d, 0, 1e-6);
	/* ball of radius R: the equator between layers dz above and below */
	disc(&lo, sqrt(R * R - dz * dz));
	disc(&mid, R);
	disc(&hi, sqrt(R * R - dz * dz));
	REQUIRE_OK(hl_slab_deviation_mm(&lo, &mid, &hi, &d, &e), &e);
	CHECK_NEAR(d, dz * dz / (2 * R), 2e-4);
	CHECK_NEAR(d, disc_dev(sqrt(R * R - dz * dz), R, sqrt(R * R - dz * dz)), 2e-4);
	/* a waist: the middle inside both ends */
	disc(&lo, 3);
	disc(&mid, 2);
	disc(&hi, 4);
	REQUIRE_OK(hl_slab_deviation_mm(&lo, &mid, &hi, &d, &e), &e);
	CHECK_NEAR(d, (9.0 - 4.0) / 4.0, 2e-3); /* pi (3^2 - 2^2) / (2 pi 2) */
	/* everything empty: nothing deviates */
	paths_clear(&lo);
	paths_clear(&mid);
	paths_clear(&hi);
	REQUIRE_OK(hl_slab_deviation_mm(&lo, &mid, &hi, &d, &e), &e);
	CHECK_NEAR(d, 0, 0);
	paths_fini(&lo);
	paths_fini(&mid);
	paths_fini(&hi);
}

/* Radius of a ball of radius R centred at height R at candidate i (layers
 * dz apart from dz / 2); <= 0 outside. */
static double ball_r(double R, double dz, size_t i)
{
	double z = (i + 0.5) * dz - R;
	return R * R - z * z > 0 ? sqrt(R * R - z * z) : 0;
}

static void test_adaptive_choice(void)
{
	enum { NC = 80 };
	struct paths reg[NC];
	size_t pick[NC], np = 0, tmax = 4;
	struct err e;
	double R = 10, dz = 0.25, tol = 0.05, eq_slab = 0, pole_slab = INFINITY;

	err_clear(&e);
	for (size_t i = 0; i < NC; i++)
		paths_init(&reg[i]);
	/* cylinder: straight in z, the thickest slab everywhere */
	for (size_t i = 0; i < NC; i++)
		disc(&reg[i], 6);
	REQUIRE_OK(hl_slices_adaptive(reg, NC, tmax, tol, pick, &np, &e), &e);
	CHECK_EQ_INT(np, 1 + (NC - 1 + tmax - 1) / tmax);
	for (size_t k = 0; k + 2 < np; k++)
		CHECK_EQ_INT(pick[k + 1] - pick[k], tmax);
	CHECK_EQ_INT(pick[np - 1], NC - 1); /* the last slab: what is left, 1..tmax */
	CHECK_NUM(pick[np - 1] - pick[np - 2], <=, tmax);
	/* ball of radius 10 mm, candidates 0.25 mm apart */
	for (size_t i = 0; i < NC; i++)
		disc(&reg[i], ball_r(R, dz, i));
	REQUIRE_OK(hl_slices_adaptive(reg, NC, tmax, tol, pick, &np, &e), &e);
	CHECK_EQ_INT(pick[0], 0);
	CHECK_EQ_INT(pick[np - 1], NC - 1);
	for (size_t k = 0; k + 1 < np; k++) {
		size_t a = pick[k], b = pick[k + 1], t = b - a;
		double worst = 0, next = 0;
		CHECK_NUM(t, >=, 1);
		CHECK_NUM(t, <=, tmax);
		/* every layer of the slab within the tolerance (polygon slack 1e-3) */
		for (size_t c = a + 1; c < b; c++)
			worst = fmax(worst, disc_dev(ball_r(R, dz, a), ball_r(R, dz, c),
						     ball_r(R, dz, b)));
		CHECK_NUM(worst, <=, tol + 1e-3);
		/* the farthest: every thicker slab allowed breaks the tolerance */
		for (size_t t2 = t + 1; t2 <= tmax && a + t2 < NC; t2++) {
			next = 0;
			for (size_t c = a + 1; c < a + t2; c++)
				next = fmax(next, disc_dev(ball_r(R, dz, a), ball_r(R, dz, c),
							   ball_r(R, dz, a + t2)));
			CHECK_NUM(next, >, tol - 1e-3);
		}
		if (a >= NC / 2 - 4 && b <= NC / 2 + 4)
			eq_slab = fmax(eq_slab, t * dz);
		if (b <= 6 || a >= NC - 7)
			pole_slab = fmin(pole_slab, t * dz);
	}
	CHECK_NEAR(eq_slab, tmax * dz, 1e-12); /* sagitta 1^2 / (8 * 10) < 0.05 */
	CHECK_NUM(pole_slab, <, eq_slab);
	for (size_t i = 0; i < NC; i++)
		paths_fini(&reg[i]);
}

/* An L: [0,10] x [0,4] u [0,4] x [0,10], counter-clockwise, steps <= s;
 * the reflex corner (4, 4) is a vertex. */
static void l_loop(struct hl_loop *L, double s)
{
	static const double c[6][2] = {{0, 0}, {10, 0}, {10, 4}, {4, 4}, {4, 10}, {0, 10}};

	corner_loop(L, c, 6, s, 0, 0);
	REQUIRE(L->xy != NULL);
	CHECK_NEAR(L->area_mm2, 10 * 4 + 4 * 6, 1e-9);
}

static void test_smooth_l(void)
{
	struct hl_loop L, ref;
	struct err e;
	double s = 0.25, prev;
	size_t corner = (size_t)-1;
	static const double L_xy[12] = {0, 0, 10, 0, 10, 4, 4, 4, 4, 10, 0, 10};

	err_clear(&e);
	l_loop(&ref, s);
	for (size_t i = 0; i < ref.n; i++)
		if (ref.xy[2 * i] == 4 && ref.xy[2 * i + 1] == 4)
			corner = i;
	REQUIRE(corner != (size_t)-1);
	l_loop(&L, s);
	REQUIRE_OK(hl_loop_smooth(&L, 0, &e), &e);
	CHECK(memcmp(L.xy, ref.xy, 2 * L.n * sizeof *L.xy) == 0);
	prev = 64;
	for (int passes = 1; passes <= 40; passes += passes == 1 ? 4 : 35) {
		hl_loop_fini(&L);
		l_loop(&L, s);
		REQUIRE_OK(hl_loop_smooth(&L, passes, &e), &e);
		CHECK_EQ_INT(L.n, ref.n);
		CHECK_NUM(L.area_mm2, >, 0);
		CHECK_NUM(L.area_mm2, <, prev);
		prev = L.area_mm2;
		CHECK_NEAR(L.xy[2 * corner], 4, 0);
		CHECK_NEAR(L.xy[2 * corner + 1], 4, 0);
		for (size_t i = 0; i < L.n; i++) {
			double x = L.xy[2 * i], y = L.xy[2 * i + 1];
			/* inside the L or on its boundary */
			int on = x == 0 || y == 0 || (x == 10 && y <= 4) || (y == 10 && x <= 4) ||
				 (x == 4 && y >= 4) || (y == 4 && x >= 4);
			CHECK(on || point_in(L_xy, 6, x, y));
		}
		CHECK(is_simple(L.xy, L.n));
	}
	/* 40 passes round the convex corners by more than a sample step */
	CHECK_NUM(64 - L.area_mm2, >, 3 * s * s);
	hl_loop_fini(&L);
	hl_loop_fini(&ref);
}

int main(void)
{
	RUN(test_deviation_discs);
	RUN(test_adaptive_choice);
	RUN(test_smooth_l);
	return harness_report();
}
