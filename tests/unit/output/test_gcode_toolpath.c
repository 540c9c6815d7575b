/* test_gcode_toolpath.c - the planner's pieces (toolpath*.c) and the
 * formatter's numbers (gcode_format.c, gcode_spool.c): flow maths, time
 * model, scanline infill, edge index, perimeter offsets, thin walls,
 * skins, ordering, the move cursor. */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/output/gcode/gcode_int.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/toolpath/toolpath.h"
#include "engine/output/toolpath/toolpath_int.h"

static void rect(struct paths *ps, double x0, double y0, double x1, double y1, int ccw)
{
	struct pt2 p[4] = {{geom_mm_to_nm(x0), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y1)},
			   {geom_mm_to_nm(x0), geom_mm_to_nm(y1)}};
	paths_add_pts(ps, p, 4);
	if (!ccw)
		path_reverse(&ps->v[ps->n - 1]);
}

static struct pt2 P(double x, double y)
{
	return (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)};
}

static void test_flow_maths(void)
{
	/* Slic3r: s = w - h (1 - pi/4); area = (w - h) h + pi h^2 / 4 = h s */
	int64_t s = tp_spacing_nm(450000, 0.2);

	CHECK_NEAR(geom_nm_to_mm(s), 0.45 - 0.2 * (1 - M_PI / 4), 1e-6);
	CHECK_NEAR(tp_bead_area_mm2(0.45, 0.2), 0.05 + M_PI * 0.01, 1e-12);
	CHECK_NEAR(tp_bead_area_mm2(0.45, 0.2), 0.2 * geom_nm_to_mm(s), 1e-6);
	/* a round bead (w = h) is a circle */
	CHECK_NEAR(tp_bead_area_mm2(0.3, 0.3), M_PI * 0.15 * 0.15, 1e-12);
}

static void fmt_is(int64_t v, int dec, const char *want)
{
	char b[32];

	b[gc_fmt_fixed(b, v, dec)] = '\0';
	CHECK_STR(b, want);
}

static void test_number_format(void)
{
	char b[32];

	fmt_is(12345, 3, "12.345");
	fmt_is(12300, 3, "12.3");
	fmt_is(12000, 3, "12");
	fmt_is(5, 3, "0.005");
	fmt_is(0, 3, "0");
	fmt_is(-800, 5, "-0.008");
	fmt_is(-80000, 5, "-0.8");
	fmt_is(220000, 3, "220");
	fmt_is(7, 0, "7");
	fmt_is(INT64_MIN, 0, "-9223372036854775808");
	b[gc_fmt_mm(b, 0.2)] = '\0';
	CHECK_STR(b, "0.2");
	b[gc_fmt_mm(b, 1.0005)] = '\0';
	CHECK_STR(b, "1.001");
	b[gc_m73(b, 30, 120)] = '\0';
	CHECK_STR(b, "M73 P25 R2\n");
	b[gc_m73(b, 120, 120)] = '\0';
	CHECK_STR(b, "M73 P100 R0\n");
}

static double one_move_time(double L, double v, double a, double j)
{
	struct tp_motion m;
	double t;

	tp_motion_init(&m, a, j);
	tp_motion_move(&m, L, 0, 0, v, 1, NULL);
	tp_motion_stop(&m, 0);
	t = m.time_s;
	tp_motion_fini(&m);
	return t;
}

