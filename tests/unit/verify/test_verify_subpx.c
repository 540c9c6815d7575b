/* test_verify_subpx.c - the verifier's sub-pixel overhang test on
 * rendered analytic shapes (docs/verify.md "Sub-pixel overhangs").
 *
 * A resin printer's pitch (0.047 mm pixels, 0.05 mm layers, alpha 45:
 * the slope allows 1.064 px per layer) and a sealed cavity in a solid
 * block whose roof is a cone (a disc shrinking every layer) or a wedge
 * (a strip shrinking every layer, turned 0, 20, 45 and 70 degrees in
 * the plane) at 30, 45 and 50 degrees from the vertical.  Layers are
 * rendered here, apart from the code under test, with the exact
 * coverage of every pixel (the pixel square clipped by the cavity's
 * half-planes; the disc as a 2048-gon, 0.0004 px from the circle), as
 * an anti-aliasing rasteriser writes them.  Expected, at the default
 * tolerance (VERIFY_TOLERANCE_PX): 30 and 45 degrees pass, 50 fails
 * (it exceeds the slope by 0.204 px a layer), and the measured excess
 * (slope_excess_px) is the analytic one within 0.1 px, also on square
 * pyramids (turned 0 and 30 degrees), whose corners move along the
 * diagonals (the two-edge corner model, corner.h) and whose roofs close
 * on a small square hole.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/verify.h"
#include "clipsq.h"

#define PX 0.047
#define LAYER 0.05
#define N 200
#define DISC_EDGES CLIPSQ_MAX_EDGES


/* One layer: solid block [10, 190]^2 px minus the cavity (half-planes h,
 * or nothing when nh == 0); pixels far from every cavity edge skip the
 * clipping. */
static void render(struct raster *r, const struct hp *h, int nh)
{
	for (int j = 0; j < N; j++)
		for (int i = 0; i < N; i++) {
			double cx = i + 0.5, cy = j + 0.5, cav;
			int in = 1, near = 0;
			uint8_t *px = &r->px[(size_t)j * r->stride + (size_t)i];
			if (i < 10 || j < 10 || i >= 190 || j >= 190) {
				*px = 0;
				continue;
			}
			for (int k = 0; k < nh; k++) {
				double f = h[k].a * cx + h[k].b * cy - h[k].c;
				if (f > 0.75) {
					in = 0;
					near = 0;
					break;
				}
				if (f > -0.75)
					near = 1;
			}
			if (nh == 0)
				cav = 0;
			else if (!in)
				cav = 0;
			else if (!near)
				cav = 1;
			else
				cav = clip_area(i, j, h, nh);
			*px = (uint8_t)lround(255 * (1 - cav));
		}
}

enum shape { CONE, WEDGE, PYRAMID };

static double g_tol_px; /* 0: the default */
static int g_threads;   /* verify_params.threads (0: one) */

/* Check the stack of a cavity whose roof leans beta_deg from the
 * vertical; theta_deg turns the wedge in the plane. */
static void run(enum shape s, double beta_deg, double theta_deg, struct verify_report *rep)
{
	struct verify_params p = {LAYER, 45, PX, PX, g_tol_px, 0, 0, g_threads};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N);
	struct hp h[DISC_EDGES];
	struct err e;
	double step_px = LAYER * tan(beta_deg * M_PI / 180) / PX, size0 = 40;
	double cx = 100.3, cy = 99.6, th = theta_deg * M_PI / 180;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0;; k++) {
		/* layers 0-4 floor, then the cavity shrinks from layer 5 */
		double size = size0 - (k - 5) * step_px;
		int nh = 0;
		if (k >= 5 && size > 0) {
			if (s == CONE) {
				for (int q = 0; q < DISC_EDGES; q++) {
					double a = 2 * M_PI * (q + 0.5) / DISC_EDGES;
					h[nh++] = (struct hp){cos(a), sin(a),
							      cos(a) * cx + sin(a) * cy +
								      size * cos(M_PI / DISC_EDGES)};
				}
			} else if (s == PYRAMID) {
				/* a square of half-side size turned theta: its corners
				 * move along the diagonals, sqrt 2 times the slope per
				 * layer, and stay within the slope of the walls below */
				for (int q = 0; q < 4; q++) {
					double a = th + q * M_PI / 2;
					h[nh++] = (struct hp){cos(a), sin(a),
							      cos(a) * cx + sin(a) * cy + size};
				}
			} else {
				/* a strip of half-width size across n = (cos, sin),
				 * capped by the square [50, 150]^2 */
				double nx = cos(th), ny = sin(th), c0 = nx * cx + ny * cy;
				h[nh++] = (struct hp){nx, ny, c0 + size};
				h[nh++] = (struct hp){-nx, -ny, -c0 + size};
				h[nh++] = (struct hp){1, 0, 150};
				h[nh++] = (struct hp){-1, 0, -50};
				h[nh++] = (struct hp){0, 1, 150};
				h[nh++] = (struct hp){0, -1, -50};
			}
		}
		render(r, h, nh);
		REQUIRE_OK(verify_layer(v, r, &e), &e);
		if (k >= 5 && size <= -10 * step_px)
			break; /* ten solid layers over the closed roof */
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
}

