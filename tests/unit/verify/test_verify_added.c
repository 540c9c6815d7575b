/* test_verify_added.c - islands a fill adds to the solid part
 * (verify_layer_ref, the report's islands_added; docs/verify.md "Added
 * islands").
 *
 * The solid reference, 0.1 mm layers and pixels: a pillar [2, 6]^2 x
 * [0, 10] mm on the plate and a chin [10, 14] x [2, 6] x [5, 10] joined
 * to it by a bridge at z >= 8: the chin's first layer (50) is the part's
 * own island.  Checked stacks: the part itself (no added island); the part
 * with the pillar hollowed and a 1 mm blob floating in the cavity at z 4
 * (one added island of 1 mm2 on layer 40, besides the chin's); the chin a
 * pixel narrower (still the part's own, within the 1-pixel tolerance);
 * the chin starting 3 layers higher (added: the part starts lower there).
 *
 * The reference also names the part's own air: a crevice whose slit
 * shifts sideways between two layers reads as a sealed pocket without it
 * (test_crevice).
 */
#include <math.h>

#include "harness.h"

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/verify.h"

#define PX 0.1
#define LAYER 0.1
#define N 160 /* 16 x 16 mm */
#define LAYERS 100

enum shape { REF, BLOB, NARROW_CHIN, HIGH_CHIN };

static int solid_at(enum shape s, double x, double y, double z)
{
	double c0 = s == NARROW_CHIN ? 10.1 : 10, c1 = s == NARROW_CHIN ? 13.9 : 14;
	double cz = s == HIGH_CHIN ? 5.3 : 5;
	int in_y = y >= 2 && y <= 6;
	int pillar = x >= 2 && x <= 6 && in_y && z <= 10;
	int chin = x >= c0 && x <= c1 && in_y && z >= cz && z <= 10;
	int bridge = x >= 6 && x <= 10 && in_y && z >= 8 && z <= 10;

	if (s == BLOB) {
		int cavity = x > 2.5 && x < 5.5 && y > 2.5 && y < 5.5 && z > 1 && z < 9;
		int blob = x >= 3.5 && x <= 4.5 && y >= 3.5 && y <= 4.5 && z >= 4 && z <= 5;
		if (cavity)
			return blob;
	}
	return pillar || chin || bridge;
}

/* Layer k of a solid given by at(arg, x, y, z) (mm), sampled at pixel and
 * layer centres into r. */
static void draw(struct raster *r, int (*at)(int, double, double, double), int arg, int k)
{
	double z = (k + 0.5) * LAYER;
	for (int j = 0; j < N; j++)
		for (int i = 0; i < N; i++)
			r->px[(size_t)j * r->stride + (size_t)i] =
				at(arg, (i + 0.5) * PX, (j + 0.5) * PX, z) ? 255 : 0;
}

static int shape_at(int s, double x, double y, double z)
{
	return solid_at((enum shape)s, x, y, z);
}

static void fill(struct raster *r, enum shape s, int k)
{
	draw(r, shape_at, (int)s, k);
}

/* The stack of layers layers of at(arg, ...) checked, against the same
 * layers of at(ref_arg, ...) when with_ref; *rep replaced. */
static void run_stack(int (*at)(int, double, double, double), int arg, int ref_arg, int layers,
		      int with_ref, struct verify_report *rep)
{
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N), *ref = raster_new(N, N);
	struct err e;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r && ref);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; k < layers; k++) {
		draw(r, at, arg, k);
		draw(ref, at, ref_arg, k);
		REQUIRE_OK(with_ref ? verify_layer_ref(v, r, ref, &e) : verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
	raster_free(ref);
}

static void run_pair(enum shape s, struct verify_report *rep)
{
	run_stack(shape_at, (int)s, REF, LAYERS, 1, rep);
}

static void test_part_itself(void)
{
	struct verify_report rep;
	run_pair(REF, &rep);
	CHECK_EQ_INT(rep.has_reference, 1);
	CHECK_EQ_INT(rep.islands, 1); /* the chin */
	CHECK_EQ_INT(rep.first_island_layer, 50);
	CHECK_EQ_INT(rep.islands_added, 0);
	CHECK_EQ_INT(rep.first_added_island_layer, -1);
	CHECK_EQ_INT(rep.first_solid_layer, 0);
	verify_report_fini(&rep);
}

static void test_floating_blob(void)
{
	struct verify_report rep;
	run_pair(BLOB, &rep);
	CHECK_EQ_INT(rep.islands, 2);
	CHECK_EQ_INT(rep.islands_added, 1);
	CHECK_NEAR(rep.island_added_mm2, 1, 0.25);
	CHECK_EQ_INT(rep.first_added_island_layer, 40);
	verify_report_fini(&rep);
}

static void test_chin_moved(void)
{
	struct verify_report rep;
	run_pair(NARROW_CHIN, &rep);
	CHECK_EQ_INT(rep.islands, 1);
	CHECK_EQ_INT(rep.islands_added, 0);
	verify_report_fini(&rep);
	run_pair(HIGH_CHIN, &rep);
	CHECK_EQ_INT(rep.islands, 1);
	CHECK_EQ_INT(rep.islands_added, 1);
	CHECK_EQ_INT(rep.first_added_island_layer, 53);
	verify_report_fini(&rep);
}

static void test_without_reference(void)
{
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N), *small = raster_new(N / 2, N);
	struct verify_report rep;
	struct err e;

	REQUIRE(r && small);
	memset(&rep, 0, sizeof rep);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	fill(r, BLOB, 0);
	REQUIRE_OK(verify_layer(v, r, &e), &e);
	/* a reference on some layers only, or of another size, is refused */
	CHECK_EQ_INT(verify_layer_ref(v, r, r, &e), ERR_PARAM);
	CHECK_STR(e.field, "reference");
	verify_free(v);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	CHECK_EQ_INT(verify_layer_ref(v, r, small, &e), ERR_PARAM);
	CHECK_STR(e.field, "reference");
	verify_free(v);
	/* without one: no added-island figures, first_solid_layer still */
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; k < LAYERS; k++) {
		raster_clear(r);
		if (k >= 7)
			fill(r, REF, k);
		REQUIRE_OK(verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, &rep, &e), &e);
	CHECK_EQ_INT(rep.has_reference, 0);
	CHECK_EQ_INT(rep.islands_added, 0);
	CHECK_EQ_INT(rep.first_solid_layer, 7);
	CHECK_EQ_INT(rep.islands, 2); /* the pillar's foot in the air, the chin */
	verify_report_fini(&rep);
	verify_free(v);
	raster_free(r);
	raster_free(small);
}