static void test_time_model(void)
{
	struct tp_motion m;

	/* trapezoid from rest to rest: L/v + v/a */
	CHECK_NEAR(one_move_time(100, 50, 1000, 0), 100.0 / 50 + 50.0 / 1000, 1e-9);
	/* triangle: never reaches v, peak sqrt(a L) */
	CHECK_NEAR(one_move_time(1, 100, 1000, 0), 2 * sqrt(1000.0 * 1) / 1000, 1e-9);
	/* jerk lets it start and stop at j */
	CHECK_NEAR(one_move_time(100, 50, 1000, 10),
		   (100 - 2 * (50.0 * 50 - 100) / 2000) / 50 + 2 * 40.0 / 1000, 1e-9);
	/* collinear pieces plan like one move */
	tp_motion_init(&m, 1000, 0);
	for (int i = 0; i < 10; i++)
		tp_motion_move(&m, 10, 0, 0, 50, 1, NULL);
	tp_motion_stop(&m, 0.5);
	CHECK_NEAR(m.time_s, 100.0 / 50 + 50.0 / 1000 + 0.5, 1e-9);
	CHECK_NEAR(m.extrude_s, 100.0 / 50 + 50.0 / 1000, 1e-9);
	tp_motion_fini(&m);
	/* a right-angle corner slows to jerk / sqrt(2) */
	tp_motion_init(&m, 1000, 8);
	tp_motion_move(&m, 50, 0, 0, 50, 0, NULL);
	tp_motion_move(&m, 0, 50, 0, 50, 0, NULL);
	tp_motion_stop(&m, 0);
	{
		double vj = 8 / sqrt(2.0), v0 = 8;
		double one = (50 - (2500 - v0 * v0) / 2000 - (2500 - vj * vj) / 2000) / 50 +
			     (50 - v0) / 1000 + (50 - vj) / 1000;
		CHECK_NEAR(m.time_s, 2 * one, 1e-9);
		CHECK_NUM(m.time_s, >, 2.0);
	}
	CHECK_NUM(m.extrude_s, ==, 0);
	tp_motion_fini(&m);
}

static double total_len(const struct tp_plan *p)
{
	double l = 0;

	for (size_t i = 0; i < p->npaths; i++)
		for (size_t k = 1; k < p->paths[i].n; k++)
			l += geom_nm_to_mm((int64_t)tp_dist_nm(p->pts[p->paths[i].first + k - 1],
							       p->pts[p->paths[i].first + k]));
	return l;
}

static void test_scanline_fill(void)
{
	struct paths sq;
	struct tp_plan p;
	struct err e;

	paths_init(&sq);
	tp_plan_init(&p);
	err_clear(&e);
	rect(&sq, 0, 0, 10, 10, 1);
	/* lines at y = m + 1/2: ten of 10 mm */
	REQUIRE_OK(tp_fill_lines(&sq, 0, 1000000, 0, TP_ROLE_SOLID, 450000, &p, &e), &e);
	CHECK_EQ_INT(p.npaths, 10);
	CHECK_NEAR(total_len(&p), 100, 1e-6);
	CHECK_EQ_INT(p.pts[0].y, 500000);
	/* the grid is fixed to the origin: shifting the area keeps the lines */
	tp_plan_reset(&p);
	paths_clear(&sq);
	rect(&sq, 0.3, 0.3, 10.3, 10.3, 1);
	REQUIRE_OK(tp_fill_lines(&sq, 0, 1000000, 0, TP_ROLE_SOLID, 450000, &p, &e), &e);
	CHECK_EQ_INT(p.npaths, 10);
	CHECK_EQ_INT(p.pts[0].y, 500000);
	CHECK_EQ_INT(p.pts[0].x, 300000);
	/* a hole splits the lines through it */
	tp_plan_reset(&p);
	paths_clear(&sq);
	rect(&sq, 0, 0, 10, 10, 1);
	rect(&sq, 3, 3, 6, 6, 0);
	REQUIRE_OK(tp_fill_lines(&sq, 0, 1000000, 0, TP_ROLE_SOLID, 450000, &p, &e), &e);
	CHECK_EQ_INT(p.npaths, 13);
	CHECK_NEAR(total_len(&p), 100 - 9, 1e-6);
	/* 45 degrees: total length = area / spacing up to one line */
	tp_plan_reset(&p);
	paths_clear(&sq);
	rect(&sq, 0, 0, 10, 10, 1);
	REQUIRE_OK(tp_fill_lines(&sq, M_PI / 4, 500000, 0, TP_ROLE_SPARSE, 450000, &p, &e), &e);
	CHECK_NEAR(total_len(&p), 100 / 0.5, 10 * sqrt(2.0));
	/* pieces shorter than the minimum are dropped */
	tp_plan_reset(&p);
	REQUIRE_OK(tp_fill_lines(&sq, M_PI / 4, 500000, 3000000, TP_ROLE_SPARSE, 450000, &p, &e), &e);
	for (size_t i = 0; i < p.npaths; i++)
		CHECK_NUM(tp_dist_nm(p.pts[2 * i], p.pts[2 * i + 1]), >=, 3000000 - 2);
	tp_plan_fini(&p);
	paths_fini(&sq);
}

