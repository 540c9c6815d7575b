/* test_gcode_write.c - the G-code writer end to end on synthetic layer
 * stacks, verified by the independent checker tests/support/gcodecheck.py
 * (containment in analytic regions, E per move, layer tags, header and
 * footer consistency) plus skins, density, threads, memory, failures.
 */
#include "gcode_fixture.h"

/* Run the writer on st and the checker on its output; returns the
 * checker's status and leaves the summary in fx_tmp(name).sum. */
static int write_and_check(const struct fx_stack *st, const struct printer *pr, int threads,
			   const char *name, struct fx_run *r, const char *extra)
{
	char g[512], j[512], s[512];

	fx_run_init(r, threads);
	if (fx_write(st, pr, r)) {
		fprintf(stderr, "%s: writer failed: %s\n", name, r->e.msg);
		return -1;
	}
	snprintf(g, sizeof g, "%s", fx_tmp(name));
	snprintf(j, sizeof j, "%s.json", g);
	snprintf(s, sizeof s, "%s.sum", g);
	if (fx_save(&r->out, g) || fx_write_json(st, j))
		return -1;
	return fx_check(g, j, s, extra);
}

static const char *sum_of(const char *name)
{
	static char b[512];

	snprintf(b, sizeof b, "%s.sum", fx_tmp(name));
	return b;
}

static double layer_vol(const char *sum, int layer, const char *role)
{
	char k[128];

	snprintf(k, sizeof k, "layer.%d.volume.%s", layer, role);
	return fx_get0(sum, k);
}

/* Sum of all roles but the skirt on one layer. */
static double layer_part_vol(const char *sum, int layer)
{
	static const char *roles[] = {"external_perimeter", "perimeter", "gap_fill", "internal_infill",
				      "solid_infill", "top_solid_infill", "bridge_infill"};
	double v = 0;

	for (size_t i = 0; i < sizeof roles / sizeof roles[0]; i++)
		v += layer_vol(sum, layer, roles[i]);
	return v;
}

static void box_with_hole(struct fx_stack *st, int layers)
{
	struct fx_range *r;

	memset(st, 0, sizeof *st);
	st->layers = layers;
	st->layer_mm = 0.2;
	r = fx_range_add(st, 0, layers - 1);
	fx_rect(r, 90, 90, 120, 120, 0);
	fx_rect(r, 100, 102, 108, 110, 1);
}

static void test_box_with_hole(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	const char *sum = sum_of("box");
	double area = 900 - 64;

	box_with_hole(&st, 25);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "box", &r, "--bed 220,220"), 0);
	/* Bottom skins (4 layers), then sparse, then top skins (5 layers);
	 * nothing is bridged on the bed; the hole runs through, so no skin
	 * forms around it. */
	for (int k = 0; k < 25; k++) {
		double sp = layer_vol(sum, k, "internal_infill");
		double so = layer_vol(sum, k, "solid_infill");
		double top = layer_vol(sum, k, "top_solid_infill");
		double br = layer_vol(sum, k, "bridge_infill");
		if (k < 4 || k >= 20) {
			CHECK_NUM(sp, ==, 0);
			CHECK_NUM(so + top, >, 0);
			/* solid layers deposit about all of the area (Slic3r beads
			 * tile the plane; overlaps at the perimeters add a little) */
			CHECK_REL(layer_part_vol(sum, k), area * 0.2, 0.08);
		} else {
			CHECK_NUM(sp, >, 0);
			CHECK_NUM(so + top, ==, 0);
		}
		CHECK_NUM(br, ==, 0);
		if (k == 24)
			CHECK_NUM(top, >, 0);
		else
			CHECK_NUM(top, ==, 0);
	}
	CHECK_EQ_INT(fx_get(sum, "layers"), 25);
	/* metrics agree with the checker's own sums */
	CHECK_NEAR(fx_metric(&r.m, "gcode.filament_mm"), fx_get(sum, "extruded_e_mm"), 0.006);
	CHECK_NEAR(fx_metric(&r.m, "material_volume_mm3"),
		   fx_get(sum, "extruded_e_mm") * M_PI * 1.75 * 1.75 / 4, 0.02);
	CHECK_EQ_INT(fx_metric(&r.m, "gcode.layers"), 25);
	CHECK_NEAR(fx_metric(&r.m, "gcode.print_time_s"), fx_get(sum, "print_time_s"), 1);
	CHECK_NUM(fx_metric(&r.m, "gcode.retractions"), >=, 25);
	CHECK_NUM(fx_metric(&r.m, "gcode.travel_mm"), >, 0);
	CHECK_NEAR(fx_metric(&r.m, "gcode.travel_mm"), fx_get(sum, "travel_mm"), 1.0);
	CHECK_NEAR(fx_metric(&r.m, "gcode.bytes"), (double)r.out.len, 0);
	CHECK_EQ_INT(fx_metric(&r.m, "gcode.thin_dropped"), 0);
	fx_run_fini(&r);
}

