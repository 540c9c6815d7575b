/* test_verify_corner.c - the verifier's two-edge corner model (corner.h,
 * docs/verify.md "Sub-pixel overhangs") on rendered corners.
 *
 * Layers are rendered here, apart from the code under test, with the
 * exact coverage of every pixel (squares clipped by the cavity's
 * half-planes), at a resin printer's pitch (0.047 mm pixels, 0.05 mm
 * layers, alpha 45: the slope allows 1.064 px per layer).  Checked:
 *  - a corner's two edges are recovered from the coverage alone, on
 *    both sides (a wedge of void, a wedge of solid), and a pixel on a
 *    straight edge is left to the one-edge model;
 *  - on a square pyramid roof at 45 degrees (turned 0 and 30), the
 *    farthest point of a moving corner's pixel from the layer below's
 *    solid, against the exact one: the one-edge model errs by more than
 *    0.15 px there, the corner model by less than 0.05 px;
 *  - a corner that genuinely overhangs still fails: an L-shaped cavity
 *    whose walls rise at 45 degrees moves its re-entrant corner (the
 *    solid's tip) sqrt 2 times the slope a layer, (sqrt 2 - 1) 1.064 =
 *    0.441 px beyond it; with walls at 35.3 degrees the tip moves the
 *    slope exactly and passes.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/corner.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify.h"
#include "clipsq.h"

#define PX 0.047
#define LAYER 0.05
#define SLOPE_PX (LAYER / PX) /* tan 45 */


/* gray of a pixel whose void is the convex set h (void_convex) or whose
 * solid is (!void_convex) */
static uint8_t shade(int i, int j, const struct hp *h, int nh, int void_convex)
{
	double a = clip_area(i, j, h, nh);
	return (uint8_t)lround(255 * (void_convex ? 1 - a : a));
}

/* ---- corners recovered ---- */

/* A wedge of opening open_deg, its tip at (tx, ty) (raster frame), its
 * bisector at angle bis_deg: void (void_wedge) or solid, the rest the
 * other.  The corner pixel's fit: both edges within 1 degree and their
 * meeting point within 0.02 px. */
static void check_wedge(double tx, double ty, double bis_deg, double open_deg, int void_wedge)
{
	enum { W = 15 };
	uint8_t g[W * W];
	struct verify_subpx_img im = {g, 0, 0, W, W, PX, PX, 0, NULL, NULL};
	struct verify_corner k;
	struct hp h[2];
	double b = bis_deg * M_PI / 180, o = open_deg * M_PI / 180 / 2, det, fx, fy;
	int matched = 0;

	/* the wedge {p : n_e . (p - tip) <= 0}, outward normals at the
	 * bisector +- (90 deg + half the opening) */
	for (int e = 0; e < 2; e++) {
		double a = b + (e ? 1 : -1) * (M_PI / 2 + o);
		h[e] = (struct hp){cos(a), sin(a), cos(a) * tx + sin(a) * ty};
	}
	for (int j = 0; j < W; j++)
		for (int i = 0; i < W; i++)
			g[j * W + i] = shade(i, j, h, 2, void_wedge);
	verify_corner_fit(&im, (int)floor(tx), (int)floor(ty), &k);
	printf("wedge of %s, %3.0f deg open, bisector %3.0f deg, tip (%.2f, %.2f): fit n %d "
	       "convex %d\n",
	       void_wedge ? "void " : "solid", open_deg, bis_deg, tx, ty, k.n, k.convex);
	REQUIRE(k.n == 2);
	/* a solid wedge is convex; around a void wedge the solid is concave */
	CHECK_EQ_INT(k.convex, !void_wedge);
	/* normals from solid to void: the wedge's outward normals for a
	 * solid wedge, their opposites around a void one */
	for (int e = 0; e < 2; e++)
		for (int f = 0; f < 2; f++) {
			double s = void_wedge ? -1 : 1;
			if (fabs(remainder(atan2(k.ny[f], k.nx[f]) - atan2(s * h[e].b, s * h[e].a),
					   2 * M_PI)) < M_PI / 180)
				matched++;
		}
	CHECK_EQ_INT(matched, 2);
	/* the meeting point (the fit's frame: the pixel's centre) */
	det = k.nx[0] * k.ny[1] - k.ny[0] * k.nx[1];
	REQUIRE(fabs(det) > 1e-6);
	fx = (k.d[0] * k.ny[1] - k.d[1] * k.ny[0]) / det + floor(tx) + 0.5;
	fy = (k.nx[0] * k.d[1] - k.nx[1] * k.d[0]) / det + floor(ty) + 0.5;
	CHECK_NEAR(fx, tx, 0.02);
	CHECK_NEAR(fy, ty, 0.02);
}