/* A block [1, 15]^2 x [0, 6] mm with a crevice: on the layers under
 * z = 3 a slit y in [7.5, 8.5], x < 8 open at the block's side; on the
 * layer [3.0, 3.1] a slit y in [9.2, 10.2], x in [4, 8] that touches no
 * pixel of the one below (so the linking reads it as sealed, as a thin
 * slanted crevice reads under thick layers); solid above.  cavity: also
 * a box hollowed at x in [5, 8], y in [11, 13.5], z in [1, 4], 0.8 mm
 * from that slit and 1.5 mm from the block's side. */
static int crevice_at(int cavity, double x, double y, double z)
{
	if (x < 1 || x > 15 || y < 1 || y > 15 || z > 6)
		return 0;
	if (z < 3 && y > 7.5 && y < 8.5 && x < 8)
		return 0;
	if (z > 3 && z < 3.1 && y > 9.2 && y < 10.2 && x > 4 && x < 8)
		return 0;
	return !(cavity && x > 5 && x < 8 && y > 11 && y < 13.5 && z > 1 && z < 4);
}

static void run_crevice(int cavity, int with_ref, struct verify_report *rep)
{
	run_stack(crevice_at, cavity, 0, 60, with_ref, rep);
}

static void test_crevice(void)
{
	struct verify_report rep;
	double alone;

	/* alone, the pocket is an enclosed void (40 x 10 px on one layer)
	 * with its flat ceiling over it */
	run_crevice(0, 0, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 0.4, 1e-9);
	CHECK(rep.interior_overhang_mm2 > 1);
	CHECK_NEAR(rep.part_overhang_mm2, 0, 1e-12);
	CHECK_NEAR(rep.min_wall_mm, 3.0, 1e-6); /* to the block's side x = 1 */
	alone = rep.interior_overhang_mm2;
	verify_report_fini(&rep);
	/* against the part itself it is the part's own air: its ceiling is
	 * the part's overhang, the same area */
	run_crevice(0, 1, &rep);
	CHECK_NEAR(rep.part_overhang_mm2, alone, 1e-9);
	CHECK_EQ_INT(rep.enclosed_void_mm3 == 0, 1);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK_EQ_INT(isinf(rep.min_wall_mm), 1);
	verify_report_fini(&rep);
	/* a cavity the interior adds stays enclosed (30 x 25 x 30 voxels of
	 * 0.001 mm3), its wall to the part's air read to the crevice */
	run_crevice(1, 1, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 22.5, 1e-9);
	CHECK(rep.interior_overhang_mm2 > 4);
	CHECK_NEAR(rep.part_overhang_mm2, alone, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, 0.8, 1e-6);
	CHECK_EQ_INT(isinf(rep.min_wall_between_mm), 1);
	verify_report_fini(&rep);
	/* alone, the crevice is a second cavity 0.8 mm away */
	run_crevice(1, 0, &rep);
	CHECK_NEAR(rep.enclosed_void_mm3, 22.9, 1e-9);
	CHECK_NEAR(rep.min_wall_mm, 1.5, 1e-6);
	CHECK_NEAR(rep.min_wall_between_mm, 0.8, 1e-6);
	verify_report_fini(&rep);
}

int main(void)
{
	RUN(test_crevice);
	RUN(test_part_itself);
	RUN(test_floating_blob);
	RUN(test_chin_moved);
	RUN(test_without_reference);
	return harness_report();
}