static void test_cylinder_with_cavity(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a, *b, *c;
	const char *sum = sum_of("cyl");

	memset(&st, 0, sizeof st);
	st.layers = 30;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 9);
	fx_circle(a, 110, 110, 12, 0);
	b = fx_range_add(&st, 10, 19); /* closed cavity r = 4 */
	fx_circle(b, 110, 110, 12, 0);
	fx_circle(b, 110, 110, 4, 1);
	c = fx_range_add(&st, 20, 29);
	fx_circle(c, 110, 110, 12, 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "cyl", &r, NULL), 0);
	/* Floor of the cavity: top skin under it (layers 5..9, exposed on 9);
	 * its ceiling bridges on layer 20 and is solid on 21..23. */
	CHECK_NUM(layer_vol(sum, 4, "solid_infill") + layer_vol(sum, 4, "top_solid_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 7, "solid_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 7, "internal_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 9, "top_solid_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 20, "bridge_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 22, "solid_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 24, "solid_infill") + layer_vol(sum, 24, "bridge_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 24, "internal_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 29, "top_solid_infill"), >, 0);
	for (int k = 10; k < 20; k++)
		CHECK_NUM(layer_vol(sum, k, "bridge_infill") + layer_vol(sum, k, "top_solid_infill"), ==,
			  0);
	fx_run_fini(&r);
}

static void test_thin_walls(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *sum = sum_of("thin");

	memset(&st, 0, sizeof st);
	st.layers = 6;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 5);
	fx_rect(a, 100, 100, 100.3, 112, 0);  /* 0.30: one bead */
	fx_rect(a, 103, 100, 103.6, 112, 0);  /* 0.60: too narrow for two loops */
	fx_rect(a, 106, 100, 106.15, 112, 0); /* 0.15: thinner than a layer: dropped */
	fx_circle(a, 120, 106, 5, 0);         /* 0.3 mm ring */
	fx_circle(a, 120, 106, 4.7, 1);
	CHECK_EQ_INT(write_and_check(&st, &pr, 0, "thin", &r, NULL), 0);
	/* Three printable thin pieces and one dropped per layer. */
	CHECK_EQ_INT(fx_metric(&r.m, "gcode.thin_regions"), 3 * 6);
	CHECK_EQ_INT(fx_metric(&r.m, "gcode.thin_dropped"), 6);
	CHECK_NEAR(fx_metric(&r.m, "gcode.thin_dropped_mm2"), 6 * 0.15 * 12, 0.05);
	/* Material of the printed walls (all External perimeter here): the
	 * Slic3r bead of width w holds (w - h(1 - pi/4)) / w of the w x h
	 * rectangle (86% at 0.3 mm, 93% at 0.6 mm); ends fall a little short. */
	for (int k = 1; k < 6; k++) {
		double rect = (0.3 * 12 + 0.6 * 12 + M_PI * (25 - 4.7 * 4.7)) * 0.2;
		double v = layer_vol(sum, k, "external_perimeter");
		CHECK_NUM(v, >, 0.80 * rect);
		CHECK_NUM(v, <, 1.0 * rect);
	}
	fx_run_fini(&r);
}

static void test_islands(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;

	memset(&st, 0, sizeof st);
	st.layers = 8;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 7);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			fx_rect(a, 90 + 7 * i, 90 + 7 * j, 94 + 7 * i, 94 + 7 * j, 0);
	for (int i = 0; i < 4; i++)
		fx_circle(a, 93.5 + 7 * i, 115, 1.5, 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "islands", &r, NULL), 0);
	/* every island is entered by a retracting travel (it leaves material) */
	CHECK_NUM(fx_metric(&r.m, "gcode.retractions"), >=, 8 * 12);
	fx_run_fini(&r);
}

