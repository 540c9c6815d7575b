/* test_path_clip.c - integer paths and the Clipper shim. */
#include <string.h>

#include "harness.h"

#include "engine/core/err.h"
#include "engine/geom/clip.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"

static void square(struct paths *ps, double x0, double y0, double s, int ccw)
{
	struct pt2 p[4] = {{geom_mm_to_nm(x0), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x0 + s), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x0 + s), geom_mm_to_nm(y0 + s)},
			   {geom_mm_to_nm(x0), geom_mm_to_nm(y0 + s)}};
	paths_add_pts(ps, p, 4);
	if (!ccw)
		path_reverse(&ps->v[ps->n - 1]);
}

static void test_area_winding(void)
{
	struct paths ps;

	paths_init(&ps);
	square(&ps, 0, 0, 10, 1);
	square(&ps, 2, 2, 2, 0); /* hole */
	CHECK_NEAR(paths_area_mm2(&ps), 100 - 4, 1e-9);
	CHECK_EQ_INT(paths_winding(&ps, (struct pt2){geom_mm_to_nm(1), geom_mm_to_nm(1)}), 1);
	CHECK_EQ_INT(paths_winding(&ps, (struct pt2){geom_mm_to_nm(3), geom_mm_to_nm(3)}), 0);
	CHECK_EQ_INT(paths_winding(&ps, (struct pt2){geom_mm_to_nm(11), geom_mm_to_nm(3)}), 0);
	CHECK_EQ_INT(paths_winding(&ps, (struct pt2){geom_mm_to_nm(10), geom_mm_to_nm(3)}), 1);
	CHECK_NEAR(paths_distance_mm(&ps, (struct pt2){geom_mm_to_nm(5), geom_mm_to_nm(3)}), 1,
		   1e-9);
	CHECK_NEAR(path_length_mm(&ps.v[0], 1), 40, 1e-9);
	paths_fini(&ps);
}

/* Brute force for paths_hole_owners: every outer loop tested against
 * every hole's first point by winding, no boxes. */
static size_t owner_brute(const struct paths *ps, size_t i)
{
	size_t best = SIZE_MAX;

	if (path_area2_nm2(&ps->v[i]) >= 0)
		return SIZE_MAX;
	for (size_t j = 0; j < ps->n; j++) {
		struct paths one = {&ps->v[j], 1, 1};
		if (path_area2_nm2(&ps->v[j]) <= 0 || !paths_winding(&one, ps->v[i].pts[0]))
			continue;
		if (best == SIZE_MAX || path_area2_nm2(&ps->v[j]) < path_area2_nm2(&ps->v[best]))
			best = j;
	}
	return best;
}

static void test_hole_owners(void)
{
	struct paths ps;
	size_t owner[64];

	paths_init(&ps);
	square(&ps, 0, 0, 10, 0);    /* 0: hole of 1 */
	square(&ps, -5, -5, 40, 1);  /* 1: outer */
	square(&ps, 2, 2, 4, 1);     /* 2: island inside hole 0 */
	square(&ps, 3, 3, 1, 0);     /* 3: hole of 2, not of 1 */
	square(&ps, 50, 50, 2, 0);   /* 4: a hole no loop holds */
	square(&ps, 20, 20, 10, 1);  /* 5: a second island of 1's */
	square(&ps, 24, 20, 2, 0);   /* 6: its hole touching its edge (on-edge first point) */
	paths_add(&ps);              /* 7: empty */
	/* a row of small islands, each with a hole: the many-voids layer */
	for (int k = 0; k < 20; k++) {
		square(&ps, -4.5 + 1.5 * k, 32, 1.2, 1);
		square(&ps, -4.4 + 1.5 * k, 32.1, 0.5, 0);
	}
	CHECK_EQ_INT(paths_hole_owners(&ps, NULL, owner), 0);
	CHECK(owner[0] == 1);
	CHECK(owner[1] == SIZE_MAX && owner[2] == SIZE_MAX && owner[5] == SIZE_MAX);
	CHECK(owner[3] == 2);
	CHECK(owner[4] == SIZE_MAX);
	CHECK(owner[6] == 5);
	CHECK(owner[7] == SIZE_MAX);
	for (size_t i = 0; i < ps.n; i++)
		CHECK(owner[i] == owner_brute(&ps, i));
	for (size_t k = 0; k < 20; k++)
		CHECK(owner[9 + 2 * k] == 8 + 2 * k);
	/* measured once, given: the same owners; each measure as the path's
	 * own area and box, and path_holds as the winding test */
	{
		struct path_measure m[64];
		size_t owner2[64];
		paths_measure(&ps, m);
		CHECK_EQ_INT(paths_hole_owners(&ps, m, owner2), 0);
		for (size_t i = 0; i < ps.n; i++) {
			struct paths one = {&ps.v[i], 1, 1};
			struct pt2 lo, hi;
			CHECK(owner2[i] == owner[i]);
			CHECK_NEAR(path_measure_mm2(&m[i]), path_area_mm2(&ps.v[i]), 0);
			if (paths_bbox(&one, &lo, &hi))
				CHECK(m[i].lo.x == lo.x && m[i].lo.y == lo.y && m[i].hi.x == hi.x &&
				      m[i].hi.y == hi.y);
			else
				CHECK(m[i].lo.x > m[i].hi.x); /* the empty path: no box */
		}
		CHECK_NEAR(path_measure_mm2(&m[1]), 1600, 1e-9);
		CHECK_NEAR(path_measure_mm2(&m[0]), -100, 1e-9);
		for (int k = 0; k < 200; k++) {
			/* points on a grid over the layer, the on-edge ones too */
			struct pt2 q = {geom_mm_to_nm(-6 + 0.25 * (k % 20) * 3),
					geom_mm_to_nm(-6 + 0.25 * (k / 20) * 3)};
			for (size_t i = 0; i < ps.n; i++) {
				struct paths one = {&ps.v[i], 1, 1};
				CHECK_EQ_INT(path_holds(&ps.v[i], &m[i], q),
					     ps.v[i].n > 0 && paths_winding(&one, q) != 0);
			}
		}
		CHECK_EQ_INT(path_holds(&ps.v[1], &m[1], ps.v[1].pts[0]), 1);
		CHECK_EQ_INT(path_holds(&ps.v[7], &m[7], (struct pt2){0, 0}), 0);
	}
	paths_fini(&ps);
}

