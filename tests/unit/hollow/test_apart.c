/* test_apart.c - walls between the fill's voids read in 3D
 * (engine/hollow/fill/apart.c, hl_fill_apart) on synthetic fills of a few
 * layers, every property re-measured here by brute force on pixel masks:
 *  - only void turns solid, and only over solid in the layer below (so the
 *    overhang rule and the islands cannot get worse);
 *  - afterwards no two void pixels of one layer in different 3D components
 *    (8-connected in a layer, linked to the same pixel above and below)
 *    lie closer than wall + 1 px (pixel centres);
 *  - voids far from any other, in the rows of a cut or not, keep every
 *    pixel; pieces of one void, however close, keep every pixel;
 *  - a wall too thin over every layer is cut from its foot up; a wall
 *    along the rows is found (near pairs on two rows only); two squares
 *    touching at a corner are one void;
 *  - the runs stay row-major, disjoint and maximal.
 * Grid: 0.05 mm pixels; wall 0.3 mm, so wall + 1 px = 7 px.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/fill/fill_int.h"

#define W 64
#define H 50
#define NL 3
#define PX 0.05
#define WALL 0.3
#define NP ((size_t)W * H)

/* masks[k][y * W + x]: 1 = void in layer k */
static uint8_t masks[NL][NP], before[NL][NP];

static void rect(int k, int x0, int y0, int x1, int y1)
{
	for (int y = y0; y <= y1; y++)
		for (int x = x0; x <= x1; x++)
			masks[k][(size_t)y * W + (size_t)x] = 1;
}

/* f from masks (runs row-major, as hl_grid_runs makes them). */
static int fill_from_masks(struct hl_fill *f)
{
	struct err e;

	memset(f, 0, sizeof *f);
	f->n = NL;
	f->w = W;
	f->h = H;
	f->layer_mm = 0.05;
	f->layer = mem_calloc(NL, sizeof *f->layer);
	if (!f->layer)
		return 0;
	for (int k = 0; k < NL; k++) {
		size_t cap = 0;
		if (hl_grid_runs(masks[k], W, 0, 0, W, H, &f->layer[k].run, &f->layer[k].n, &cap,
				 &e))
			return 0;
	}
	memcpy(before, masks, sizeof masks);
	return 1;
}

/* masks from f, checking the runs' order on the way; 0 when out of order */
static int masks_from_fill(const struct hl_fill *f)
{
	int ok = 1;

	memset(masks, 0, sizeof masks);
	for (int k = 0; k < NL; k++) {
		const struct hl_fill_layer *L = &f->layer[k];
		for (size_t i = 0; i < L->n; i++) {
			const struct hl_span *r = &L->run[i];
			if (i && !(L->run[i - 1].y < r->y ||
				   (L->run[i - 1].y == r->y && L->run[i - 1].x1 + 1 < r->x0)))
				ok = 0;
			hl_grid_paint(masks[k], W, r, 1, 1);
		}
	}
	return ok;
}

/* 3D components of masks by flood fill: lab[k][i] > 0 on void. */
static int32_t lab[NL][NP];

static void label3d(void)
{
	static int32_t stack[NL * NP];
	int32_t nc = 0;

	memset(lab, 0, sizeof lab);
	for (int k0 = 0; k0 < NL; k0++)
		for (size_t i0 = 0; i0 < NP; i0++) {
			int n = 0;
			if (!masks[k0][i0] || lab[k0][i0])
				continue;
			lab[k0][i0] = ++nc;
			stack[n++] = (int32_t)((size_t)k0 * NP + i0);
			while (n) {
				int32_t v = stack[--n];
				int k = (int)(v / (int32_t)NP), i = (int)(v % (int32_t)NP);
				int x = i % W, y = i / W;
				for (int dz = -1; dz <= 1; dz++)
					for (int dy = -1; dy <= 1; dy++)
						for (int dx = -1; dx <= 1; dx++) {
							int kk = k + dz, xx = x + dx, yy = y + dy;
							size_t j;
							/* 8 in a layer, the same pixel above and below */
							if (dz && (dx || dy))
								continue;
							if (kk < 0 || kk >= NL || xx < 0 || yy < 0 || xx >= W ||
							    yy >= H)
								continue;
							j = (size_t)yy * W + (size_t)xx;
							if (!masks[kk][j] || lab[kk][j])
								continue;
							lab[kk][j] = nc;
							stack[n++] = (int32_t)((size_t)kk * NP + j);
						}
			}
		}
}