static void test_comb(void)
{
	/* A base with teeth 3, 1.2, 0.8, 0.5 and 0.35 mm wide, one polygon. */
	static const double comb[] = {
		100, 100, 130, 100, 130, 105, 128, 105, 128, 113, 127.65, 113, 127.65, 105,
		123, 105, 123, 113, 122.5, 113, 122.5, 105, 118, 105, 118, 113, 117.2, 113,
		117.2, 105, 112, 105, 112, 113, 110.8, 113, 110.8, 105, 106, 105, 106, 113,
		103, 113, 103, 105, 100, 105};
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *sum = sum_of("comb");

	memset(&st, 0, sizeof st);
	st.layers = 12;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 11);
	fx_poly(a, comb, (int)(sizeof comb / sizeof comb[0] / 2), 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "comb", &r, NULL), 0);
	CHECK_NUM(fx_metric(&r.m, "gcode.thin_regions"), >=, 12 * 2);
	CHECK_EQ_INT(fx_metric(&r.m, "gcode.thin_dropped"), 0);
	/* Everything but the sparse middle is deposited: a solid layer holds
	 * about the comb's area. */
	{
		double area = 30 * 5 + 8 * (3 + 1.2 + 0.8 + 0.5 + 0.35);
		CHECK_REL(layer_part_vol(sum, 1), area * 0.2, 0.10);
	}
	fx_run_fini(&r);
}

static void test_skins_step_and_overhang(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *sum = sum_of("step");

	/* A 30 mm box with a 10 mm box standing on it. */
	memset(&st, 0, sizeof st);
	st.layers = 30;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 14);
	fx_rect(a, 90, 90, 120, 120, 0);
	a = fx_range_add(&st, 15, 29);
	fx_rect(a, 100, 100, 110, 110, 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "step", &r, NULL), 0);
	CHECK_NUM(layer_vol(sum, 7, "solid_infill") + layer_vol(sum, 7, "top_solid_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 12, "solid_infill"), >, 0);       /* under the exposed ring */
	CHECK_NUM(layer_vol(sum, 12, "internal_infill"), >, 0);    /* under the small box */
	CHECK_NUM(layer_vol(sum, 12, "top_solid_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 14, "top_solid_infill"), >, 0);
	for (int k = 15; k < 24; k++) /* standing on the big box: no skins */
		CHECK_NUM(layer_vol(sum, k, "solid_infill") + layer_vol(sum, k, "bridge_infill"), ==, 0);
	fx_run_fini(&r);

	/* The other way up: the big box overhangs the small one. */
	sum = sum_of("mushroom");
	memset(&st, 0, sizeof st);
	st.layers = 20;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 9);
	fx_rect(a, 100, 100, 110, 110, 0);
	a = fx_range_add(&st, 10, 19);
	fx_rect(a, 90, 90, 120, 120, 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "mushroom", &r, NULL), 0);
	CHECK_NUM(layer_vol(sum, 10, "bridge_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 12, "solid_infill"), >, 0);
	CHECK_NUM(layer_vol(sum, 12, "bridge_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 14, "solid_infill") + layer_vol(sum, 14, "bridge_infill"), ==, 0);
	CHECK_NUM(layer_vol(sum, 14, "internal_infill"), >, 0);
	fx_run_fini(&r);
}

static void test_sparse_density(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *sum = sum_of("density");
	double s = 0.45 - 0.2 * (1 - M_PI / 4);
	double side = 60 - 2 * (0.45 / 2 + 1.5 * s); /* the fill area: s/2 inside loop 2 */

	pr.fdm.infill_pct = 20;
	memset(&st, 0, sizeof st);
	st.layers = 14;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 13);
	fx_rect(a, 80, 80, 140, 140, 0);
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "density", &r, NULL), 0);
	for (int k = 4; k <= 8; k++) {
		char key[96];
		double lines, conn;
		snprintf(key, sizeof key, "layer.%d.infill_lines_volume_mm3", k);
		lines = fx_get0(sum, key);
		snprintf(key, sizeof key, "layer.%d.infill_connector_volume_mm3", k);
		conn = fx_get0(sum, key);
		/* lines along the layer's direction hold 20% of the fill area */
		CHECK_REL(lines / (side * side * 0.2), 0.20, 0.05);
		/* the zigzag joins along the border add at most a tenth more */
		CHECK_NUM(conn, <, 0.10 * lines);
		CHECK_NUM(conn, >, 0);
	}
	fx_run_fini(&r);
}

static void test_designed_material_is_solid(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *sum = sum_of("lattice");

	memset(&st, 0, sizeof st);
	st.layers = 6;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 5);
	a->fill = LAYER_FILL_SOLID;
	for (int i = 0; i < 5; i++)
		for (int j = 0; j < 5; j++)
			fx_circle(a, 100 + 3 * i, 100 + 3 * j, 1.2, 0);
	fx_rect(a, 90, 90, 96, 110, 0); /* a solid slab, far from the posts */
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "lattice", &r, NULL), 0);
	for (int k = 0; k < 6; k++) {
		double area = 25 * M_PI * 1.2 * 1.2 + 6 * 20;
		CHECK_NUM(layer_vol(sum, k, "internal_infill"), ==, 0);
		CHECK_REL(layer_part_vol(sum, k), area * 0.2, 0.10);
	}
	fx_run_fini(&r);
}