static void test_edge_index(void)
{
	struct paths sq;
	struct tp_index ix;
	struct err e;
	struct pt2 q;

	paths_init(&sq);
	err_clear(&e);
	rect(&sq, 0, 0, 10, 10, 1);
	rect(&sq, 3, 3, 6, 6, 0);
	REQUIRE_OK(tp_index_build(&ix, &sq, &e), &e);
	CHECK(tp_index_inside(&ix, P(1, 1)));
	CHECK(!tp_index_inside(&ix, P(4, 4)));
	CHECK(!tp_index_inside(&ix, P(11, 4)));
	CHECK(!tp_index_inside(&ix, P(-1, 4)));
	CHECK(tp_index_inside(&ix, P(10, 4))); /* on an edge */
	CHECK(tp_index_crosses(&ix, P(1, 4), P(8, 4)));  /* through the hole */
	CHECK(!tp_index_crosses(&ix, P(1, 1), P(9, 1)));
	CHECK(!tp_index_crosses(&ix, P(1, 1), P(3, 1))); /* touching the hole's corner line */
	CHECK(tp_index_segment_inside(&ix, P(1, 1), P(9, 2)));
	CHECK(!tp_index_segment_inside(&ix, P(1, 4), P(8, 4)));
	CHECK(tp_index_nearest(&ix, P(4.5, 2.5), 1000000, &q));
	CHECK_NEAR(geom_nm_to_mm(q.y), 3, 1e-6);
	CHECK(!tp_index_nearest(&ix, P(1.5, 1.5), 1000000, &q));
	CHECK(tp_index_first_hit(&ix, P(1, 4), P(9, 4), 0, &q));
	CHECK_NEAR(geom_nm_to_mm(q.x), 3, 1e-6);
	tp_index_fini(&ix);
	paths_fini(&sq);
}

static struct tp_config config(void)
{
	struct tp_config c;
	struct err e;

	err_clear(&e);
	tp_config_init(&c, &printer_fdm_profiles[0].fdm, 0.2, &e);
	return c;
}

/* Layer `index` with exposures top[0..ntop) and bottom[0..nbottom). */
static void layer_in(struct tp_layer_in *in, const struct paths *reg, int index, int count,
		     const struct paths **top, int ntop, const struct paths **bottom, int nbottom)
{
	memset(in, 0, sizeof *in);
	in->index = index;
	in->count = count;
	in->height_mm = 0.2;
	in->fill = LAYER_FILL_PART;
	in->region = reg;
	in->top = top;
	in->bottom = bottom;
	in->ntop = ntop;
	in->nbottom = nbottom;
}

/* Distance of every vertex of the plan's paths with this role from the
 * square [0,20]^2's outline. */
static void role_depth(const struct tp_plan *p, enum tp_role r, double *lo, double *hi)
{
	*lo = 1e9;
	*hi = -1;
	for (size_t i = 0; i < p->npaths; i++) {
		if (p->paths[i].role != r)
			continue;
		for (size_t k = 0; k < p->paths[i].n; k++) {
			struct pt2 q = p->pts[p->paths[i].first + k];
			double x = geom_nm_to_mm(q.x), y = geom_nm_to_mm(q.y);
			double d = fmin(fmin(x, 20 - x), fmin(y, 20 - y));
			*lo = fmin(*lo, d);
			*hi = fmax(*hi, d);
		}
	}
}

