/* test_opt_steps.c - the optimiser's first steps (engine/hollow/opt/,
 * opt_int.h), each on synthetic input whose answer is known in closed
 * form (strips, voids and the start: test_opt_strip.c):
 *  - contour.c: a square region becomes one counter-clockwise loop of
 *    vertices at most s apart with the area of the square opened by s
 *    (100 - (4 - pi) s^2 mm^2); a square with a square hole one simple
 *    loop (a slit of slit_mm opens the hole) of area outer - hole - slit;
 *    a neck narrower than 2 s is opened (two loops), a wider one is kept
 *    (one loop); regions under min_area_mm2 or thinner than 2 s vanish;
 *  - group.c: rectangles whose overlaps are computed by hand link by the
 *    paper's three rules (section 7.1);
 *  - poles.c: on a circle the shifting directions point at the centre and
 *    the bounds are the radius; on an 8 x 4 mm rectangle they point at the
 *    medial axis (y = 2 from the long sides, the disc touching three sides
 *    from the short ones); hl_bounds_smooth against eq. 10 by hand.
 * Frame: printer frame, mm, z up; loops counter-clockwise, the void on
 * their left.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/geom/path.h"
#include "engine/hollow/opt/opt_int.h"
#include "loopgen.h"

/* ---- helpers ---- */

/* Axis-aligned rectangle (mm) appended to a region; ccw 0: a hole. */
static void rect_path(struct paths *ps, double x0, double y0, double x1, double y1, int ccw)
{
	struct pt2 p[4] = {{geom_mm_to_nm(x0), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y1)},
			   {geom_mm_to_nm(x0), geom_mm_to_nm(y1)}};

	if (paths_add_pts(ps, p, 4) == 0 && !ccw)
		path_reverse(&ps->v[ps->n - 1]);
}

/* Shoelace area (mm^2) of xy (n points). */
static double shoelace(const double *xy, size_t n)
{
	double a = 0;

	for (size_t i = 0; i < n; i++) {
		size_t j = (i + 1) % n;
		a += xy[2 * i] * xy[2 * j + 1] - xy[2 * j] * xy[2 * i + 1];
	}
	return 0.5 * a;
}

static void slice_fini(struct hl_slice *s)
{
	for (size_t i = 0; i < s->n; i++)
		hl_loop_fini(&s->loop[i]);
	mem_free(s->loop);
	memset(s, 0, sizeof *s);
}

/* ---- contour.c ---- */

/* Common checks of one contour loop: counter-clockwise, slice and z set,
 * area_mm2 its shoelace area, steps at most s (chords of an arc at most
 * s long), simple, every vertex inside the box lo..hi (the opening lies
 * inside the region). */
static void check_loop(const struct hl_loop *L, double s, int slice, double z, double x0,
		       double y0, double x1, double y1)
{
	double maxstep = 0;

	CHECK_EQ_INT(L->slice, slice);
	CHECK_NEAR(L->z_mm, z, 0);
	CHECK_NUM(L->n, >=, 6);
	CHECK_NEAR(L->area_mm2, shoelace(L->xy, L->n), 1e-9);
	CHECK_NUM(L->area_mm2, >, 0);
	for (size_t i = 0; i < L->n; i++) {
		size_t j = (i + 1) % L->n;
		maxstep = fmax(maxstep, hypot(L->xy[2 * j] - L->xy[2 * i],
					      L->xy[2 * j + 1] - L->xy[2 * i + 1]));
		CHECK(L->xy[2 * i] >= x0 - 1e-6 && L->xy[2 * i] <= x1 + 1e-6);
		CHECK(L->xy[2 * i + 1] >= y0 - 1e-6 && L->xy[2 * i + 1] <= y1 + 1e-6);
	}
	CHECK_NUM(maxstep, <=, s + 1e-6);
	CHECK(is_simple(L->xy, L->n));
}