static void test_threads_identical(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run a, b;

	box_with_hole(&st, 16);
	fx_run_init(&a, 0);
	fx_run_init(&b, 3);
	REQUIRE_OK(fx_write(&st, &pr, &a), &a.e);
	REQUIRE_OK(fx_write(&st, &pr, &b), &b.e);
	CHECK_EQ_INT(a.out.len, b.out.len);
	CHECK(a.out.len == b.out.len && memcmp(a.out.data, b.out.data, a.out.len) == 0);
	fx_run_fini(&a);
	fx_run_fini(&b);
}

/* Peak heap while writing n layers of a 30 mm box, output to a counting
 * sink (so the output itself is not held). */
static int count_write(void *ctx, const void *p, size_t n, struct err *e)
{
	(void)p;
	(void)e;
	*(size_t *)ctx += n;
	return 0;
}

static double peak_for(int layers, size_t *bytes)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct sink s;
	double base, peak;

	box_with_hole(&st, layers);
	pr.fdm.infill_pct = 60; /* a few kB per layer */
	*bytes = 0;
	memset(&s, 0, sizeof s);
	s.write = count_write;
	s.ctx = bytes;
	fx_run_init(&r, 0);
	r.sink = &s;
	r.sample_heap = 1;
	base = fx_heap_bytes();
	fx_write(&st, &pr, &r);
	CHECK_EQ_INT(r.rc, 0);
	peak = r.peak_heap_bytes - base;
	fx_run_fini(&r);
	return peak;
}

static void test_memory_independent_of_layers(void)
{
	size_t b1, b2;
	double p1 = peak_for(60, &b1), p2 = peak_for(600, &b2);

	fprintf(stderr, "memory: %d layers %.0f KiB (output %zu KiB), %d layers %.0f KiB (output %zu "
			"KiB)\n",
		60, p1 / 1024, b1 / 1024, 600, p2 / 1024, b2 / 1024);
	/* ten times the layers and the output, but the same working set: the
	 * body spools to a file past 1 MiB */
	CHECK_NUM((double)b2, >, 8.0 * (double)b1);
	CHECK_NUM((double)b2, >, 2.0 * 1048576);
	CHECK_NUM(p2, <, p1 + 1.5 * 1048576);
}

struct failing {
	size_t left;
};

static int failing_write(void *ctx, const void *p, size_t n, struct err *e)
{
	struct failing *f = ctx;

	(void)p;
	if (n > f->left)
		return ERR_SET(e, ERR_IO, "disk full");
	f->left -= n;
	return 0;
}

static void test_failing_sink(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct failing f = {5000};
	struct sink s;

	box_with_hole(&st, 12);
	memset(&s, 0, sizeof s);
	s.write = failing_write;
	s.ctx = &f;
	fx_run_init(&r, 2);
	r.sink = &s;
	CHECK_EQ_INT(fx_write(&st, &pr, &r), ERR_IO);
	CHECK_CONTAINS(r.e.msg, "disk full");
	fx_run_fini(&r);

	/* an output limit stops the writer while spooling */
	memset(&s, 0, sizeof s);
	f.left = (size_t)-1;
	s.write = failing_write;
	s.ctx = &f;
	s.limit = 20000;
	fx_run_init(&r, 2);
	r.sink = &s;
	CHECK_EQ_INT(fx_write(&st, &pr, &r), ERR_LIMIT);
	CHECK_NUM((double)s.bytes, <=, 20000);
	fx_run_fini(&r);
}

