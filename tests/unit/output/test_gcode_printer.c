/* test_gcode_printer.c - the generic-fdm profile, its override table and
 * the FDM cross-field checks (printer_fdm.c). */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/param.h"
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"

#include <stddef.h>

static const struct fdm_printer *generic(void)
{
	for (size_t i = 0; i < printer_fdm_profile_count; i++)
		if (strcmp(printer_fdm_profiles[i].name, "generic-fdm") == 0)
			return &printer_fdm_profiles[i].fdm;
	return NULL;
}

static void test_generic_profile(void)
{
	const struct fdm_printer *f = generic();

	REQUIRE(f);
	CHECK_NUM(f->nozzle_mm, ==, 0.4);
	CHECK_NUM(f->filament_mm, ==, 1.75);
	CHECK_NUM(f->layer_mm, ==, 0.2);
	CHECK_NUM(f->first_layer_mm, ==, 0.2);
	CHECK_NUM(f->bed_x_mm, ==, 220);
	CHECK_NUM(f->bed_y_mm, ==, 220);
	CHECK_NUM(f->max_z_mm, ==, 250);
	CHECK_STR(f->filament_type, "PLA");
	CHECK_NUM(f->nozzle_c, >=, 190);
	CHECK_NUM(f->nozzle_c, <=, 230);
	CHECK_NUM(f->bed_c, >=, 50);
	CHECK_NUM(f->bed_c, <=, 70);
	CHECK_EQ_INT(printer_fdm_profiles[0].kind, PRINTER_FDM);
}

/* The table's defaults are the profile: a field missing from the table
 * would stay zero here and differ (the profile's zero fields are the three
 * off-by-default switches, checked by name below). */
static void test_table_covers_profile(void)
{
	struct fdm_printer d;
	const struct fdm_printer *f = generic();
	struct err e;

	REQUIRE(f);
	memset(&d, 0, sizeof d);
	param_defaults(&printer_fdm_table, &d);
	CHECK(memcmp(&d, f, sizeof d) == 0);
	err_clear(&e);
	CHECK_EQ_INT(param_check(&printer_fdm_table, f, &e), 0);
	CHECK_EQ_INT(printer_fdm_check(f, &e), 0);
	CHECK(param_find(&printer_fdm_table, "external_perimeter_first") != NULL);
	CHECK(param_find(&printer_fdm_table, "seam") != NULL);
	CHECK(param_find(&printer_fdm_table, "klipper") != NULL);
	/* one entry per field, no field twice */
	for (size_t i = 0; i < printer_fdm_table.n; i++)
		for (size_t j = i + 1; j < printer_fdm_table.n; j++)
			CHECK(printer_fdm_table.v[i].offset != printer_fdm_table.v[j].offset);
}

/* Every quantity is named with its unit. */
static void test_names_carry_units(void)
{
	static const char *unitless[] = {"perimeters", "top_layers", "bottom_layers", "skirt_loops",
					 "filament_type", "seam", "klipper",
					 "external_perimeter_first"};
	static const char *suffixes[] = {"_mm", "_mm_s", "_mm_s2", "_c", "_pct", "_deg", "_s",
					 "_g_cm3"};

	for (size_t i = 0; i < printer_fdm_table.n; i++) {
		const char *n = printer_fdm_table.v[i].name;
		int ok = 0;
		for (size_t k = 0; k < sizeof unitless / sizeof unitless[0]; k++)
			ok |= strcmp(n, unitless[k]) == 0;
		for (size_t k = 0; k < sizeof suffixes / sizeof suffixes[0]; k++) {
			size_t a = strlen(n), b = strlen(suffixes[k]);
			ok |= a > b && strcmp(n + a - b, suffixes[k]) == 0;
		}
		if (!ok)
			fprintf(stderr, "parameter without a unit: %s\n", n);
		CHECK(ok);
		CHECK(printer_fdm_table.v[i].help && printer_fdm_table.v[i].help[0]);
	}
}

static void expect_field(struct fdm_printer *f, const char *field)
{
	struct err e;

	err_clear(&e);
	CHECK_EQ_INT(printer_fdm_check(f, &e), ERR_PARAM);
	CHECK_STR(e.field, field);
	*f = *generic();
}

static void test_cross_field_checks(void)
{
	struct fdm_printer f = *generic();
	struct err e;

	f.line_width_mm = 0.3; /* narrower than 0.8 x nozzle */
	expect_field(&f, "line_width_mm");
	f.line_width_mm = 1.2; /* wider than 2.5 x nozzle */
	expect_field(&f, "line_width_mm");
	f.layer_mm = 0.35; /* over 80% of the nozzle */
	expect_field(&f, "default_layer_mm");
	f.first_layer_mm = 0.45;
	expect_field(&f, "first_layer_mm");
	f.nozzle_mm = 0.8;
	f.line_width_mm = 0.7;
	f.first_layer_mm = 0.7; /* a bead no wider than it is high */
	expect_field(&f, "line_width_mm");
	f.min_print_speed_mm_s = 30; /* above the external perimeter speed */
	expect_field(&f, "min_print_speed_mm_s");
	f.skirt_distance_mm = 120;
	expect_field(&f, "skirt_distance_mm");
	f.z_hop_mm = 300;
	expect_field(&f, "z_hop_mm");
	/* and the range checks of the table */
	err_clear(&e);
	CHECK_EQ_INT(param_set(&printer_fdm_table, &f, "infill_pct", "101", &e), ERR_PARAM);
	CHECK_STR(e.field, "infill_pct");
	CHECK_EQ_INT(param_set(&printer_fdm_table, &f, "seam", "rear", &e), 0);
	CHECK_EQ_INT(f.seam, FDM_SEAM_REAR);
	CHECK_EQ_INT(param_set(&printer_fdm_table, &f, "nozzle_temp_c", "230", &e), 0);
	CHECK_NUM(f.nozzle_c, ==, 230);
	CHECK_EQ_INT(param_set(&printer_fdm_table, &f, "filament_diameter_mm", "2.85", &e), 0);
	CHECK_NUM(f.filament_mm, ==, 2.85);
}

int main(void)
{
	RUN(test_generic_profile);
	RUN(test_table_covers_profile);
	RUN(test_names_carry_units);
	RUN(test_cross_field_checks);
	return harness_report();
}