static void test_clip(void)
{
	struct paths a, b, out;
	struct err e;

	paths_init(&a);
	paths_init(&b);
	paths_init(&out);
	err_clear(&e);
	square(&a, 0, 0, 10, 1);
	square(&b, 5, 5, 10, 0); /* CW input: nonzero union still sees it as filled */
	REQUIRE_OK(clip_union(&b, CLIP_FILL_NONZERO, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 100, 1e-9); /* normalised to CCW */
	paths_fini(&b);
	paths_init(&b);
	square(&b, 5, 5, 10, 1);
	REQUIRE_OK(clip_boolean(CLIP_UNION, &a, &b, CLIP_FILL_NONZERO, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 175, 1e-9);
	REQUIRE_OK(clip_boolean(CLIP_INTERSECTION, &a, &b, CLIP_FILL_NONZERO, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 25, 1e-9);
	REQUIRE_OK(clip_boolean(CLIP_DIFFERENCE, &a, &b, CLIP_FILL_NONZERO, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 75, 1e-9);
	/* inward offset of a 10 mm square by 1 mm: an 8 mm square */
	REQUIRE_OK(clip_offset(&a, -1e6, CLIP_JOIN_MITER, 2, 0, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 64, 1e-6);
	/* outward round offset: 100 + 4*10*1 + pi (within arc tolerance) */
	REQUIRE_OK(clip_offset(&a, 1e6, CLIP_JOIN_ROUND, 0, 1000, &out, &e), &e);
	CHECK_NEAR(paths_area_mm2(&out), 140 + M_PI, 0.01);
	/* line clipping */
	{
		struct paths lines;
		struct pt2 l[2] = {{geom_mm_to_nm(-5), geom_mm_to_nm(5)},
				   {geom_mm_to_nm(15), geom_mm_to_nm(5)}};
		paths_init(&lines);
		paths_add_pts(&lines, l, 2);
		REQUIRE_OK(clip_lines(&lines, &a, &out, &e), &e);
		CHECK_EQ_INT(out.n, 1);
		CHECK_NEAR(path_length_mm(&out.v[0], 0), 10, 1e-9);
		paths_fini(&lines);
	}
	paths_fini(&a);
	paths_fini(&b);
	paths_fini(&out);
}

/* raster_row_span against a plain scan, on rows of every length 1..40
 * with one or two marks at every place (values under, at and over the
 * threshold) */
static void test_row_span(void)
{
	uint8_t row[40];
	int a = -7, b = -7;

	memset(row, 0, sizeof row);
	CHECK_EQ_INT(raster_row_span(row, 40, 128, &a, &b), 0);
	CHECK(a == -7 && b == -7);
	for (int w = 1; w <= 40; w++)
		for (int i = 0; i < w; i++)
			for (int j = i; j < w; j++)
				for (int v = 0; v < 3; v++) {
					int ea = -1, eb = -1, got;
					memset(row, 0, sizeof row);
					row[i] = v == 0 ? 127 : v == 1 ? 128 : 255;
					row[j] = 200;
					if (w < 40)
						row[w] = 255; /* past the row: unread */
					for (int x = 0; x < w; x++)
						if (row[x] >= 128) {
							ea = ea < 0 ? x : ea;
							eb = x;
						}
					got = raster_row_span(row, w, 128, &a, &b);
					CHECK_EQ_INT(got, ea >= 0);
					if (got)
						CHECK(a == ea && b == eb);
				}
}

static void test_raster_map(void)
{
	/* 0.05 mm pixels, column = x / 0.05, row = (10 - y) / 0.05 */
	struct raster_map m = {{{20, 0}, {0, -20}}, {0, 200}};
	double u, v, x, y;

	raster_map_apply(&m, 1.0, 2.0, &u, &v);
	CHECK_NEAR(u, 20, 1e-12);
	CHECK_NEAR(v, 160, 1e-12);
	CHECK_EQ_INT(raster_map_invert(&m, u, v, &x, &y), 0);
	CHECK_NEAR(x, 1.0, 1e-12);
	CHECK_NEAR(y, 2.0, 1e-12);
	CHECK_NEAR(raster_map_pixel_area_mm2(&m), 0.0025, 1e-15);
}

int main(void)
{
	RUN(test_area_winding);
	RUN(test_hole_owners);
	RUN(test_clip);
	RUN(test_row_span);
	RUN(test_raster_map);
	return harness_report();
}