static void test_cancelled_midway(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;

	/* The driver stops feeding layers and frees the writer: nothing
	 * reaches the sink, planned layers in flight are dropped. */
	box_with_hole(&st, 30);
	fx_run_init(&r, 3);
	r.feed_layers = 17;
	CHECK_EQ_INT(fx_write(&st, &pr, &r), 0);
	CHECK_EQ_INT(r.out.len, 0);
	fx_run_fini(&r);
}

static void test_out_of_memory(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	int ok = 0, nomem = 0;

	box_with_hole(&st, 7);
	for (long k = 1; k < 5000 && !ok; k += (k < 200 ? 1 : 7)) {
		struct fx_run r;
		int rc;
		fx_run_init(&r, 0);
		mem_fail_after(k);
		rc = fx_write(&st, &pr, &r);
		mem_fail_after(-1);
		if (rc == 0)
			ok = 1;
		else if (rc == ERR_NOMEM)
			nomem++;
		else {
			fprintf(stderr, "allocation %ld: %s\n", k, r.e.msg);
			CHECK_EQ_INT(rc, ERR_NOMEM);
		}
		fx_run_fini(&r);
	}
	CHECK(ok);
	CHECK_NUM(nomem, >, 50);
}

static void test_bad_input(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer(), resin;
	struct out_info info;
	struct buf b;
	struct sink s;
	struct err e;
	void *state = NULL;
	struct layer ly;

	box_with_hole(&st, 3);
	memset(&resin, 0, sizeof resin);
	snprintf(resin.name, sizeof resin.name, "sl1");
	resin.kind = PRINTER_RESIN;
	memset(&info, 0, sizeof info);
	info.format = OUT_GCODE;
	info.printer = &resin;
	info.layer_mm = 0.2;
	info.layer_count = 3;
	info.threads = 1;
	buf_init(&b);
	sink_init_buf(&s, &b);
	err_clear(&e);
	CHECK_EQ_INT(gcode_writer_ops.open(&info, &s, &state, &e), ERR_PARAM);
	CHECK_STR(e.field, "printer");
	info.printer = &pr;
	info.layer_mm = 0.35; /* > 80% of the 0.4 mm nozzle */
	err_clear(&e);
	CHECK_EQ_INT(gcode_writer_ops.open(&info, &s, &state, &e), ERR_PARAM);
	CHECK_STR(e.field, "layer_mm");
	info.layer_mm = 0.2;
	REQUIRE_OK(gcode_writer_ops.open(&info, &s, &state, &e), &e);
	memset(&ly, 0, sizeof ly);
	ly.index = 1; /* layer 0 never came */
	paths_init(&ly.region);
	CHECK_EQ_INT(gcode_writer_ops.layer(state, &ly, &e), ERR_INTERNAL);
	CHECK_EQ_INT(gcode_writer_ops.close(state, NULL, &e), ERR_INTERNAL);
	gcode_writer_ops.free_state(state);
	CHECK_EQ_INT(b.len, 0);
	buf_fini(&b);
}

