/* test_verify_walls.c - the checker's wall measures and void topology on
 * small pixel-exact stacks: a box (floor, walls, ceiling) around a cavity
 * whose walls are a known number of pixels; a void meeting the outside
 * only at a pixel corner (the outside, not an enclosed void); anti-aliased
 * edges (one threshold: gray >= 128 is solid); rasterisation specks
 * (counted apart from the wall minimum); many cavities in one layer (the
 * per-component enclosure flags survive the growth of their array); fins
 * (solid one or two pixels thick between two cavities).
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/verify.h"

#define PX 0.05
#define LAYER 0.05
#define N 64     /* image N x N pixels */
#define FLOOR 3  /* solid layers under the cavity, and over it */
#define MID 6    /* layers with the cavity */

/* Gray value of pixel (i, j) on layer k; cavity: k is one of the MID
 * layers between FLOOR solid layers below and above. */
typedef uint8_t (*layer_fn)(int i, int j, int k, int cavity, const void *arg);

static void run_box(layer_fn f, const void *arg, int speck_voxels, struct verify_report *rep)
{
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, speck_voxels, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N);
	struct err e;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; k < 2 * FLOOR + MID; k++) {
		int cavity = k >= FLOOR && k < FLOOR + MID;
		for (int j = 0; j < N; j++)
			for (int i = 0; i < N; i++)
				r->px[(size_t)j * r->stride + (size_t)i] = f(i, j, k, cavity, arg);
		REQUIRE_OK(verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
}

static int in_sq(int i, int j, int lo, int hi)
{
	return i >= lo && i < hi && j >= lo && j < hi;
}

/* Box [10, 54)^2 pixels; cavity [10 + w, 54 - w)^2: walls of w pixels. */
static uint8_t ring(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	int w = *(const int *)arg;

	if (!in_sq(i, j, 10, 54))
		return 0;
	return cavity && in_sq(i, j, 10 + w, 54 - w) ? 0 : 255;
}

static void test_ring_walls(void)
{
	for (int w = 1; w <= 6; w++) {
		struct verify_report rep;
		int side = 44 - 2 * w;
		run_box(ring, &w, 0, &rep);
		/* w solid pixels between void centres w + 1 pixels apart */
		CHECK_NEAR(rep.min_wall_mm, w * PX, 1e-6);
		CHECK_NEAR(rep.min_wall_vertical_mm, FLOOR * LAYER, 1e-9);
		CHECK_NEAR(rep.enclosed_void_mm3, side * side * MID * PX * PX * LAYER, 1e-9);
		CHECK_EQ_INT(rep.specks, 0);
		CHECK_EQ_INT(rep.islands, 0);
		/* a thin wall to the outside is a wall, not a fin */
		CHECK_EQ_INT((int)rep.fin_px, 0);
		verify_report_fini(&rep);
	}
}

/* Box [10, 54)^2 with cavity [20, 44)^2 split by a partition of w pixel
 * columns [31, 31 + w) over the cavity's rows: two cavities. */
static uint8_t split(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	int w = *(const int *)arg;

	if (!in_sq(i, j, 10, 54))
		return 0;
	if (!cavity || !in_sq(i, j, 20, 44) || (i >= 31 && i < 31 + w))
		return 255;
	return 0;
}

static void test_fins(void)
{
	for (int w = 1; w <= 4; w++) {
		struct verify_report rep;
		run_box(split, &w, 0, &rep);
		/* every partition pixel on every cavity layer at w <= 2, none
		 * from 3 pixels on (the box's own corners add none) */
		CHECK_EQ_INT((int)rep.fin_px, w <= 2 ? w * 24 * MID : 0);
		CHECK_NEAR(rep.fin_mm3, (double)rep.fin_px * PX * PX * LAYER, 1e-12);
		CHECK_NEAR(rep.min_wall_mm, 10 * PX, 1e-6);
		CHECK_NEAR(rep.enclosed_void_mm3, (24 - w) * 24 * MID * PX * PX * LAYER, 1e-9);
		verify_report_fini(&rep);
	}
}

/* The box with a 20 x 20 cavity (walls 12 px) and a notch at its corner:
 * (10, 10) is void (outside), and (11, 11) is void, its four neighbours
 * solid: it meets the outside at one pixel corner only.  With *arg set, a
 * one-pixel diagonal crack runs from (11, 11) to (16, 16). */
static uint8_t corner(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	int crack = *(const int *)arg;

	if (!in_sq(i, j, 10, 54))
		return 0;
	if (!cavity)
		return 255;
	if (in_sq(i, j, 22, 42) || (i == j && i <= (crack ? 16 : 11)))
		return 0;
	return 255;
}

static void test_corner_void_is_outside(void)
{
	struct verify_report rep;
	int crack = 0;

	run_box(corner, &crack, 1, &rep);
	/* only the cavity is enclosed: the corner pixel is the outside, so no
	 * sqrt(2) - 1 pixel "wall" */
	CHECK_NEAR(rep.enclosed_void_mm3, 20 * 20 * MID * PX * PX * LAYER, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, 12 * PX, 1e-6);
	CHECK_EQ_INT(rep.specks, 0);
	verify_report_fini(&rep);
	/* a diagonal crack of void pixels is open too; the cavity's wall to
	 * the crack's end (16, 16) -> (22, 22) is 6 sqrt 2 - 1 pixels */
	crack = 1;
	run_box(corner, &crack, 1, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 20 * 20 * MID * PX * PX * LAYER, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, (6 * sqrt(2) - 1) * PX, 1e-6);
	verify_report_fini(&rep);
}

/* Coverage of pixel [i, i+1) x [j, j+1) by the square [lo, hi)^2. */
static double cover(int i, int j, double lo, double hi)
{
	double ox = fmax(0, fmin(i + 1, hi) - fmax(i, lo));
	double oy = fmax(0, fmin(j + 1, hi) - fmax(j, lo));
	return ox * oy;
}

/* Anti-aliased box [10.3, 53.7)^2 with cavity [14.3, 49.7)^2: a true wall
 * of 4.0 pixels whose edges cut pixels at 30 and 70 % coverage. */
static uint8_t aa_ring(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	double c = cover(i, j, 10.3, 53.7);

	(void)arg;
	if (cavity)
		c -= cover(i, j, 14.3, 49.7);
	return (uint8_t)lround(255 * fmax(0, c));
}

/* The 3 px ring, its inner boundary pixels at gray *arg. */
static uint8_t grey_ring(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	int g = *(const int *)arg;

	if (!in_sq(i, j, 10, 54))
		return 0;
	if (!cavity || !in_sq(i, j, 13, 51))
		return 255;
	return in_sq(i, j, 14, 50) ? 0 : (uint8_t)g;
}

static void test_antialiased_edges(void)
{
	struct verify_report rep;
	int g;

	run_box(aa_ring, NULL, 0, &rep);
	/* coverage >= 50 % is solid: pixels 10..13 -> 4 px, the true wall */
	CHECK_NEAR(rep.min_wall_mm, 4 * PX, 1e-6);
	CHECK_EQ_INT(rep.specks, 0);
	CHECK_EQ_INT(rep.islands, 0);
	verify_report_fini(&rep);
	/* the threshold: 128 is solid (wall 4 px), 127 is void (3 px) */
	g = 128;
	run_box(grey_ring, &g, 0, &rep);
	CHECK_NEAR(rep.min_wall_mm, 4 * PX, 1e-6);
	verify_report_fini(&rep);
	g = 127;
	run_box(grey_ring, &g, 0, &rep);
	CHECK_NEAR(rep.min_wall_mm, 3 * PX, 1e-6);
	verify_report_fini(&rep);
}

/* The 8 px ring plus a sealed 1 x 2 pixel pocket (11, 30..31), one pixel
 * in from the outer face, on every cavity layer. */
static uint8_t speck(int i, int j, int k, int cavity, const void *arg)
{
	(void)k;
	(void)arg;
	if (!in_sq(i, j, 10, 54))
		return 0;
	if (!cavity)
		return 255;
	if (in_sq(i, j, 18, 46))
		return 0;
	return i == 11 && (j == 30 || j == 31) ? 0 : 255;
}

static void test_specks(void)
{
	struct verify_report rep;

	/* 2 px x MID layers = 12 voxels: a speck at speck_voxels 12, with a
	 * 1 px wall to the outside, kept out of min_wall_mm */
	run_box(speck, NULL, 12, &rep);
	CHECK_EQ_INT(rep.specks, 1);
	CHECK_NEAR(rep.speck_min_wall_mm, 1 * PX, 1e-6);
	CHECK_NEAR(rep.min_wall_mm, 8 * PX, 1e-6);
	CHECK_NEAR(rep.min_wall_vertical_mm, FLOOR * LAYER, 1e-9);
	verify_report_fini(&rep);
	/* at the default (8 voxels) the same pocket is a cavity: 1 px wall */
	run_box(speck, NULL, 0, &rep);
	CHECK_EQ_INT(rep.specks, 0);
	CHECK(isinf(rep.speck_min_wall_mm));
	CHECK_NEAR(rep.min_wall_mm, 1 * PX, 1e-6);
	verify_report_fini(&rep);
}

/* The 8 px ring's box with a 4 x 4 px chimney at [46, 50) x [14, 18)
 * from layer 1 through the top: enclosed in every layer, but open to
 * the outside above the stack, so the one layer under it is no wall. */
static uint8_t chimney(int i, int j, int k, int cavity, const void *arg)
{
	(void)arg;
	if (!in_sq(i, j, 10, 54))
		return 0;
	if (k >= 1 && i >= 46 && i < 50 && j >= 14 && j < 18)
		return 0;
	return cavity && in_sq(i, j, 20, 36) ? 0 : 255;
}

static void test_open_pocket_is_no_wall(void)
{
	struct verify_report rep;

	run_box(chimney, NULL, 0, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 16 * 16 * MID * PX * PX * LAYER, 1e-9);
	CHECK_NEAR(rep.min_wall_vertical_mm, FLOOR * LAYER, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, 10 * PX, 1e-6);
	verify_report_fini(&rep);
}

/* The box with 8 x 8 cavities of 2 x 2 px, 2 px apart, filling
 * [20, 50) x [20, 50): the first cavity layer has 65 void components, more
 * than any layer before it, so the enclosure flags are grown while
 * labelling.  Walls to the outside: 10 px left/top, 4 px right/bottom.
 * A cavity taken for the outside would read a 2 px wall to its neighbour. */
static uint8_t grid(int i, int j, int k, int cavity, const void *arg)
{
	(void)arg;
	(void)k;
	if (!in_sq(i, j, 10, 54))
		return 0;
	if (cavity && in_sq(i, j, 20, 50) && (i - 20) % 4 < 2 && (j - 20) % 4 < 2)
		return 0;
	return 255;
}

static void test_many_cavities(void)
{
	struct verify_report rep;

	run_box(grid, NULL, 0, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 64 * 4 * MID * PX * PX * LAYER, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, 4 * PX, 1e-6);
	CHECK_NEAR(rep.min_wall_vertical_mm, FLOOR * LAYER, 1e-9);
	CHECK_EQ_INT(rep.specks, 0);
	verify_report_fini(&rep);
}

int main(void)
{
	RUN(test_ring_walls);
	RUN(test_corner_void_is_outside);
	RUN(test_antialiased_edges);
	RUN(test_specks);
	RUN(test_open_pocket_is_no_wall);
	RUN(test_many_cavities);
	RUN(test_fins);
	return harness_report();
}
