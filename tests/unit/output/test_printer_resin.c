/* test_printer_resin.c - resin profiles, their override table and
 * checks, the printer-mm -> pixel map against REFERENCE.md's formula,
 * and the config.ini helpers (jobDir, exposure schedule, time model).
 */
#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/resin/resin_int.h"
#include "harness.h"

static const struct printer *profile(const char *name)
{
	for (size_t i = 0; i < printer_resin_profile_count; i++)
		if (strcmp(printer_resin_profiles[i].name, name) == 0)
			return &printer_resin_profiles[i];
	return NULL;
}

/* PrusaSlicer 2.5's values (PrusaResearch.ini, PrintConfig.cpp defaults). */
static void test_profiles(void)
{
	const struct printer *sl1 = profile("sl1"), *sl1s = profile("sl1s");
	struct err e;

	REQUIRE(sl1 && sl1s && profile("generic-resin"));
	CHECK_STR(sl1->resin.model, "SL1");
	CHECK_EQ_INT(sl1->resin.pixels_x, 2560);
	CHECK_EQ_INT(sl1->resin.pixels_y, 1440);
	CHECK_NUM(sl1->resin.display_w_mm, ==, 120.96);
	CHECK_NUM(sl1->resin.display_h_mm, ==, 68.04);
	CHECK_EQ_INT(sl1->resin.portrait, 1);
	CHECK_EQ_INT(sl1->resin.mirror_x, 1);
	CHECK_EQ_INT(sl1->resin.mirror_y, 0);
	CHECK_NUM(sl1->resin.max_z_mm, ==, 150);
	CHECK_STR(sl1s->resin.model, "SL1S");
	CHECK_NUM(sl1s->resin.display_w_mm / sl1s->resin.pixels_x, ==, 0.05);
	CHECK_NUM(sl1s->resin.display_h_mm / sl1s->resin.pixels_y, ==, 0.05);
	CHECK_NUM(printer_resin_extent_x_mm(&sl1->resin), ==, 120.96);
	CHECK_NUM(printer_resin_extent_y_mm(&sl1->resin), ==, 68.04);
	for (size_t i = 0; i < printer_resin_profile_count; i++) {
		err_clear(&e);
		CHECK_EQ_INT(param_check(&printer_resin_table, &printer_resin_profiles[i].resin, &e),
			     0);
		CHECK_EQ_INT(printer_resin_check(&printer_resin_profiles[i].resin, &e), 0);
	}
}

static void test_overrides_and_checks(void)
{
	struct printer p = *profile("sl1");
	struct err e;

	err_clear(&e);
	REQUIRE_OK(param_set(&printer_resin_table, &p.resin, "exposure_s", "9", &e), &e);
	CHECK_NUM(p.resin.exposure_s, ==, 9);
	REQUIRE_OK(param_set(&printer_resin_table, &p.resin, "print_speed", "slow", &e), &e);
	CHECK_EQ_INT(p.resin.print_speed, RESIN_SPEED_SLOW);
	REQUIRE_OK(param_set(&printer_resin_table, &p.resin, "material", "Tough Grey", &e), &e);
	CHECK_STR(p.resin.material, "Tough Grey");
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "exposure_s", "0.5", &e),
		     ERR_PARAM);
	CHECK_STR(e.field, "exposure_s");
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "exposure_first_s", "500", &e),
		     ERR_PARAM);
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "fade_layers", "2", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "nonsense", "2", &e), ERR_NOTFOUND);

	p.resin.exposure_first_s = 5; /* shorter than exposure_s */
	CHECK_EQ_INT(printer_resin_check(&p.resin, &e), ERR_PARAM);
	CHECK_STR(e.field, "exposure_first_s");
	p = *profile("sl1");
	snprintf(p.resin.material, sizeof p.resin.material, "Resin #2");
	CHECK_EQ_INT(printer_resin_check(&p.resin, &e), ERR_PARAM);
	CHECK_STR(e.field, "material");
	p = *profile("sl1");
	p.resin.pixels_x = 0;
	CHECK_EQ_INT(printer_resin_check(&p.resin, &e), ERR_PARAM);
	CHECK_STR(e.field, "display_px_x");
}

/* The map against REFERENCE.md: column = Y / 0.04725, row = (120.96 - X)
 * / 0.04725 on a 1440 x 2560 image; SL1S likewise at 50 um. */