/* Smallest centre distance (pixels) between two void pixels of one layer
 * in different components, over all layers; INFINITY when none. */
static double closest_pair_px(void)
{
	double best = INFINITY;

	label3d();
	for (int k = 0; k < NL; k++)
		for (size_t i = 0; i < NP; i++)
			for (size_t j = i + 1; lab[k][i] && j < NP; j++)
				if (lab[k][j] && lab[k][j] != lab[k][i])
					best = fmin(best, hypot((double)((int)(i % W) - (int)(j % W)),
								(double)((int)(i / W) - (int)(j / W))));
	return best;
}

/* Every change turns void solid, over solid in the layer below (after). */
static void check_cuts_held(long *removed)
{
	*removed = 0;
	for (int k = 0; k < NL; k++)
		for (size_t i = 0; i < NP; i++) {
			CHECK(!(masks[k][i] && !before[k][i]));
			if (before[k][i] && !masks[k][i]) {
				(*removed)++;
				CHECK(k == 0 || !masks[k - 1][i]);
			}
		}
}

static int same_rect(int k, int x0, int y0, int x1, int y1)
{
	for (int y = y0; y <= y1; y++)
		for (int x = x0; x <= x1; x++)
			if (masks[k][(size_t)y * W + (size_t)x] != before[k][(size_t)y * W + (size_t)x])
				return 0;
	return 1;
}

static void run_apart(struct hl_fill *f, long *cut, long *left)
{
	struct err e;

	err_clear(&e);
	REQUIRE_OK(hl_fill_apart(f, WALL, PX, PX, 1, cut, left, &e), &e);
	CHECK(masks_from_fill(f));
}

/* The pass on masks as they are: nothing to cut, nothing left, every
 * pixel as it was. */
static void expect_untouched(void)
{
	struct hl_fill f;
	long cut, left;

	REQUIRE(fill_from_masks(&f));
	run_apart(&f, &cut, &left);
	CHECK_EQ_INT(cut, 0);
	CHECK_EQ_INT(left, 0);
	CHECK(!memcmp(masks, before, sizeof masks));
	hl_fill_fini(&f);
}

/* Two voids born side by side in the top layer, 4 px apart (centres),
 * each over its own narrower void below; a third void in rows outside
 * the cut and a fourth beside the cut's rows, both far from the rest. */
static void test_births_side_by_side(void)
{
	struct hl_fill f;
	long cut, left, removed;
	double d;

	memset(masks, 0, sizeof masks);
	rect(2, 5, 5, 20, 30); /* A */
	rect(2, 24, 5, 40, 30); /* B */
	for (int k = 0; k < 2; k++) {
		rect(k, 5, 5, 14, 30);
		rect(k, 30, 5, 40, 30);
	}
	rect(2, 50, 40, 55, 45); /* C: rows 40..45, 10 px from A and B */
	rect(1, 50, 40, 55, 45);
	rect(2, 56, 10, 60, 12); /* D: in the cut's rows, 16 px right of B */
	REQUIRE(fill_from_masks(&f));
	CHECK_NUM(closest_pair_px(), <, 7);
	run_apart(&f, &cut, &left);
	d = closest_pair_px();
	CHECK_NUM(d, >=, WALL / PX + 1 - 1e-9);
	check_cuts_held(&removed);
	CHECK_EQ_INT(removed, cut);
	CHECK_NUM(cut, >, 0);
	CHECK_EQ_INT(left, 0);
	/* about half the wall from each side, not the whole wall from one:
	 * cut nearer than (wall + 1 px) / 2 + 1/2 px = 4 px to the pixels
	 * astride the boundary, x 21 .. 23 here (x 22 is as near to A as to
	 * B, and the tie goes either way from row to row): A keeps x <= 17,
	 * B x >= 28, 11 px apart where 7 are needed */
	CHECK(masks[2][(size_t)15 * W + 18] == 0 && masks[2][(size_t)15 * W + 27] == 0);
	CHECK(masks[2][(size_t)15 * W + 17] == 1 && masks[2][(size_t)15 * W + 28] == 1);
	CHECK(d <= 7 + 4);
	CHECK(same_rect(2, 50, 40, 55, 45) && same_rect(1, 50, 40, 55, 45));
	CHECK(same_rect(2, 56, 10, 60, 12));
	CHECK(same_rect(0, 0, 0, W - 1, H - 1) && same_rect(1, 0, 0, W - 1, H - 1));
	hl_fill_fini(&f);
}

