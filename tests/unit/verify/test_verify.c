/* test_verify.c - the layer-stack checker on synthetic stacks whose
 * answers are known in closed form.
 *
 * A 20 mm cube printed at 0.1 mm layers and 0.1 mm pixels with:
 *  - a sealed 16 mm cubic cavity (flat ceiling, the uniform hollowing of
 *    every slicer): the ceiling is an interior overhang of about
 *    16 x 16 mm minus the ring the walls can reach (layer tan a + 1 px);
 *  - the same cavity under a 45 degree pyramid roof: no interior overhang
 *    at alpha 45 (the roof steps 0.1 mm per 0.1 mm layer); under a roof
 *    71.6 degrees from the vertical, overhangs on every step;
 *  - the flat-ceiling cavity with a hole in the top: overhangs exist but
 *    over a void that reaches the outside, so they are not interior;
 *  - a block floating above the plate: one island;
 *  - walls: 2 mm all round (in-layer and vertical).
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/geom/raster.h"
#include "engine/verify/verify.h"

#define PX 0.1
#define LAYER 0.1
#define N 220 /* image 22 x 22 mm, cube at [1, 21] */

enum shape { FLAT, ROOF, LOWROOF, OPEN, ISLAND };

static int solid_at(enum shape s, double x, double y, double z)
{
	int cube = x >= 1 && x <= 21 && y >= 1 && y <= 21 && z <= 20;
	double d;

	if (s == ISLAND)
		return (x >= 5 && x <= 10 && y >= 5 && y <= 10 && z <= 3) ||
		       (x >= 12 && x <= 17 && y >= 5 && y <= 10 && z >= 5 && z <= 8);
	if (!cube)
		return 0;
	/* cavity [3, 19]^2 x [2, 18] */
	if (x > 3 && x < 19 && y > 3 && y < 19 && z > 2) {
		if (s == FLAT || s == OPEN)
			return !(z < 18 || (s == OPEN && fabs(x - 11) < 1 && fabs(y - 11) < 1));
		/* roof: distance to the cavity wall limits the height above 10 */
		d = fmin(fmin(x - 3, 19 - x), fmin(y - 3, 19 - y));
		if (s == LOWROOF) /* 71.6 degrees from the vertical: 0.3 mm per layer */
			d /= 3;
		/* pixel and layer centres fall on the roof's steps exactly: the
		 * 1e-9 decides the ties one way (a step of one pixel per layer),
		 * where rounding would give steps of 0 and 2 */
		return !(z < 18 && z - 10 < d + 1e-9);
	}
	return 1;
}

static void run_stack(enum shape s, double alpha, struct verify_report *rep)
{
	struct verify_params p = {LAYER, alpha, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(N, N);
	struct err e;
	int layers = 200;

	err_clear(&e);
	memset(rep, 0, sizeof *rep);
	REQUIRE(r);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	for (int k = 0; k < layers; k++) {
		double z = (k + 0.5) * LAYER;
		for (int j = 0; j < N; j++)
			for (int i = 0; i < N; i++)
				r->px[(size_t)j * r->stride + (size_t)i] =
					solid_at(s, (i + 0.5) * PX, (j + 0.5) * PX, z) ? 255 : 0;
		REQUIRE_OK(verify_layer(v, r, &e), &e);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	raster_free(r);
}

static void test_flat_ceiling(void)
{
	struct verify_report rep;
	/* ceiling at z = 18 over a 16 x 16 mm cavity; the walls reach
	 * 0.1 tan 45 + 0.1 = 0.2 mm in: (16 - 2 * 0.2)^2 = 243 mm^2 (+-1 px ring) */
	run_stack(FLAT, 45, &rep);
	CHECK_EQ_INT(rep.layers, 200);
	CHECK_NEAR(rep.interior_overhang_mm2, 15.6 * 15.6, 16 * 4 * PX);
	CHECK_EQ_INT(rep.overhang_layers, 1);
	CHECK_EQ_INT(rep.worst_layer, 180);
	CHECK_EQ_INT(rep.islands, 0);
	CHECK_NEAR(rep.min_wall_mm, 2, PX);
	CHECK_NEAR(rep.min_wall_vertical_mm, 2, LAYER);
	CHECK_NEAR(rep.enclosed_void_mm3, 16 * 16 * 16, 16 * 16 * 16 * 0.03);
	verify_report_fini(&rep);
}

static void test_roof(void)
{
	struct verify_report rep;
	run_stack(ROOF, 45, &rep);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK_EQ_INT(rep.islands, 0);
	verify_report_fini(&rep);
	/* a roof 71.6 degrees from the vertical steps 3 pixels per layer */
	run_stack(LOWROOF, 45, &rep);
	CHECK(rep.interior_overhang_mm2 > 10);
	CHECK(rep.overhang_layers > 20);
	verify_report_fini(&rep);
}

static void test_open_cavity(void)
{
	struct verify_report rep;
	run_stack(OPEN, 45, &rep);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK(rep.exterior_overhang_mm2 > 200);
	CHECK_NEAR(rep.enclosed_void_mm3, 0, 1e-9);
	verify_report_fini(&rep);
}

static void test_island(void)
{
	struct verify_report rep;
	run_stack(ISLAND, 45, &rep);
	CHECK_EQ_INT(rep.islands, 1);
	CHECK_NEAR(rep.island_mm2, 25, 1.5);
	CHECK_EQ_INT(rep.first_island_layer, 50);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	verify_report_fini(&rep);
}

static void test_params(void)
{
	struct verify_params p = {0, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct err e;

	CHECK_EQ_INT(verify_new(&p, &v, &e), ERR_PARAM);
	CHECK_STR(e.field, "layer_mm");
	p.layer_mm = 0.1;
	p.alpha_deg = 95;
	CHECK_EQ_INT(verify_new(&p, &v, &e), ERR_PARAM);
	verify_free(NULL);
}

int main(void)
{
	RUN(test_flat_ceiling);
	RUN(test_roof);
	RUN(test_open_cavity);
	RUN(test_island);
	RUN(test_params);
	return harness_report();
}