static void test_raster_geometry(void)
{
	struct raster_map map;
	int w, h;
	double pts[][2] = {{0, 0}, {60.48, 34.02}, {120.96, 68.04}, {10, 60}, {100.5, 3.25}};

	printer_raster_geometry(profile("sl1"), &map, &w, &h);
	CHECK_EQ_INT(w, 1440);
	CHECK_EQ_INT(h, 2560);
	for (size_t i = 0; i < sizeof pts / sizeof pts[0]; i++) {
		double u, v, x, y;
		raster_map_apply(&map, pts[i][0], pts[i][1], &u, &v);
		CHECK_NEAR(u, pts[i][1] / 0.04725, 1e-9);
		CHECK_NEAR(v, (120.96 - pts[i][0]) / 0.04725, 1e-9);
		REQUIRE(raster_map_invert(&map, u, v, &x, &y) == 0);
		CHECK_NEAR(x, pts[i][0], 1e-9);
		CHECK_NEAR(y, pts[i][1], 1e-9);
	}
	CHECK_NEAR(raster_map_pixel_area_mm2(&map), 0.04725 * 0.04725, 1e-15);

	printer_raster_geometry(profile("sl1s"), &map, &w, &h);
	CHECK_EQ_INT(w, 1620);
	CHECK_EQ_INT(h, 2560);
	for (size_t i = 0; i < sizeof pts / sizeof pts[0]; i++) {
		double u, v;
		raster_map_apply(&map, pts[i][0], pts[i][1], &u, &v);
		CHECK_NEAR(u, pts[i][1] / 0.05, 1e-9);
		CHECK_NEAR(v, (128 - pts[i][0]) / 0.05, 1e-9);
	}
}

/* Each flag flips one image axis; landscape keeps X along the columns. */
static void test_raster_geometry_flags(void)
{
	struct printer p = *profile("sl1");
	struct raster_map map;
	double u, v;
	int w, h;

	p.resin.mirror_y = 1;
	printer_raster_geometry(&p, &map, &w, &h);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 20 / 0.04725, 1e-9);
	CHECK_NEAR(v, 10 / 0.04725, 1e-9);
	p.resin.mirror_y = 0;
	p.resin.mirror_x = 0;
	printer_raster_geometry(&p, &map, &w, &h);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 1440 - 20 / 0.04725, 1e-9);
	CHECK_NEAR(v, (120.96 - 10) / 0.04725, 1e-9);
	p.resin.portrait = 0;
	printer_raster_geometry(&p, &map, &w, &h);
	CHECK_EQ_INT(w, 2560);
	CHECK_EQ_INT(h, 1440);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 10 / 0.04725, 1e-9);
	CHECK_NEAR(v, (68.04 - 20) / 0.04725, 1e-9);
}

static void test_job_dir(void)
{
	char d[SL1_JOB_DIR_MAX + 1];
	const char *cases[][2] = {
		{"bunny", "bunny"},
		{"my part v2.stl", "my_part_v2"},
		{"femur.OFF", "femur"},
		{"part v2.5", "part_v2_5"},
		{".stl", "_stl"},
		{"../../etc/passwd", "______etc_passwd"},
		{"", "infilld"},
		{"thumb", "job_thumb"},
		{"thumbnail", "job_thumb"},
		{"t", "job_t"},
		{"thumbnails", "thumbs"},
		{"MyThumbnailHolder.stl", "MyThumbHolder"},
		{"THUMBNAIL.OFF", "THUMB"},
		{"thumbnailnail", "job_thumb"},
		{"a.thumbnail.b", "a_thumb_b"},
		{"caf\xc3\xa9", "caf__"},
	};

	for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		out_job_dir(cases[i][0], d);
		CHECK_STR(d, cases[i][1]);
	}
	out_job_dir(NULL, d);
	CHECK_STR(d, "infilld");
	out_job_dir("aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa", d);
	CHECK_EQ_INT(strlen(d), SL1_JOB_DIR_MAX);
}

/* The firmware's schedule (slafw): 3 first layers, then numFade layers
 * falling in equal steps of (first - normal) / (numFade + 1). */