static double excess_px(double beta_deg)
{
	return LAYER * (tan(beta_deg * M_PI / 180) - 1) / PX;
}

/* One roof: at or under alpha it passes with its excess under tol_px;
 * over it, it fails with the analytic excess within tol_px. */
static void check_roof(enum shape s, double beta_deg, double theta_deg, double tol_px)
{
	static const char *name[] = {"cone", "wedge", "pyramid"};
	struct verify_report rep;

	run(s, beta_deg, theta_deg, &rep);
	printf("%s %2.0f deg turned %2.0f: interior overhang %lld px, slope excess %.3f px "
	       "(analytic %.3f)\n",
	       name[s], beta_deg, theta_deg, rep.interior_overhang_px, rep.slope_excess_px,
	       fmax(0, excess_px(beta_deg)));
	CHECK(rep.enclosed_void_mm3 > 0);
	CHECK_EQ_INT(rep.islands, 0);
	if (beta_deg <= 45) {
		CHECK_EQ_INT(rep.interior_overhang_px, 0);
		CHECK(rep.slope_excess_px <= tol_px);
	} else {
		CHECK(rep.interior_overhang_px > 0);
		CHECK_NEAR(rep.slope_excess_px, excess_px(beta_deg), tol_px);
	}
	verify_report_fini(&rep);
}

static void test_cone(void)
{
	static const double beta[] = {30, 45, 50};
	for (size_t b = 0; b < sizeof beta / sizeof *beta; b++)
		check_roof(CONE, beta[b], 0, 0.1);
}

static void test_wedge(void)
{
	static const double beta[] = {30, 45, 50}, theta[] = {0, 20, 45, 70};
	for (size_t t = 0; t < sizeof theta / sizeof *theta; t++)
		for (size_t b = 0; b < sizeof beta / sizeof *beta; b++)
			check_roof(WEDGE, beta[b], theta[t], 0.1);
}

/* Moving corners, read by two edges a pixel (test_verify_corner.c), and
 * a roof's last hole, a small square: within 0.1 px too. */
static void test_pyramid(void)
{
	static const double beta[] = {45, 50}, theta[] = {0, 30};
	for (size_t t = 0; t < sizeof theta / sizeof *theta; t++)
		for (size_t b = 0; b < sizeof beta / sizeof *beta; b++)
			check_roof(PYRAMID, beta[b], theta[t], 0.1);
}

/* The same cone at 50 degrees passes with a tolerance of one pixel: the
 * reading the verifier had before it measured at sub-pixel accuracy. */
static void test_tolerance_matters(void)
{
	struct verify_report rep;

	CHECK(excess_px(50) > VERIFY_TOLERANCE_PX);
	g_tol_px = 1;
	run(CONE, 50, 0, &rep);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK_NEAR(rep.tolerance_px, 1, 1e-12);
	verify_report_fini(&rep);
	g_tol_px = 0;
}

/* The overhang readings on three threads (the open pixels of each layer
 * shared out, the corner fits and the memo shared): the same report as
 * on one, to the bit, on roofs that read over with corners (the pyramid
 * at 50 degrees turned 30) and without (the cone). */
static void test_threads_same_report(void)
{
	static const enum shape shp[2] = {PYRAMID, CONE};
	static const double theta[2] = {30, 0};

	for (int k = 0; k < 2; k++) {
		struct verify_report one, three;
		g_threads = 0;
		run(shp[k], 50, theta[k], &one);
		g_threads = 3;
		run(shp[k], 50, theta[k], &three);
		g_threads = 0;
		CHECK(one.interior_overhang_px > 0);
		CHECK(one.interior_overhang_px == three.interior_overhang_px);
		CHECK(one.interior_overhang_mm2 == three.interior_overhang_mm2);
		CHECK(one.slope_excess_mm == three.slope_excess_mm);
		CHECK_EQ_INT(one.overhang_layers, three.overhang_layers);
		CHECK_EQ_INT(one.worst_layer, three.worst_layer);
		CHECK(one.worst_layer_px == three.worst_layer_px);
		CHECK(one.exterior_overhang_mm2 == three.exterior_overhang_mm2);
		CHECK(one.enclosed_void_mm3 == three.enclosed_void_mm3);
		CHECK_EQ_INT(one.layers, three.layers);
		for (int l = 0; l < one.layers && l < three.layers; l++)
			CHECK(one.overhang_px[l] == three.overhang_px[l]);
		printf("%s at 50 deg on 1 and 3 threads: %lld px over, excess %.6f px, equal\n",
		       k ? "cone" : "pyramid", one.interior_overhang_px, one.slope_excess_px);
		verify_report_fini(&one);
		verify_report_fini(&three);
	}
}

/* verify_far_pixels on one pair: below solid on the side n.p <= c of a
 * line turned 20 degrees, above the same line moved d px into the void
 * (solid band [c, c + d] over nothing).  Every pixel of above it reports
 * lies in that band, beyond the reach, and the farthest reads d within
 * 0.1 px (d = 1.5: a small excess, measured, not bounded); with d under
 * the reach it reports none; a nonzero return of fn stops the scan. */