/* Header, start and end code, and the printer options that change them. */
static void test_header_and_options(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	char *text;

	box_with_hole(&st, 10);
	pr.fdm.klipper = 1;
	pr.fdm.first_layer_mm = 0.3;
	pr.fdm.z_hop_mm = 0;
	pr.fdm.seam = FDM_SEAM_REAR;
	pr.fdm.external_perimeter_first = 1;
	CHECK_EQ_INT(write_and_check(&st, &pr, 2, "opts", &r, NULL), 0);
	REQUIRE(buf_append(&r.out, "", 1) == 0);
	text = (char *)r.out.data;
	CHECK(strncmp(text, "; generated by infilld ", 23) == 0);
	CHECK_CONTAINS(text, " on 2023-11-14 at 22:13:20 UTC\n");
	CHECK_CONTAINS(text, "\n;FLAVOR:Marlin\n");
	CHECK_CONTAINS(text, "\n;LAYER_COUNT:10\n");
	CHECK_CONTAINS(text, "\n;Layer height: 0.2\n");
	CHECK_CONTAINS(text, "\nM140 S60");
	CHECK_CONTAINS(text, "\nM190 S60");
	CHECK_CONTAINS(text, "\nM104 S215");
	CHECK_CONTAINS(text, "\nM109 S215");
	CHECK_CONTAINS(text, "\nG28");
	CHECK_CONTAINS(text, "\nM83");
	CHECK_CONTAINS(text, "\nG92 E0\n");
	CHECK_CONTAINS(text, "\nSET_PRINT_STATS_INFO TOTAL_LAYER=10\n");
	CHECK_CONTAINS(text, "\nSET_PRINT_STATS_INFO CURRENT_LAYER=1\n");
	CHECK_CONTAINS(text, ";LAYER:0\nM73 P");
	CHECK_CONTAINS(text, "\n;Z:0.3\n;HEIGHT:0.3\n;LAYER:0\n");
	CHECK_CONTAINS(text, "\n;Z:0.5\n;HEIGHT:0.2\n;LAYER:1\n");
	CHECK_CONTAINS(text, "\nM106 S255\n");
	CHECK_CONTAINS(text, "\nM84");
	CHECK_CONTAINS(text, "\nM73 P100 R0\n");
	CHECK_CONTAINS(text, "\n; first_layer_height = 0.3\n");
	CHECK_CONTAINS(text, "\n; filament_type = PLA\n");
	CHECK(strstr(text, "; thumbnail begin") == NULL); /* no mesh: no thumbnail */
	/* external loop first: in each layer the first loop is external */
	{
		const char *l1 = strstr(text, ";LAYER:3\n");
		REQUIRE(l1);
		l1 = strstr(l1, ";TYPE:");
		REQUIRE(l1);
		CHECK(strncmp(l1, ";TYPE:External perimeter", 24) == 0);
	}
	fx_run_fini(&r);
}

/* The checker's mesh mode: the same box given as an OFF mesh it slices
 * itself; shifted by 0.3 mm the check must fail. */
static void test_checker_mesh_mode(void)
{
	struct fx_stack st;
	struct printer pr = fx_printer();
	struct fx_run r;
	struct fx_range *a;
	const char *off = fx_tmp("box.off"), *g = fx_tmp("meshbox"), *s = fx_tmp("meshbox.sum");
	FILE *f;
	char extra[700];

	memset(&st, 0, sizeof st);
	st.layers = 15;
	st.layer_mm = 0.2;
	a = fx_range_add(&st, 0, 14);
	fx_rect(a, 90, 90, 120, 120, 0);
	f = fopen(off, "w");
	REQUIRE(f);
	fprintf(f, "OFF\n8 6 0\n90 90 0\n120 90 0\n120 120 0\n90 120 0\n90 90 3\n120 90 3\n"
		   "120 120 3\n90 120 3\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n"
		   "4 3 0 4 7\n");
	fclose(f);
	fx_run_init(&r, 2);
	REQUIRE_OK(fx_write(&st, &pr, &r), &r.e);
	REQUIRE(fx_save(&r.out, g) == 0);
	snprintf(extra, sizeof extra, "--mesh '%s' --quiet", off);
	CHECK_EQ_INT(fx_check(g, NULL, s, extra), 0);
	snprintf(extra, sizeof extra, "--mesh '%s' --mesh-translate 0.3,0,0 --quiet 2>/dev/null", off);
	CHECK_EQ_INT(fx_check(g, NULL, s, extra), 1);
	CHECK_NUM(fx_get(s, "errors.containment"), >, 0);
	fx_run_fini(&r);
}

int main(void)
{
	RUN(test_box_with_hole);
	RUN(test_cylinder_with_cavity);
	RUN(test_thin_walls);
	RUN(test_islands);
	RUN(test_comb);
	RUN(test_skins_step_and_overhang);
	RUN(test_sparse_density);
	RUN(test_designed_material_is_solid);
	RUN(test_threads_identical);
	RUN(test_memory_independent_of_layers);
	RUN(test_failing_sink);
	RUN(test_cancelled_midway);
	RUN(test_out_of_memory);
	RUN(test_bad_input);
	RUN(test_header_and_options);
	RUN(test_checker_mesh_mode);
	if (!getenv("KEEP")) fx_tmp_clean();
	return harness_report();
}
