/* test_verify_between.c - walls between two cavities (min_wall_between_mm,
 * min_wall_between_vertical_mm) on pixel-exact stacks: a partition of N
 * pixels between two cavities reads N pixels; cavities joined above are
 * one cavity (no wall between); cavities with the outside between them
 * are no pair; a cavity over another with a floor of N layers reads N
 * layers and, up to 2 layers, is a shelf; a speck beside a cavity is
 * kept out; random discs read the
 * brute-force nearest pixel pair's distance; thin partitions are fins and,
 * but for their ends, slivers, where a bump on a wall is a fin only.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/verify.h"

#define PX 0.05
#define LAYER 0.05
#define N 80 /* image N x N pixels */

static uint64_t rng = 0x2545f4914f6cdd1dULL;
static uint64_t xs(void)
{
	return harness_xorshift64(&rng);
}

/* 1 when pixel (i, j) of layer k is solid. */
typedef int (*solid_fn)(int i, int j, int k, const void *arg);

static void run_stack(solid_fn f, const void *arg, int layers, struct verify_report *rep)
{
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N);
	struct err e;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; k < layers; k++) {
		for (int j = 0; j < N; j++)
			for (int i = 0; i < N; i++)
				r->px[(size_t)j * r->stride + (size_t)i] = f(i, j, k, arg) ? 255 : 0;
		REQUIRE_OK(verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
}

static int in_box(int i, int j, int x0, int y0, int x1, int y1)
{
	return i >= x0 && i < x1 && j >= y0 && j < y1;
}

/* Box [10, 70)^2, layers 0..11: cavities on layers 3..8, [20, 60) in y;
 * left x in [20, 38), right x in [38 + w, 60): a partition of w columns.
 * join: layer 8 is void across the partition too (one cavity). */
struct part {
	int w, join;
};

static int partition(int i, int j, int k, const void *arg)
{
	const struct part *p = arg;

	if (!in_box(i, j, 10, 10, 70, 70))
		return 0;
	if (k < 3 || k > 8 || !in_box(i, j, 20, 20, 60, 60))
		return 1;
	if (p->join && k == 8)
		return 0;
	return i >= 38 && i < 38 + p->w;
}

static void test_partition(void)
{
	for (int w = 1; w <= 8; w++) {
		struct part p = {w, 0};
		struct verify_report rep;
		run_stack(partition, &p, 12, &rep);
		/* w solid pixels between void centres w + 1 pixels apart */
		CHECK_NEAR(rep.min_wall_between_mm, w * PX, 1e-6);
		CHECK(rep.min_wall_between_layer >= 3 && rep.min_wall_between_layer <= 8);
		CHECK(isinf(rep.min_wall_between_vertical_mm));
		CHECK_NEAR(rep.min_wall_mm, 10 * PX, 1e-6);
		verify_report_fini(&rep);
	}
}

/* Joined on their top layer: one cavity, its partition is not a wall
 * between cavities (a thin one is a fin). */
static void test_joined_is_one_cavity(void)
{
	struct part p = {4, 1};
	struct verify_report rep;

	run_stack(partition, &p, 12, &rep);
	CHECK(isinf(rep.min_wall_between_mm));
	CHECK_EQ_INT(rep.min_wall_between_layer, -1);
	CHECK(isinf(rep.min_wall_between_vertical_mm));
	CHECK_NEAR(rep.enclosed_void_mm3, (40 * 40 + 5 * 40 * 36) * PX * PX * LAYER, 1e-9);
	/* the partition's top layer is solid under nothing: no shelf */
	CHECK_EQ_INT((int)rep.shelf_px, 0);
	verify_report_fini(&rep);
}

/* Two boxes [10, 38) and [42, 70) in x (a slot of outside between them),
 * each with a cavity 2 px from the slot: no pair, each wall is to the
 * outside. */
static int slot(int i, int j, int k, const void *arg)
{
	(void)arg;
	if (!in_box(i, j, 10, 10, 70, 70) || (i >= 38 && i < 42))
		return 0;
	if (k < 3 || k > 8)
		return 1;
	return !(in_box(i, j, 20, 20, 36, 60) || in_box(i, j, 44, 20, 60, 60));
}

static void test_outside_between(void)
{
	struct verify_report rep;

	run_stack(slot, NULL, 12, &rep);
	CHECK(isinf(rep.min_wall_between_mm));
	CHECK_NEAR(rep.min_wall_mm, 2 * PX, 1e-6);
	verify_report_fini(&rep);
}

/* A cavity on layers 2..5 and another on layers 6 + f .. 9 + f, same
 * footprint: a floor of f layers between them. */
static int stacked(int i, int j, int k, const void *arg)
{
	int f = *(const int *)arg;

	if (!in_box(i, j, 10, 10, 70, 70))
		return 0;
	if (!in_box(i, j, 20, 20, 60, 60))
		return 1;
	return !((k >= 2 && k <= 5) || (k >= 6 + f && k <= 9 + f));
}

static void test_floor_between(void)
{
	for (int f = 1; f <= 5; f++) {
		struct verify_report rep;
		run_stack(stacked, &f, 13 + f, &rep);
		CHECK_NEAR(rep.min_wall_between_vertical_mm, f * LAYER, 1e-9);
		/* a floor of 1 or 2 layers between cavities is a shelf */
		CHECK_EQ_INT((int)rep.shelf_px, f <= 2 ? f * 40 * 40 : 0);
		CHECK_NEAR(rep.shelf_mm3, (double)rep.shelf_px * PX * PX * LAYER, 1e-12);
		CHECK(isinf(rep.min_wall_between_mm));
		/* to the outside: the 2-layer floor and 3-layer roof */
		CHECK_NEAR(rep.min_wall_vertical_mm, 2 * LAYER, 1e-9);
		verify_report_fini(&rep);
	}
}

/* One cavity on layers 2..9 with a plate of one layer (layer 5) over half
 * its footprint: a shelf inside one cavity, no wall between cavities. */
static int plate(int i, int j, int k, const void *arg)
{
	(void)arg;
	if (!in_box(i, j, 10, 10, 70, 70))
		return 0;
	if (!in_box(i, j, 20, 20, 60, 60) || k < 2 || k > 9)
		return 1;
	return k == 5 && i < 40;
}

static void test_shelf_in_one_cavity(void)
{
	struct verify_report rep;

	run_stack(plate, NULL, 12, &rep);
	CHECK_EQ_INT((int)rep.shelf_px, 20 * 40);
	CHECK(isinf(rep.min_wall_between_vertical_mm));
	CHECK(isinf(rep.min_wall_between_mm));
	verify_report_fini(&rep);
}

/* A 2 x 2 x 1 speck (4 voxels) 2 px from a cavity: not a cavity. */
static int speck(int i, int j, int k, const void *arg)
{
	(void)arg;
	if (!in_box(i, j, 10, 10, 70, 70))
		return 0;
	if (k >= 3 && k <= 8 && in_box(i, j, 20, 20, 40, 60))
		return 0;
	if (k == 5 && in_box(i, j, 42, 30, 44, 32))
		return 0;
	return 1;
}

static void test_speck_is_no_cavity(void)
{
	struct verify_report rep;

	run_stack(speck, NULL, 12, &rep);
	CHECK_EQ_INT(rep.specks, 1);
	CHECK(isinf(rep.min_wall_between_mm));
	verify_report_fini(&rep);
}

/* Random discs (centres, radii in pixels) in the box, layers 3..8. */
#define NDISC 5
struct discs {
	double cx[NDISC], cy[NDISC], r[NDISC];
};

static int in_disc(const struct discs *d, int q, int i, int j)
{
	double dx = i - d->cx[q], dy = j - d->cy[q];
	return dx * dx + dy * dy <= d->r[q] * d->r[q];
}

static int discs(int i, int j, int k, const void *arg)
{
	const struct discs *d = arg;

	if (!in_box(i, j, 5, 5, 75, 75))
		return 0;
	if (k < 3 || k > 8)
		return 1;
	for (int q = 0; q < NDISC; q++)
		if (in_disc(d, q, i, j))
			return 0;
	return 1;
}

static void test_random_discs(void)
{
	int trials = 0;

	while (trials < 30) {
		struct discs d;
		struct verify_report rep;
		double best = INFINITY;
		int ok = 1;
		for (int q = 0; q < NDISC; q++) {
			d.r[q] = 2 + (double)(xs() % 600) / 100;
			d.cx[q] = 15 + d.r[q] + (double)(xs() % 4000) / 100;
			d.cy[q] = 15 + d.r[q] + (double)(xs() % 4000) / 100;
		}
		/* brute force: the nearest pixel pair of two discs; discs that
		 * touch or overlap (one cavity) make the draw void */
		for (int a = 0; a < NDISC && ok; a++)
			for (int b = a + 1; b < NDISC && ok; b++) {
				double m2 = INFINITY;
				for (int j = 0; j < N; j++)
					for (int i = 0; i < N; i++) {
						if (!in_disc(&d, a, i, j))
							continue;
						for (int y = 0; y < N; y++)
							for (int x = 0; x < N; x++)
								if (in_disc(&d, b, x, y)) {
									double dx = x - i, dy = y - j;
									m2 = fmin(m2, dx * dx + dy * dy);
								}
					}
				if (m2 <= 2.5 * 2.5)
					ok = 0; /* closer than 1.5 px of wall: may merge */
				best = fmin(best, sqrt(m2));
			}
		if (!ok)
			continue;
		trials++;
		run_stack(discs, &d, 12, &rep);
		/* centre distance less one pixel: never below the true pair
		 * (between.h), and on these 30 draws exactly it */
		CHECK_NUM(rep.min_wall_between_mm, >=, (best - 1) * PX - 1e-9);
		CHECK_NEAR(rep.min_wall_between_mm, (best - 1) * PX, 1e-9);
		verify_report_fini(&rep);
	}
}

/* Fins and slivers: a partition of 1 or 2 columns between the two
 * cavities of `partition` stands free between them except its end pixels,
 * which touch the box's solid: 40 fin pixels a column per layer, of which
 * 38 slivers.  A 3-column partition is no fin. */
static void test_slivers(void)
{
	for (int w = 1; w <= 3; w++) {
		struct part p = {w, 0};
		struct verify_report rep;
		run_stack(partition, &p, 12, &rep);
		CHECK_EQ_INT((int)rep.fin_px, w <= 2 ? 6 * 40 * w : 0);
		CHECK_EQ_INT((int)rep.sliver_px, w <= 2 ? 6 * 38 * w : 0);
		CHECK_NEAR(rep.sliver_mm3, (double)rep.sliver_px * PX * PX * LAYER, 1e-12);
		verify_report_fini(&rep);
	}
}

/* One cavity [20, 60)^2 on layers 3..8 with a pixel bump on its left wall
 * at (20, 40): solid between void above and below it, a fin pixel, but
 * attached along its side to the wall, no sliver. */
static int bump(int i, int j, int k, const void *arg)
{
	(void)arg;
	if (!in_box(i, j, 10, 10, 70, 70))
		return 0;
	if (k < 3 || k > 8 || !in_box(i, j, 20, 20, 60, 60))
		return 1;
	return i == 20 && j == 40;
}

static void test_bump_is_no_sliver(void)
{
	struct verify_report rep;

	run_stack(bump, NULL, 12, &rep);
	CHECK_EQ_INT((int)rep.fin_px, 6);
	CHECK_EQ_INT((int)rep.sliver_px, 0);
	verify_report_fini(&rep);
}

int main(void)
{
	RUN(test_partition);
	RUN(test_joined_is_one_cavity);
	RUN(test_outside_between);
	RUN(test_floor_between);
	RUN(test_shelf_in_one_cavity);
	RUN(test_speck_is_no_cavity);
	RUN(test_random_discs);
	RUN(test_slivers);
	RUN(test_bump_is_no_sliver);
	return harness_report();
}