/* Two pieces of the top layer 3 px apart that are one void (joined in
 * the layer below) stay as they are. */
static void test_one_void_untouched(void)
{
	memset(masks, 0, sizeof masks);
	rect(2, 5, 5, 20, 30);
	rect(2, 24, 5, 40, 30);
	rect(1, 5, 5, 40, 30);
	rect(0, 5, 5, 40, 30);
	expect_untouched();
}

/* Two voids 3 px apart in every layer: cut in layer 0 (the plate
 * below), then each layer above over the solid the cut left. */
static void test_wall_cut_from_foot(void)
{
	struct hl_fill f;
	long cut, left, removed;

	memset(masks, 0, sizeof masks);
	for (int k = 0; k < NL; k++) {
		rect(k, 5, 5, 20, 30);
		rect(k, 24, 5, 40, 30);
	}
	REQUIRE(fill_from_masks(&f));
	run_apart(&f, &cut, &left);
	CHECK_NUM(closest_pair_px(), >=, WALL / PX + 1 - 1e-9);
	check_cuts_held(&removed);
	CHECK_EQ_INT(removed, cut);
	CHECK_EQ_INT(left, 0);
	hl_fill_fini(&f);
}

/* A's near pixels stand over A's own void below (cannot be cut): B
 * alone gives way, over the rounds, until the wall is whole. */
static void test_one_side_held(void)
{
	struct hl_fill f;
	long cut, left, removed;

	memset(masks, 0, sizeof masks);
	rect(2, 5, 5, 20, 30); /* A */
	rect(1, 5, 5, 20, 30);
	rect(0, 5, 5, 20, 30);
	rect(2, 24, 5, 40, 30); /* B: the top layer only */
	REQUIRE(fill_from_masks(&f));
	run_apart(&f, &cut, &left);
	check_cuts_held(&removed);
	CHECK_EQ_INT(removed, cut);
	CHECK(same_rect(2, 5, 5, 20, 30)); /* A whole */
	CHECK_NUM(closest_pair_px(), >=, WALL / PX + 1 - 1e-9);
	CHECK_EQ_INT(left, 0); /* within the rounds, the boundary moved off A */
	hl_fill_fini(&f);
}

/* Two voids one above the other in the grid (a wall along the rows):
 * every near pair lies on two different rows. */
static void test_wall_along_rows(void)
{
	struct hl_fill f;
	long cut, left, removed;

	memset(masks, 0, sizeof masks);
	rect(2, 5, 5, 40, 15);
	rect(2, 5, 19, 40, 30);
	for (int k = 0; k < 2; k++) {
		rect(k, 5, 5, 40, 12);
		rect(k, 5, 23, 40, 30);
	}
	REQUIRE(fill_from_masks(&f));
	CHECK_NUM(closest_pair_px(), <, 7);
	run_apart(&f, &cut, &left);
	CHECK_NUM(closest_pair_px(), >=, WALL / PX + 1 - 1e-9);
	check_cuts_held(&removed);
	CHECK_EQ_INT(removed, cut);
	CHECK_NUM(cut, >, 0);
	CHECK_EQ_INT(left, 0);
	hl_fill_fini(&f);
}

/* Two squares of the top layer that touch at one corner are one void
 * (8-connected, as the verifier reads it): nothing is cut, though each
 * goes down on its own. */
static void test_corner_is_one_void(void)
{
	memset(masks, 0, sizeof masks);
	for (int k = 0; k < NL; k++) {
		rect(k, 5, 5, 15, 15);
		rect(k, 16, 16, 26, 26);
	}
	rect(0, 5, 30, 9, 34); /* far: 15 rows from both */
	expect_untouched();
}

int main(void)
{
	RUN(test_births_side_by_side);
	RUN(test_one_void_untouched);
	RUN(test_wall_cut_from_foot);
	RUN(test_one_side_held);
	RUN(test_wall_along_rows);
	RUN(test_corner_is_one_void);
	return harness_report();
}