static void test_exposure_and_time(void)
{
	struct resin_printer r = profile("sl1")->resin;
	double step = (35 - 7.5) / 11;

	CHECK_NUM(sl1_layer_exposure_s(&r, 0), ==, 35);
	CHECK_NUM(sl1_layer_exposure_s(&r, 2), ==, 35);
	CHECK_NEAR(sl1_layer_exposure_s(&r, 3), 35 - step, 1e-12);
	CHECK_NEAR(sl1_layer_exposure_s(&r, 12), 35 - 10 * step, 1e-12);
	CHECK_NUM(sl1_layer_exposure_s(&r, 13), ==, 7.5);
	CHECK_NUM(sl1_layer_exposure_s(&r, 5000), ==, 7.5);
	/* fast tilt 5 s, tower 5 s/mm; slow layers: slow tilt 8 s + 1 s */
	CHECK_NEAR(sl1_layer_time_s(&r, 100, 0.05, 0), 7.5 + 5 + 0.25, 1e-12);
	CHECK_NEAR(sl1_layer_time_s(&r, 100, 0.05, 1), 7.5 + 8 + 1 + 0.25, 1e-12);
	r.print_speed = RESIN_SPEED_SLOW;
	CHECK_NEAR(sl1_layer_time_s(&r, 100, 0.05, 0), 7.5 + 8 + 3 + 0.25, 1e-12);
	r.print_speed = RESIN_SPEED_HIGH_VISCOSITY;
	CHECK_NEAR(sl1_layer_time_s(&r, 100, 0.05, 0), 7.5 + 10 + 3.5 + 0.25, 1e-12);
	/* slow above 50% of the 120.96 x 68.04 display */
	CHECK_EQ_INT(sl1_layer_is_slow(&r, 0.49 * 120.96 * 68.04), 0);
	CHECK_EQ_INT(sl1_layer_is_slow(&r, 0.51 * 120.96 * 68.04), 1);
}

static void test_config_ini_text(void)
{
	const struct printer *p = profile("sl1");
	struct out_info oi;
	struct sl1_summary sum = {.layers = 10, .slow_layers = 1, .fast_layers = 9,
				  .volume_mm3 = 1234.5678, .print_time_s = 456.25};
	struct buf b;
	struct err e;
	char stamp[40];

	memset(&oi, 0, sizeof oi);
	oi.printer = p;
	oi.layer_mm = 0.025;
	oi.engine_name = "lattice";
	oi.created = 0;
	buf_init(&b);
	REQUIRE_OK(sl1_config_ini(&oi, &p->resin, "part", &sum, &b, &e), &e);
	REQUIRE(buf_append(&b, "", 1) == 0);
	CHECK_CONTAINS((char *)b.data, "\nusedMaterial = 1.234568\n");
	CHECK_CONTAINS((char *)b.data, "\nprintTime = 456.250\n");
	CHECK_CONTAINS((char *)b.data, "\nlayerHeight = 0.025\n");
	CHECK_CONTAINS((char *)b.data, "\nnumSlow = 1\nnumFast = 9\n");
	CHECK_CONTAINS((char *)b.data, "\nhollow = 1\n");
	CHECK_CONTAINS((char *)b.data, "\nfileCreationTimestamp = 1970-01-01 at 00:00:00 UTC\n");
	CHECK_CONTAINS((char *)b.data, "\nprusaSlicerVersion = infilld ");
	buf_fini(&b);
	sl1_timestamp(1700000000, stamp, sizeof stamp);
	CHECK_STR(stamp, "2023-11-14 at 22:13:20 UTC");
}

/* generic-resin: the display keys set a 3840 x 2400 px, 153.36 x 95.76 mm
 * landscape display (39.9375 x 39.9 um pixels); mirror_x flips columns. */
static void set_ok(struct printer *p, const char *key, const char *value)
{
	struct err e;

	err_clear(&e);
	REQUIRE_OK(param_set(&printer_resin_table, &p->resin, key, value, &e), &e);
}