static void test_contour_square(void)
{
	struct hl_contour_params cp = {0.25, 0.8, 4 * 0.25 * 0.25};
	struct paths reg;
	struct hl_slice out;
	struct err e;
	double s = cp.spacing_mm, per, dmax = 0;

	paths_init(&reg);
	memset(&out, 0, sizeof out);
	err_clear(&e);
	rect_path(&reg, 0, 0, 10, 10, 1);
	REQUIRE_OK(hl_contours_from_region(&reg, 3, 1.75, &cp, &out, &e), &e);
	REQUIRE(out.n == 1);
	check_loop(&out.loop[0], s, 3, 1.75, 0, 0, 10, 10);
	/* the opening by s rounds the four corners with radius s:
	 * 100 - (4 - pi) s^2; the samples lie on that boundary (convex), so
	 * the loop is no larger, and chords of at most s cut at most s^2 / 2
	 * off each corner (a generous floor) */
	CHECK_NUM(out.loop[0].area_mm2, <=, 100 - (4 - M_PI) * s * s + 1e-6);
	CHECK_NUM(out.loop[0].area_mm2, >=, 100 - (4 - M_PI) * s * s - 4 * 0.5 * s * s);
	/* vertices on the opened boundary: within (1 - 1/sqrt 2) s of a side
	 * at the rounded corners, plus the arc polygon's deviation from the
	 * true arc (contour.c's arc tolerance, 0.05 s) */
	for (size_t i = 0; i < out.loop[0].n; i++) {
		double x = out.loop[0].xy[2 * i], y = out.loop[0].xy[2 * i + 1];
		dmax = fmax(dmax, fmin(fmin(x, 10 - x), fmin(y, 10 - y)));
	}
	CHECK_NUM(dmax, <=, (1 - M_SQRT1_2) * s + 0.05 * s);
	/* one uniform chain round the perimeter 40 - (8 - 2 pi) s, in steps
	 * of at most s: ceil(perimeter / s) vertices (the arcs are polygons,
	 * a vertex either way) */
	per = 40 - (8 - 2 * M_PI) * s;
	CHECK_NUM(out.loop[0].n, >=, ceil(per / s) - 1);
	CHECK_NUM(out.loop[0].n, <=, ceil(per / s) + 1);
	slice_fini(&out);
	paths_fini(&reg);
}

static void test_contour_hole_slit(void)
{
	struct hl_contour_params cp = {0.25, 0.8, 0.25};
	struct paths reg;
	struct hl_slice out;
	struct err e;
	double s = cp.spacing_mm, w = cp.slit_mm, expect;
	const struct hl_loop *L;

	paths_init(&reg);
	memset(&out, 0, sizeof out);
	err_clear(&e);
	rect_path(&reg, 0, 0, 10, 10, 1);
	rect_path(&reg, 3, 3, 7, 7, 0); /* the hole, clockwise */
	REQUIRE_OK(hl_contours_from_region(&reg, 0, 0.25, &cp, &out, &e), &e);
	/* genus 0: the O becomes one C, no separate hole loop */
	REQUIRE(out.n == 1);
	L = &out.loop[0];
	check_loop(L, s, 0, 0.25, 0, 0, 10, 10);
	/* the slit [xt - w/2, xt + w/2] x [7 - w/2, oo) from a top corner of
	 * the hole (xt = 3 or 7; the hole's concave corners survive the
	 * opening) removes 3 w above the hole and (w/2)^2 beside its corner:
	 * area = 100 - (4 - pi) s^2 - 16 - 3 w - w^2 / 4, less what chords cut
	 * off the convex corners (at most s^2 / 4 each at a right angle; the
	 * four rounded ones and four of the slit's) */
	expect = 100 - (4 - M_PI) * s * s - 16 - 3 * w - 0.25 * w * w;
	CHECK_NUM(L->area_mm2, <=, expect + 1e-3);
	CHECK_NUM(L->area_mm2, >=, expect - 8 * 0.5 * s * s);
	/* the hole and the slit are outside the loop, the ring inside */
	CHECK(!point_in(L->xy, L->n, 5, 5));
	CHECK(point_in(L->xy, L->n, 1.5, 5));
	CHECK(point_in(L->xy, L->n, 8.5, 5));
	CHECK(point_in(L->xy, L->n, 5, 1.5));
	CHECK(point_in(L->xy, L->n, 5, 8.5));
	CHECK(!point_in(L->xy, L->n, 3, 8.5) || !point_in(L->xy, L->n, 7, 8.5));
	CHECK(point_in(L->xy, L->n, 3, 8.5) || point_in(L->xy, L->n, 7, 8.5));
	slice_fini(&out);
	paths_fini(&reg);
}