static void test_corner_fit(void)
{
	check_wedge(7.3, 7.6, 0, 90, 1);
	check_wedge(7.8, 7.2, 30, 90, 1);
	check_wedge(7.5, 7.45, 200, 60, 1);
	check_wedge(7.3, 7.6, 45, 90, 0);
	check_wedge(7.7, 7.3, 250, 70, 0);
	check_wedge(7.1, 7.9, 120, 120, 0);
}

/* A pixel on a straight edge is left to the one-edge model. */
static void test_straight_edge_no_corner(void)
{
	enum { W = 15 };
	uint8_t g[W * W];
	struct verify_subpx_img im = {g, 0, 0, W, W, PX, PX, 0, NULL, NULL};
	struct hp h = {cos(0.3), sin(0.3), cos(0.3) * 7.4 + sin(0.3) * 7.5};
	struct verify_corner k;
	int fitted = 0, grey = 0;

	for (int j = 0; j < W; j++)
		for (int i = 0; i < W; i++)
			g[j * W + i] = shade(i, j, &h, 1, 0);
	for (int j = 3; j < W - 3; j++)
		for (int i = 3; i < W - 3; i++)
			if (g[j * W + i] > 0 && g[j * W + i] < 255) {
				grey++;
				verify_corner_fit(&im, i, j, &k);
				fitted += k.n > 0;
			}
	CHECK(grey >= 5);
	CHECK_EQ_INT(fitted, 0);
}

/* The memo of fits (verify_fit_memo) gives every grey pixel of the
 * wedges above the fit made without it, when it stores the fit and when
 * it returns it: the same corner or none, the same edges to the bit.  A
 * memo of one slot, where every neighbourhood replaces the last, too. */
static int same_fit(const struct verify_corner *a, const struct verify_corner *b)
{
	if (a->n != b->n)
		return 0;
	if (a->n == 0)
		return 1;
	return a->convex == b->convex && memcmp(a->nx, b->nx, sizeof a->nx) == 0 &&
	       memcmp(a->ny, b->ny, sizeof a->ny) == 0 && memcmp(a->d, b->d, sizeof a->d) == 0;
}

static void test_memo_same_fits(void)
{
	enum { W = 15 };
	static const double wedge[6][5] = {{7.3, 7.6, 0, 90, 1},    {7.8, 7.2, 30, 90, 1},
					   {7.5, 7.45, 200, 60, 1}, {7.3, 7.6, 45, 90, 0},
					   {7.7, 7.3, 250, 70, 0},  {7.1, 7.9, 120, 120, 0}};
	struct verify_fit_memo *memo[2] = {verify_fit_memo_new(0), verify_fit_memo_new(1)};
	uint8_t g[W * W];
	struct verify_subpx_img im = {g, 0, 0, W, W, PX, PX, 0, NULL, NULL};
	int corners = 0, fits = 0;
	size_t looked[2], held[2], looked1, held1;

	REQUIRE(memo[0] && memo[1]);
	for (int round = 0; round < 2; round++) {
		if (round == 1)
			verify_fit_memo_stats(memo[0], &looked1, &held1);
		for (int w = 0; w < 6; w++) {
			const double *q = wedge[w];
			double b = q[2] * M_PI / 180, o = q[3] * M_PI / 180 / 2;
			struct hp h[2];
			for (int e = 0; e < 2; e++) {
				double a = b + (e ? 1 : -1) * (M_PI / 2 + o);
				h[e] = (struct hp){cos(a), sin(a), cos(a) * q[0] + sin(a) * q[1]};
			}
			for (int j = 0; j < W; j++)
				for (int i = 0; i < W; i++)
					g[j * W + i] = shade(i, j, h, 2, (int)q[4]);
			for (int j = 0; j < W; j++)
				for (int i = 0; i < W; i++) {
					struct verify_corner k0, k1;
					if (g[j * W + i] == 0 || g[j * W + i] == 255)
						continue;
					im.memo = NULL;
					verify_corner_fit(&im, i, j, &k0);
					fits++;
					corners += k0.n == 2;
					for (int m = 0; m < 2; m++) {
						im.memo = memo[m];
						verify_corner_fit(&im, i, j, &k1);
						CHECK(same_fit(&k0, &k1));
					}
				}
		}
	}
	/* the second round finds every fit the first one stored in the
	 * default memo (the first round's neighbourhoods, a few hundred,
	 * take distinct slots of its 65,536); one slot holds only the last */
	verify_fit_memo_stats(memo[0], &looked[0], &held[0]);
	verify_fit_memo_stats(memo[1], &looked[1], &held[1]);
	printf("memo: %d fits of grey pixels (each memo twice), %d corners, all equal; "
	       "default memo: %zu of %zu lookups held, one slot: %zu of %zu\n",
	       fits, corners, held[0], looked[0], held[1], looked[1]);
	CHECK(looked1 > 0 && looked[0] == 2 * looked1 && looked[1] == looked[0]);
	CHECK(held[0] - held1 == looked1);
	CHECK(held[1] < looked1);
	CHECK(corners >= 12); /* each wedge's tip, both rounds */
	verify_fit_memo_free(memo[0]);
	verify_fit_memo_free(memo[1]);
}