static void test_generic_resin(void)
{
	const double pitch_x = 153.36 / 3840, pitch_y = 95.76 / 2400; /* mm per pixel */
	struct printer p;
	struct raster_map map;
	struct err e;
	double u, v, x, y;
	int w, h;

	err_clear(&e);
	REQUIRE_OK(printer_lookup("generic-resin", &p, &e), &e);
	CHECK_EQ_INT(p.kind, PRINTER_RESIN);
	CHECK_EQ_INT(p.resin.portrait, 0);
	REQUIRE_OK(printer_check(&p, &e), &e);
	set_ok(&p, "display_px_x", "3840");
	set_ok(&p, "display_px_y", "2400");
	set_ok(&p, "display_mm_x", "153.36");
	set_ok(&p, "display_mm_y", "95.76");
	set_ok(&p, "mirror_x", "false");
	set_ok(&p, "exposure_s", "3");
	set_ok(&p, "exposure_first_s", "30");
	set_ok(&p, "fade_layers", "5");
	REQUIRE_OK(printer_check(&p, &e), &e);
	CHECK_NUM(printer_build_volume(&p).hi.x, ==, 153.36);
	CHECK_NUM(printer_build_volume(&p).hi.y, ==, 95.76);

	printer_raster_geometry(&p, &map, &w, &h);
	CHECK_EQ_INT(w, 3840);
	CHECK_EQ_INT(h, 2400);
	CHECK_NEAR(raster_map_pixel_area_mm2(&map), pitch_x * pitch_y, 1e-15);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 10 / pitch_x, 1e-9);
	CHECK_NEAR(v, 2400 - 20 / pitch_y, 1e-9); /* rows grow downwards, Y upwards */
	raster_map_apply(&map, 153.36, 0, &u, &v);
	CHECK_NEAR(u, 3840, 1e-9);
	CHECK_NEAR(v, 2400, 1e-9);

	set_ok(&p, "mirror_x", "true");
	REQUIRE_OK(printer_check(&p, &e), &e);
	printer_raster_geometry(&p, &map, &w, &h);
	CHECK_EQ_INT(w, 3840);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 3840 - 10 / pitch_x, 1e-9);
	CHECK_NEAR(v, 2400 - 20 / pitch_y, 1e-9);
	REQUIRE(raster_map_invert(&map, u, v, &x, &y) == 0);
	CHECK_NEAR(x, 10, 1e-9);
	CHECK_NEAR(y, 20, 1e-9);
	set_ok(&p, "mirror_y", "true");
	printer_raster_geometry(&p, &map, &w, &h);
	raster_map_apply(&map, 10, 20, &u, &v);
	CHECK_NEAR(u, 3840 - 10 / pitch_x, 1e-9);
	CHECK_NEAR(v, 20 / pitch_y, 1e-9);

	/* impossible values, each naming its key */
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "display_px_x", "0", &e),
		     ERR_PARAM);
	CHECK_STR(e.field, "display_px_x");
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "display_px_y", "-4", &e),
		     ERR_PARAM);
	CHECK_STR(e.field, "display_px_y");
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "display_px_x", "16385", &e),
		     ERR_PARAM);
	CHECK_EQ_INT(param_set(&printer_resin_table, &p.resin, "display_mm_y", "0", &e),
		     ERR_PARAM);
	CHECK_STR(e.field, "display_mm_y");
	set_ok(&p, "display_mm_x", "15.336"); /* 4 um pixels */
	CHECK_EQ_INT(printer_check(&p, &e), ERR_PARAM);
	CHECK_STR(e.field, "display_mm_x");
	set_ok(&p, "display_mm_x", "153.36");
	set_ok(&p, "display_px_y", "100"); /* 0.9576 mm pixels */
	CHECK_EQ_INT(printer_check(&p, &e), ERR_PARAM);
	CHECK_STR(e.field, "display_mm_y");
	set_ok(&p, "display_px_y", "2400");
	REQUIRE_OK(printer_check(&p, &e), &e);

	/* the SL1/SL1S display is the firmware's: any display key is refused */
	static const char *const keys[][2] = {{"display_px_x", "3840"}, {"display_px_y", "2400"},
					      {"display_mm_x", "100"}, {"display_mm_y", "60"},
					      {"mirror_x", "false"}, {"mirror_y", "true"}};
	for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++) {
		REQUIRE_OK(printer_lookup(i % 2 ? "sl1s" : "sl1", &p, &e), &e);
		REQUIRE_OK(printer_check(&p, &e), &e);
		set_ok(&p, keys[i][0], keys[i][1]);
		CHECK_EQ_INT(printer_check(&p, &e), ERR_PARAM);
		CHECK_STR(e.field, keys[i][0]);
	}
	/* a value equal to the firmware's is no override */
	REQUIRE_OK(printer_lookup("sl1", &p, &e), &e);
	set_ok(&p, "display_px_x", "2560");
	set_ok(&p, "mirror_x", "true");
	REQUIRE_OK(printer_check(&p, &e), &e);
}

int main(void)
{
	RUN(test_profiles);
	RUN(test_overrides_and_checks);
	RUN(test_raster_geometry);
	RUN(test_raster_geometry_flags);
	RUN(test_generic_resin);
	RUN(test_job_dir);
	RUN(test_exposure_and_time);
	RUN(test_config_ini_text);
	return harness_report();
}