static void test_perimeters_and_order(void)
{
	struct tp_config c = config();
	struct paths sq, none;
	const struct paths *nb[10], *own[1];
	struct tp_layer_in in;
	struct tp_plan p;
	struct err e;
	double lo, hi, s = 0.45 - 0.2 * (1 - M_PI / 4);
	int seen_ext = 0, order_ok = 1;

	paths_init(&sq);
	tp_plan_init(&p);
	err_clear(&e);
	paths_init(&none);
	rect(&sq, 0, 0, 20, 20, 1);
	for (int i = 0; i < 10; i++)
		nb[i] = &none; /* prismatic: no exposures */
	layer_in(&in, &sq, 5, 20, nb, 5, nb + 5, 4);
	c.skirt_loops = 0;
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	role_depth(&p, TP_ROLE_EXT_PERIMETER, &lo, &hi);
	CHECK_NEAR(lo, 0.225, 1e-6);
	CHECK_NEAR(hi, 0.225, 1e-6);
	role_depth(&p, TP_ROLE_PERIMETER, &lo, &hi);
	CHECK_NEAR(lo, 0.225 + s, 1e-6);
	/* the neighbours are identical: no skins, sparse only */
	for (size_t i = 0; i < p.npaths; i++) {
		CHECK(p.paths[i].role != TP_ROLE_SOLID && p.paths[i].role != TP_ROLE_TOP);
		if (p.paths[i].role == TP_ROLE_EXT_PERIMETER)
			seen_ext = 1;
		if (p.paths[i].role == TP_ROLE_PERIMETER && seen_ext)
			order_ok = 0; /* inner loop after the outer one */
	}
	CHECK(order_ok);
	role_depth(&p, TP_ROLE_SPARSE, &lo, &hi);
	CHECK_NUM(lo, >=, 0.225 + 1.5 * s - 1e-6);
	/* outer loop first when asked */
	c.external_first = 1;
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	CHECK_EQ_INT(p.paths[0].role, TP_ROLE_EXT_PERIMETER);
	/* nothing above: the whole layer is exposed, a top skin */
	own[0] = &sq;
	layer_in(&in, &sq, 19, 20, own, 1, nb + 5, 4);
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	{
		/* solid lines s apart cover the fill area: length = area / s */
		double side = 20 - 2 * (0.225 + 1.5 * s), len = 0;
		for (size_t i = 0; i < p.npaths; i++)
			if (p.paths[i].role == TP_ROLE_TOP)
				for (size_t k = 1; k < p.paths[i].n; k++)
					len += tp_dist_nm(p.pts[p.paths[i].first + k - 1],
							  p.pts[p.paths[i].first + k]) / 1e6;
		CHECK_REL(len, side * side / s, 0.08);
	}
	role_depth(&p, TP_ROLE_SPARSE, &lo, &hi);
	CHECK_NUM(hi, <, 0);
	tp_plan_fini(&p);
	paths_fini(&sq);
	paths_fini(&none);
}

static void test_travel_retraction(void)
{
	struct tp_config c = config();
	struct paths two, none;
	const struct paths *nb[10];
	struct tp_layer_in in;
	struct tp_plan p;
	struct err e;
	int islands_entered = 0;

	paths_init(&two);
	tp_plan_init(&p);
	err_clear(&e);
	rect(&two, 0, 0, 5, 5, 1);
	rect(&two, 5.5, 0, 10.5, 5, 1); /* 0.5 mm away: a short travel over air */
	paths_init(&none);
	for (int i = 0; i < 10; i++)
		nb[i] = &none;
	layer_in(&in, &two, 5, 20, nb, 5, nb + 5, 4);
	c.skirt_loops = 0;
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	for (size_t i = 1; i < p.npaths; i++) {
		struct pt2 a, b = p.pts[p.paths[i].first];
		const struct tp_path *pv = &p.paths[i - 1];
		a = pv->closed ? p.pts[pv->first] : p.pts[pv->first + pv->n - 1];
		if ((a.x < 5250000) != (b.x < 5250000)) {
			islands_entered++;
			CHECK(p.paths[i].retract); /* crosses the outline */
		} else if (tp_dist_nm(a, b) > 1000000) {
			CHECK(p.paths[i].retract); /* longer than min_travel_retract */
		} else {
			CHECK(!p.paths[i].retract);
		}
	}
	/* island by island: the gap is crossed once */
	CHECK_EQ_INT(islands_entered, 1);
	tp_plan_fini(&p);
	paths_fini(&two);
	paths_fini(&none);
}