/* ---- a pyramid's moving corners: one edge against two ---- */

enum { PN = 60 };

/* The cavity (a square of half-side size_px turned theta around (30.3,
 * 29.6)) of a pyramid roof's layer. */
static void pyramid(double size_px, double theta, struct hp *h)
{
	for (int q = 0; q < 4; q++) {
		double a = theta + q * M_PI / 2;
		h[q] = (struct hp){cos(a), sin(a), cos(a) * 30.3 + sin(a) * 29.6 + size_px};
	}
}

/* Exact distance (pixels) from raster-frame point (x, y) to the solid
 * around cavity h: its depth inside (0 outside). */
static double depth(const struct hp *h, double x, double y)
{
	double d = INFINITY;

	for (int k = 0; k < 4; k++)
		d = fmin(d, h[k].c - h[k].a * x - h[k].b * y);
	return d > 0 ? d : 0;
}

/* Largest error (px) of verify_subpx_far_mm against the exact farthest
 * point, over the pixels of the upper layer within 3 px of a corner of
 * its cavity whose farthest point lies within 0.25 px of the reach (the
 * ones that decide the check: deeper in the solid, the 5 x 5 sampling of
 * a pixel misses the top of a ridge of the distance by up to 0.06 px,
 * whatever the model), for the one-edge model (one_edge) or the corner
 * model. */
static double corner_error(double theta, int one_edge)
{
	static uint8_t gb[PN * PN], ga[PN * PN];
	struct hp hb[4], ha[4];
	struct verify_subpx_img below = {gb, 0, 0, PN, PN, PX, PX, one_edge, NULL, NULL};
	struct verify_subpx_img above = {ga, 0, 0, PN, PN, PX, PX, one_edge, NULL, NULL};
	double err = 0, cx[4], cy[4];

	pyramid(15, theta, hb);
	pyramid(15 - SLOPE_PX, theta, ha);
	for (int j = 0; j < PN; j++)
		for (int i = 0; i < PN; i++) {
			gb[j * PN + i] = shade(i, j, hb, 4, 1);
			ga[j * PN + i] = shade(i, j, ha, 4, 1);
		}
	for (int q = 0; q < 4; q++) {
		/* corner q of the upper cavity: sides q and q + 1 meet */
		const struct hp *s = &ha[q], *t = &ha[(q + 1) % 4];
		double det = s->a * t->b - s->b * t->a;
		cx[q] = (s->c * t->b - t->c * s->b) / det;
		cy[q] = (s->a * t->c - t->a * s->c) / det;
	}
	for (int j = 0; j < PN; j++)
		for (int i = 0; i < PN; i++) {
			double exact = -1, model, near = INFINITY;
			for (int q = 0; q < 4; q++)
				near = fmin(near, hypot(i + 0.5 - cx[q], j + 0.5 - cy[q]));
			if (near > 3 || ga[j * PN + i] == 0 || gb[j * PN + i] == 255)
				continue;
			/* exact: the points of the pixel outside the upper cavity */
			for (int v = 0; v <= 40; v++)
				for (int u = 0; u <= 40; u++) {
					double x = i + u / 40.0, y = j + v / 40.0;
					int in = 1;
					for (int k = 0; k < 4; k++)
						in &= ha[k].a * x + ha[k].b * y <= ha[k].c;
					if (!in)
						exact = fmax(exact, depth(hb, x, y));
				}
			if (exact < SLOPE_PX - 0.25)
				continue; /* far inside the reach: decides nothing */
			model = verify_subpx_far_mm(&below, &above, i, j, 5) / PX;
			if (model == -INFINITY)
				continue; /* a valley's sliver the disc covers: skipped */
			err = fmax(err, fabs(model - exact));
		}
	return err;
}