static void test_contour_neck(void)
{
	struct hl_contour_params cp = {0.25, 0.8, 0.25};
	struct paths reg, u;
	struct hl_slice out;
	struct err e;
	double s = cp.spacing_mm, a0 = 16 - (4 - M_PI) * s * s;
	double nub = s - sqrt(s * s - 0.15 * 0.15) + 1e-6;

	/* two 4 x 4 squares joined by a 1 mm long neck 0.3 mm wide (< 2 s):
	 * the opening removes the neck, two rounded squares remain, each with
	 * a nub where the neck was: the eroded square reaches within
	 * sqrt(s^2 - 0.15^2) of the neck's side, so the opening pokes out
	 * s - sqrt(s^2 - 0.15^2) = 0.05 mm past the square's side */
	paths_init(&reg);
	paths_init(&u);
	memset(&out, 0, sizeof out);
	err_clear(&e);
	rect_path(&reg, 0, 0, 4, 4, 1);
	rect_path(&reg, 5, 0, 9, 4, 1);
	rect_path(&reg, 3.9, 1.85, 5.1, 2.15, 1);
	REQUIRE_OK(clip_union(&reg, CLIP_FILL_NONZERO, &u, &e), &e);
	REQUIRE(u.n == 1);
	REQUIRE_OK(hl_contours_from_region(&u, 1, 0.75, &cp, &out, &e), &e);
	REQUIRE(out.n == 2);
	for (size_t i = 0; i < 2; i++) {
		const struct hl_loop *L = &out.loop[i];
		double cx = 0;
		for (size_t j = 0; j < L->n; j++)
			cx += L->xy[2 * j] / (double)L->n;
		if (cx < 4.5)
			check_loop(L, s, 1, 0.75, 0, 0, 4 + nub, 4);
		else
			check_loop(L, s, 1, 0.75, 5 - nub, 0, 9, 4);
		CHECK_NUM(L->area_mm2, <=, a0 + nub * 0.3);
		CHECK_NUM(L->area_mm2, >=, a0 - 2 * s * s);
	}
	slice_fini(&out);
	paths_fini(&reg);
	paths_fini(&u);
	/* the same with a neck 1 mm wide (> 2 s): one loop, 16 + 16 + 1 less
	 * the eight rounded convex corners, (1 - pi/4) s^2 each (the neck's
	 * corners are concave: the opening keeps them) */
	paths_init(&reg);
	paths_init(&u);
	rect_path(&reg, 0, 0, 4, 4, 1);
	rect_path(&reg, 5, 0, 9, 4, 1);
	rect_path(&reg, 3.9, 1.5, 5.1, 2.5, 1);
	REQUIRE_OK(clip_union(&reg, CLIP_FILL_NONZERO, &u, &e), &e);
	REQUIRE_OK(hl_contours_from_region(&u, 1, 0.75, &cp, &out, &e), &e);
	REQUIRE(out.n == 1);
	check_loop(&out.loop[0], s, 1, 0.75, 0, 0, 9, 4);
	CHECK_NUM(out.loop[0].area_mm2, <=, 33 - 2 * (4 - M_PI) * s * s + 1e-3);
	CHECK_NUM(out.loop[0].area_mm2, >=, 33 - 2 * (4 - M_PI) * s * s - 8 * s * s / 4);
	CHECK(point_in(out.loop[0].xy, out.loop[0].n, 4.5, 2));
	slice_fini(&out);
	paths_fini(&reg);
	paths_fini(&u);
}