static void test_thin_pieces(void)
{
	struct paths pc;
	struct tp_plan p;
	struct err e;

	paths_init(&pc);
	tp_plan_init(&p);
	err_clear(&e);
	rect(&pc, 10, 10, 10.3, 20, 1);   /* 0.3 wide */
	rect(&pc, 12, 10, 12.12, 20, 1);  /* 0.12: below the 0.2 minimum */
	REQUIRE_OK(tp_thin(&pc, TP_ROLE_EXT_PERIMETER, 200000, 800000, &p, &e), &e);
	CHECK_EQ_INT(p.thin_regions, 1);
	CHECK_EQ_INT(p.thin_dropped, 1);
	CHECK_NEAR(p.thin_dropped_mm2, 1.2, 1e-6);
	REQUIRE(p.npaths == 1);
	for (size_t k = 0; k < p.paths[0].n; k++) {
		struct pt2 q = p.pts[p.paths[0].first + k];
		CHECK_NEAR(geom_nm_to_mm(q.x), 10.15, 0.002); /* on the centreline */
		if (k + 1 < p.paths[0].n) {
			double w = geom_nm_to_mm(tp_seg_width(&p, &p.paths[0], k));
			CHECK_NUM(w, <=, 0.3 + 1e-9);
			CHECK_NUM(w, >=, 0.2);
		}
	}
	/* most of the length is printed at the full width */
	CHECK_NUM(geom_nm_to_mm(tp_seg_width(&p, &p.paths[0], (p.paths[0].n - 1) / 2)), ==, 0.3);
	/* a 0.3 mm ring becomes one closed loop */
	tp_plan_reset(&p);
	paths_clear(&pc);
	{
		struct pt2 o[128], h[128];
		for (int k = 0; k < 128; k++) {
			o[k] = P(50 + 5 * cos(2 * M_PI * k / 128), 50 + 5 * sin(2 * M_PI * k / 128));
			h[127 - k] = P(50 + 4.7 * cos(2 * M_PI * k / 128),
				       50 + 4.7 * sin(2 * M_PI * k / 128));
		}
		paths_add_pts(&pc, o, 128);
		paths_add_pts(&pc, h, 128);
	}
	REQUIRE_OK(tp_thin(&pc, TP_ROLE_EXT_PERIMETER, 200000, 800000, &p, &e), &e);
	REQUIRE(p.npaths == 1);
	CHECK(p.paths[0].closed);
	for (size_t k = 0; k < p.paths[0].n; k++) {
		struct pt2 q = p.pts[p.paths[0].first + k];
		CHECK_NEAR(hypot(geom_nm_to_mm(q.x) - 50, geom_nm_to_mm(q.y) - 50), 4.85, 0.01);
	}
	tp_plan_fini(&p);
	paths_fini(&pc);
}