struct far_seen {
	int n, stop_at;
	int last_x, last_y; /* the last pixel passed: calls come row by row */
	double lo, hi; /* far range seen, px */
	double hi_mid; /* the largest of rows 30..170, away from the box's ends */
	double d, nx, ny, c;
};

static int far_seen(void *ctx, int x, int y, double far_mm)
{
	struct far_seen *f = ctx;
	double s = f->nx * (x + 0.5) + f->ny * (y + 0.5) - f->c; /* centre past below's edge, px */

	f->n++;
	CHECK(y > f->last_y || (y == f->last_y && x > f->last_x));
	f->last_x = x;
	f->last_y = y;
	f->lo = fmin(f->lo, far_mm / PX);
	f->hi = fmax(f->hi, far_mm / PX);
	if (y >= 30 && y <= 170)
		f->hi_mid = fmax(f->hi_mid, far_mm / PX);
	CHECK(s > -1 && s < f->d + 1);
	CHECK(x >= 19 && x <= 180 && y >= 19 && y <= 180);
	return f->stop_at && f->n == f->stop_at ? 7 : 0;
}

static void far_pair(double d_px, int stop_at, int threads, struct verify_fit_memo *memo,
		     struct far_seen *f)
{
	struct verify_pair_read rd = {PX, PX, LAYER, threads, memo};
	struct raster *below = raster_new(N, N), *above = raster_new(N, N);
	double th = 20 * M_PI / 180;
	/* the line, capped by the box [20, 180]^2 (an image's empty margin) */
	struct hp hb[5] = {{0, 0, 0}, {1, 0, 180}, {-1, 0, -20}, {0, 1, 180}, {0, -1, -20}}, ha[5];
	struct err e;
	int rc;

	REQUIRE(below && above);
	memset(f, 0, sizeof *f);
	f->lo = INFINITY;
	f->hi = f->hi_mid = -INFINITY;
	f->d = d_px;
	f->nx = cos(th);
	f->ny = sin(th);
	f->c = 80.3;
	f->stop_at = stop_at;
	f->last_y = -1;
	hb[0] = (struct hp){f->nx, f->ny, f->c};
	memcpy(ha, hb, sizeof ha);
	ha[0].c = f->c + d_px;
	for (int j = 0; j < N; j++)
		for (int i = 0; i < N; i++) {
			below->px[(size_t)j * below->stride + (size_t)i] =
			    (uint8_t)lround(255 * clip_area(i, j, hb, 5));
			above->px[(size_t)j * above->stride + (size_t)i] =
			    (uint8_t)lround(255 * clip_area(i, j, ha, 5));
		}
	err_clear(&e);
	rc = verify_far_pixels(below, above, 0, 0, &rd, far_seen, f, &e);
	CHECK_EQ_INT(rc, stop_at ? 7 : 0);
	raster_free(below);
	raster_free(above);
}

static void test_far_pixels(void)
{
	struct far_seen f, g;
	struct verify_fit_memo *memo = verify_fit_memo_new(0);

	REQUIRE(memo);
	far_pair(1.5, 0, 1, NULL, &f); /* 1.5 px a layer: 0.44 px over the reach of 1.064 */
	printf("band 1.5 px: %d pixels read %.3f..%.3f px (%.3f away from the ends)\n", f.n, f.lo,
	       f.hi, f.hi_mid);
	CHECK(f.n > 160 / 2); /* a pixel every other row at least along the line */
	CHECK(f.lo > LAYER / PX);
	CHECK_NEAR(f.hi_mid, 1.5, 0.1);
	/* at the ends the band's corner lies 1.5 / cos 20 from below's, read
	 * within the tolerance */
	CHECK(f.hi < 1.5 / cos(20 * M_PI / 180) + VERIFY_TOLERANCE_PX);
	/* read on two threads with a memo (twice: its fits made, then
	 * taken): the same pixels, in row order, the same readings */
	for (int k = 0; k < 2; k++) {
		far_pair(1.5, 0, 2, memo, &g);
		CHECK_EQ_INT(g.n, f.n);
		CHECK(g.lo == f.lo && g.hi == f.hi && g.hi_mid == f.hi_mid);
	}
	far_pair(0.9, 0, 1, NULL, &f); /* under the reach: nothing */
	CHECK_EQ_INT(f.n, 0);
	far_pair(3.0, 5, 1, NULL, &f); /* fn's nonzero return stops the scan */
	CHECK_EQ_INT(f.n, 5);
	far_pair(3.0, 5, 2, memo, &f);
	CHECK_EQ_INT(f.n, 5);
	verify_fit_memo_free(memo);
}

int main(void)
{
	RUN(test_cone);
	RUN(test_wedge);
	RUN(test_pyramid);
	RUN(test_tolerance_matters);
	RUN(test_threads_same_report);
	RUN(test_far_pixels);
	return harness_report();
}