static void test_contour_small_dropped(void)
{
	struct hl_contour_params cp = {0.25, 0.8, 2.0};
	struct paths reg;
	struct hl_slice out;
	struct err e;

	paths_init(&reg);
	memset(&out, 0, sizeof out);
	err_clear(&e);
	/* 1 x 1 mm (0.95 mm^2 after the opening): under 2 mm^2, dropped; a
	 * 3 x 3 beside it is kept */
	rect_path(&reg, 0, 0, 1, 1, 1);
	rect_path(&reg, 5, 0, 8, 3, 1);
	REQUIRE_OK(hl_contours_from_region(&reg, 0, 0.25, &cp, &out, &e), &e);
	REQUIRE(out.n == 1);
	CHECK_NUM(out.loop[0].xy[0], >=, 5 - 1e-6);
	slice_fini(&out);
	/* with min_area 0.5 mm^2 both; a second call appends */
	cp.min_area_mm2 = 0.5;
	REQUIRE_OK(hl_contours_from_region(&reg, 0, 0.25, &cp, &out, &e), &e);
	CHECK_EQ_INT(out.n, 2);
	REQUIRE_OK(hl_contours_from_region(&reg, 1, 0.75, &cp, &out, &e), &e);
	REQUIRE(out.n == 4);
	CHECK_EQ_INT(out.loop[1].slice, 0);
	CHECK_EQ_INT(out.loop[3].slice, 1);
	CHECK_NEAR(out.loop[0].area_mm2 + out.loop[1].area_mm2,
		   out.loop[2].area_mm2 + out.loop[3].area_mm2, 1e-12);
	slice_fini(&out);
	paths_fini(&reg);
	/* a strip 0.4 mm wide (< 2 s) of 10 mm^2 vanishes in the opening,
	 * whatever min_area */
	paths_init(&reg);
	cp.min_area_mm2 = 0;
	rect_path(&reg, 0, 0, 25, 0.4, 1);
	REQUIRE_OK(hl_contours_from_region(&reg, 0, 0.25, &cp, &out, &e), &e);
	CHECK_EQ_INT(out.n, 0);
	slice_fini(&out);
	paths_fini(&reg);
}

/* ---- group.c ---- */

static void test_loop_overlap(void)
{
	struct hl_loop a, b;
	struct err e;
	double ov = -1;

	err_clear(&e);
	rect_loop(&a, 0, 0, 10, 10, 0.5, 0, 0);
	rect_loop(&b, 2, 3, 12, 13, 0.5, 0, 1);
	REQUIRE(a.xy && b.xy);
	REQUIRE_OK(hl_loop_overlap_mm2(&a, &b, &ov, &e), &e);
	CHECK_NEAR(ov, 8 * 7, 1e-6);
	hl_loop_fini(&b);
	rect_loop(&b, 11, 0, 12, 10, 0.5, 0, 1);
	REQUIRE_OK(hl_loop_overlap_mm2(&a, &b, &ov, &e), &e);
	CHECK_NEAR(ov, 0, 1e-9);
	hl_loop_fini(&a);
	hl_loop_fini(&b);
}

/* Slices of rectangles {x0, y0, x1, y1} (mm). */
static void make_slices(struct hl_slice *sl, size_t ns, const double (*const *r)[4],
			const size_t *nr)
{
	for (size_t k = 0; k < ns; k++) {
		sl[k].loop = mem_calloc(nr[k] + 1, sizeof *sl[k].loop);
		sl[k].n = sl[k].cap = nr[k];
		for (size_t i = 0; i < nr[k]; i++)
			rect_loop(&sl[k].loop[i], r[k][i][0], r[k][i][1], r[k][i][2], r[k][i][3],
				  0.5, 0.25 + 0.5 * (double)k, (int)k);
	}
}

static void test_group_rules(void)
{
	/* column A shifts 2 mm then 3 mm (overlaps 80 and 70 of 100: linked);
	 * column B shifts 6 mm (40 of 100 < 50 %: not linked) then stays
	 * (100: linked); E (16 mm^2) lies wholly inside F (100) above it, 100 %
	 * of E but 16 % of F: not linked.  Loops listed out of column order. */
	static const double s0[2][4] = {{0, 0, 10, 10}, {20, 0, 30, 10}};
	static const double s1[3][4] = {{26, 0, 36, 10}, {2, 0, 12, 10}, {40, 0, 44, 4}};
	static const double s2[3][4] = {{40, 0, 50, 10}, {5, 0, 15, 10}, {26, 0, 36, 10}};
	const double(*const r[3])[4] = {s0, s1, s2};
	const size_t nr[3] = {2, 3, 3};
	struct hl_slice sl[3];
	struct err e;
	int **up = NULL;

	err_clear(&e);
	make_slices(sl, 3, r, nr);
	REQUIRE_OK(hl_group_links(sl, 3, 0.5, &up, &e), &e);
	CHECK_EQ_INT(up[0][0], 1);  /* A0 -> A1 */
	CHECK_EQ_INT(up[0][1], -1); /* B0 -/- B1: 40 % */
	CHECK_EQ_INT(up[1][0], 2);  /* B1 -> B2 */
	CHECK_EQ_INT(up[1][1], 1);  /* A1 -> A2 */
	CHECK_EQ_INT(up[1][2], -1); /* E -/- F: 16 % of F */
	for (size_t a = 0; a < 3; a++)
		CHECK_EQ_INT(up[2][a], -1); /* the top slice links nowhere */
	hl_links_free(up, 3);
	/* at ratio 0.15 E joins F (16 % of F), and B0 joins B1 (40 %) */
	REQUIRE_OK(hl_group_links(sl, 3, 0.15, &up, &e), &e);
	CHECK_EQ_INT(up[0][1], 0);
	CHECK_EQ_INT(up[1][2], 0);
	CHECK_EQ_INT(up[1][1], 1);
	hl_links_free(up, 3);
	for (size_t k = 0; k < 3; k++)
		slice_fini(&sl[k]);
}