static void test_cursor_and_slowdown(void)
{
	struct tp_config c = config();
	struct fdm_printer f = printer_fdm_profiles[0].fdm;
	struct paths sq, none;
	const struct paths *nb[10];
	struct tp_layer_in in;
	struct tp_plan p;
	struct tp_cursor cu;
	struct tp_ev ev;
	struct err e;
	int kinds[8] = {0};
	double t, te, t2;

	paths_init(&sq);
	tp_plan_init(&p);
	err_clear(&e);
	rect(&sq, 0, 0, 5, 5, 1);
	rect(&sq, 10, 0, 15, 5, 1);
	paths_init(&none);
	for (int i = 0; i < 10; i++)
		nb[i] = &none;
	layer_in(&in, &sq, 5, 20, nb, 5, nb + 5, 4);
	c.skirt_loops = 0;
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	tp_cursor_init(&cu, &p, 1);
	while (tp_cursor_next(&cu, &ev))
		kinds[ev.kind]++;
	CHECK_NUM(kinds[TP_EV_RETRACT], >=, 1);
	CHECK_EQ_INT(kinds[TP_EV_RETRACT], kinds[TP_EV_UNRETRACT]);
	CHECK_EQ_INT(kinds[TP_EV_RETRACT], kinds[TP_EV_HOP_UP]);
	CHECK_EQ_INT(kinds[TP_EV_HOP_UP], kinds[TP_EV_HOP_DOWN]);
	CHECK_EQ_INT(kinds[TP_EV_FEATURE], p.npaths);
	/* two 5 mm squares print in a few seconds: slowed to the minimum
	 * layer time */
	REQUIRE_OK(tp_plan_time(&p, &f, &t, &te, &e), &e);
	CHECK_NUM(t, <, f.min_layer_time_s);
	REQUIRE_OK(tp_plan_slowdown(&p, &f, &t2, &e), &e);
	CHECK_NUM(p.speed_factor, <, 1);
	CHECK_NUM(t2, >, 1.5 * t);
	/* too small to reach 15 s: the slowest features hit the speed floor */
	CHECK_NUM(t2, <, f.min_layer_time_s);
	tp_cursor_init(&cu, &p, 1);
	while (tp_cursor_next(&cu, &ev))
		if (ev.kind == TP_EV_FEATURE)
			CHECK_NUM(ev.speed_mm_s, >=, f.min_print_speed_mm_s - 1e-9);
	/* a larger layer reaches the target exactly enough */
	paths_clear(&sq);
	rect(&sq, 0, 0, 30, 30, 1);
	REQUIRE_OK(tp_plan_layer(&c, &in, &p, &e), &e);
	REQUIRE_OK(tp_plan_time(&p, &f, &t, &te, &e), &e);
	f.min_layer_time_s = 1.3 * t;
	f.min_print_speed_mm_s = 1;
	REQUIRE_OK(tp_plan_slowdown(&p, &f, &t2, &e), &e);
	CHECK_REL(t2, 1.3 * t, 0.05);
	tp_plan_fini(&p);
	paths_fini(&sq);
	paths_fini(&none);
}

static void test_spool(void)
{
	struct gc_spool s;
	struct buf out;
	struct sink sk;
	struct err e;
	char big[3000];

	memset(big, 'x', sizeof big);
	buf_init(&out);
	sink_init_buf(&sk, &out);
	err_clear(&e);
	/* a tiny memory budget forces the file path */
	gc_spool_init(&s, NULL, 1024);
	REQUIRE_OK(gc_spool_text(&s, "a\n", 2, &e), &e);
	REQUIRE_OK(gc_spool_mark(&s, 50, &e), &e);
	REQUIRE_OK(gc_spool_text(&s, big, sizeof big, &e), &e);
	REQUIRE_OK(gc_spool_mark(&s, 100, &e), &e);
	CHECK(s.file != NULL);
	REQUIRE_OK(gc_spool_replay(&s, &sk, 10, 110, &e), &e);
	CHECK_EQ_INT(out.len, 2 + 11 + sizeof big + 12);
	CHECK(out.len > 14 && memcmp(out.data, "a\nM73 P54 R1\nx", 14) == 0);
	CHECK(memcmp(out.data + out.len - 12, "M73 P100 R0\n", 12) == 0);
	gc_spool_fini(&s);
	/* an unusable directory is an I/O error naming it */
	gc_spool_init(&s, "/nonexistent/dir", 16);
	CHECK_EQ_INT(gc_spool_text(&s, big, 100, &e), ERR_IO);
	CHECK_CONTAINS(e.msg, "/nonexistent/dir");
	gc_spool_fini(&s);
	buf_fini(&out);
}

int main(void)
{
	RUN(test_flow_maths);
	RUN(test_number_format);
	RUN(test_time_model);
	RUN(test_scanline_fill);
	RUN(test_edge_index);
	RUN(test_perimeters_and_order);
	RUN(test_travel_retraction);
	RUN(test_thin_pieces);
	RUN(test_cursor_and_slowdown);
	RUN(test_spool);
	return harness_report();
}