static void test_pyramid_corners(void)
{
	static const double theta_deg[] = {0, 30};

	for (size_t t = 0; t < sizeof theta_deg / sizeof *theta_deg; t++) {
		double th = theta_deg[t] * M_PI / 180;
		double one = corner_error(th, 1), two = corner_error(th, 0);
		printf("pyramid corners turned %2.0f deg: farthest point off by %.3f px with one "
		       "edge, %.3f px with the corner model\n",
		       theta_deg[t], one, two);
		CHECK(one > 0.15);
		CHECK(two < 0.05);
	}
}

/* ---- an overhanging corner fails ---- */

enum { LN = 120 };

/* Gray of pixel (i, j) of a block [10, 110)^2 whose cavity is the union
 * of rectangles r1, r2 (4 half-planes each; n == 0: none). */
static uint8_t block_l(int i, int j, const struct hp *r1, const struct hp *r2, int n)
{
	double cav;

	if (i < 10 || j < 10 || i >= 110 || j >= 110)
		return 0;
	if (n == 0)
		return 255;
	{
		struct hp both[8];
		for (int k = 0; k < 4; k++) {
			both[k] = r1[k];
			both[4 + k] = r2[k];
		}
		cav = clip_area(i, j, r1, 4) + clip_area(i, j, r2, 4) - clip_area(i, j, both, 8);
	}
	return (uint8_t)lround(255 * (1 - cav));
}

/* [x0, x1] x [y0, y1] as 4 half-planes; 0 when empty. */
static int rect(double x0, double x1, double y0, double y1, struct hp *r)
{
	r[0] = (struct hp){1, 0, x1};
	r[1] = (struct hp){-1, 0, -x0};
	r[2] = (struct hp){0, 1, y1};
	r[3] = (struct hp){0, -1, -y0};
	return x1 > x0 && y1 > y0;
}

/* An L-shaped cavity: a tall bar [30, 55] x [30, 90] and a wide one
 * [30, 90] x [30, 55], every wall moving m_px inward a layer (layers
 * 0-4 floor, cavity from layer 5, ten solid layers over it).  Its
 * re-entrant corner, the tip of the solid at (55, 55), moves sqrt 2 m_px
 * along the diagonal a layer. */
static void run_l(double m_px, struct verify_report *rep)
{
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(LN, LN);
	struct err e;
	int last = -1;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; last < 0 || k <= last + 10; k++) {
		double s = (k - 5) * m_px;
		struct hp r1[4], r2[4];
		int n = 0;
		if (k >= 5) {
			int a = rect(30 + s, 55 - s, 30 + s, 90 - s, r1);
			int b = rect(30 + s, 90 - s, 30 + s, 55 - s, r2);
			n = a && b;
			if (!n && last < 0)
				last = k;
		}
		for (int j = 0; j < LN; j++)
			for (int i = 0; i < LN; i++)
				r->px[(size_t)j * r->stride + (size_t)i] = block_l(i, j, r1, r2, n);
		REQUIRE_OK(verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
}

static void test_overhanging_corner_fails(void)
{
	struct verify_report rep;
	double excess = (sqrt(2) - 1) * SLOPE_PX;

	/* walls at 45 degrees: the tip overhangs by 0.441 px a layer */
	run_l(SLOPE_PX, &rep);
	printf("L cavity, walls at 45 deg: interior overhang %lld px, slope excess %.3f px "
	       "(analytic %.3f)\n",
	       rep.interior_overhang_px, rep.slope_excess_px, excess);
	CHECK(rep.enclosed_void_mm3 > 0);
	CHECK(rep.interior_overhang_px > 0);
	CHECK_NEAR(rep.slope_excess_px, excess, 0.1);
	verify_report_fini(&rep);
	/* walls at 35.3 degrees: the tip moves the slope exactly */
	run_l(SLOPE_PX / sqrt(2), &rep);
	printf("L cavity, walls at 35.3 deg: interior overhang %lld px, slope excess %.3f px "
	       "(analytic 0)\n",
	       rep.interior_overhang_px, rep.slope_excess_px);
	CHECK(rep.enclosed_void_mm3 > 0);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK(rep.slope_excess_px <= 0.1);
	verify_report_fini(&rep);
}

int main(void)
{
	RUN(test_corner_fit);
	RUN(test_straight_edge_no_corner);
	RUN(test_memo_same_fits);
	RUN(test_pyramid_corners);
	RUN(test_overhanging_corner_fails);
	return harness_report();
}