static void test_group_best_mutual(void)
{
	/* slice 0: P = [0,10]x[0,6] (60 mm^2), Q = [0,10]x[6.2,10] (38); slice
	 * 1: R = [0,10]^2 (100); slice 2: C = [0,10]x[0,3] (30), D =
	 * [0,10]x[3.2,10] (68).  At ratio 0.3 every pair passes rule 2
	 * (overlaps 60, 38; 30, 68: at least 30 % of both).  Rule 3: R's best
	 * below is P (60 > 38), so Q stays unlinked although R is Q's best;
	 * R's best above is D (68 > 30). */
	static const double s0[2][4] = {{0, 6.2, 10, 10}, {0, 0, 10, 6}};
	static const double s1[1][4] = {{0, 0, 10, 10}};
	static const double s2[2][4] = {{0, 0, 10, 3}, {0, 3.2, 10, 10}};
	const double(*const r[3])[4] = {s0, s1, s2};
	const size_t nr[3] = {2, 1, 2};
	struct hl_slice sl[3];
	struct err e;
	int **up = NULL;

	err_clear(&e);
	make_slices(sl, 3, r, nr);
	REQUIRE_OK(hl_group_links(sl, 3, 0.3, &up, &e), &e);
	CHECK_EQ_INT(up[0][0], -1); /* Q */
	CHECK_EQ_INT(up[0][1], 0);  /* P -> R */
	CHECK_EQ_INT(up[1][0], 1);  /* R -> D */
	hl_links_free(up, 3);
	/* at 0.5: P (60 % of R) still links; D is 68 % of R: R -> D; Q 38 %: no */
	REQUIRE_OK(hl_group_links(sl, 3, 0.5, &up, &e), &e);
	CHECK_EQ_INT(up[0][0], -1);
	CHECK_EQ_INT(up[0][1], 0);
	CHECK_EQ_INT(up[1][0], 1);
	hl_links_free(up, 3);
	/* at 0.65: P is 60 % of R, D 68 %: only R -> D */
	REQUIRE_OK(hl_group_links(sl, 3, 0.65, &up, &e), &e);
	CHECK_EQ_INT(up[0][1], -1);
	CHECK_EQ_INT(up[1][0], 1);
	hl_links_free(up, 3);
	for (size_t k = 0; k < 3; k++)
		slice_fini(&sl[k]);
}

/* ---- poles.c ---- */

static void test_poles_circle(void)
{
	enum { N = 64 };
	double xy[2 * N], dir[2 * N], ub[N], R = 5, cx = 1, cy = 2;
	struct err e;

	err_clear(&e);
	for (int j = 0; j < N; j++) {
		xy[2 * j] = cx + R * cos(2 * M_PI * j / N);
		xy[2 * j + 1] = cy + R * sin(2 * M_PI * j / N);
	}
	REQUIRE_OK(hl_poles(xy, N, dir, ub, &e), &e);
	for (int j = 0; j < N; j++) {
		double rx = (cx - xy[2 * j]) / R, ry = (cy - xy[2 * j + 1]) / R;
		CHECK_NEAR(hypot(dir[2 * j], dir[2 * j + 1]), 1, 1e-9);
		CHECK_NUM(dir[2 * j] * rx + dir[2 * j + 1] * ry, >, 0.9999);
		/* every Voronoi corner of cocircular samples is the centre */
		CHECK_NEAR(ub[j], R, 1e-3);
	}
}

static void test_poles_rectangle(void)
{
	struct hl_loop L;
	struct err e;
	double *dir, *ub;
	size_t nb = 0, ns = 0;

	err_clear(&e);
	rect_loop(&L, 0, 0, 8, 4, 0.25, 0, 0);
	dir = mem_alloc(2 * L.n * sizeof *dir);
	ub = mem_alloc(L.n * sizeof *ub);
	REQUIRE(L.xy && dir && ub);
	REQUIRE_OK(hl_poles(L.xy, L.n, dir, ub, &e), &e);
	for (size_t j = 0; j < L.n; j++) {
		double x = L.xy[2 * j], y = L.xy[2 * j + 1];
		double px = x + ub[j] * dir[2 * j], py = y + ub[j] * dir[2 * j + 1];
		CHECK_NEAR(hypot(dir[2 * j], dir[2 * j + 1]), 1, 1e-9);
		/* the pole lies in the rectangle */
		CHECK(px > -1e-6 && px < 8 + 1e-6 && py > -1e-6 && py < 4 + 1e-6);
		if (y == 0 && x >= 2.5 && x <= 5.5) {
			/* long side, the medial axis' straight part: the pole at
			 * (x +- s/2, 2), up */
			CHECK_NUM(dir[2 * j + 1], >=, 0.99);
			CHECK_NUM(ub[j], >=, 2 - 1e-6);
			CHECK_NUM(ub[j], <=, hypot(2, 0.125) + 1e-6);
			nb++;
		}
		if (x == 0 && y >= 1 && y <= 3) {
			/* short side: the largest disc touching (0, y) has
			 * radius min(y, 4 - y) and its centre straight in */
			CHECK_NUM(dir[2 * j], >=, 0.99);
			CHECK_NEAR(ub[j], fmin(y, 4 - y), 0.25);
			ns++;
		}
	}
	CHECK_EQ_INT(nb, 13);
	CHECK_EQ_INT(ns, 9);
	mem_free(dir);
	mem_free(ub);
	hl_loop_fini(&L);
}

static void test_bounds_smooth(void)
{
	/* eq. 10 by hand, one Jacobi pass (each from the old neighbours):
	 * ub'_j = min(ub_j, (ub_{j-1} + ub_{j+1}) / 2), cyclic */
	double a[8] = {2, 2, 2, 6, 2, 2, 1, 2};
	const double ea[8] = {2, 2, 2, 2, 2, 1.5, 1, 1.5};
	double b[8] = {1, 3, 3, 3, 3, 3, 3, 3};
	const double eb[8] = {1, 2, 3, 3, 3, 3, 3, 2};
	double tmp[8], c[40], c0[40];
	uint64_t rng = 0x9e3779b97f4a7c15ULL;

	hl_bounds_smooth(a, 8, tmp);
	hl_bounds_smooth(b, 8, tmp);
	for (int j = 0; j < 8; j++) {
		CHECK_NEAR(a[j], ea[j], 1e-15);
		CHECK_NEAR(b[j], eb[j], 1e-15);
	}
	/* random bounds: never raised, never above a neighbour mean, one of
	 * the two */
	for (int j = 0; j < 40; j++)
		c[j] = c0[j] = (double)(harness_xorshift64(&rng) % 1000) / 100;
	{
		double t2[40];
		hl_bounds_smooth(c, 40, t2);
	}
	for (int j = 0; j < 40; j++) {
		double avg = 0.5 * (c0[(j + 39) % 40] + c0[(j + 1) % 40]);
		CHECK_NUM(c[j], <=, c0[j]);
		CHECK_NUM(c[j], <=, avg + 1e-12);
		CHECK(c[j] == c0[j] || fabs(c[j] - avg) < 1e-12);
	}
}

int main(void)
{
	RUN(test_contour_square);
	RUN(test_contour_hole_slit);
	RUN(test_contour_neck);
	RUN(test_contour_small_dropped);
	RUN(test_loop_overlap);
	RUN(test_group_rules);
	RUN(test_group_best_mutual);
	RUN(test_poles_circle);
	RUN(test_poles_rectangle);
	RUN(test_bounds_smooth);
	return harness_report();
}
