/* test_contours.c - slice_field_contours (marching squares): analytic
 * circle and annulus fields, sample classification of random fields
 * against point-in-polygon, saddles, the grid border, maps, bad input. */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/slice/slice.h"

static struct raster_map map_pitch(double p, int rot90, int mirror)
{
	struct raster_map m = {{{1 / p, 0}, {0, 1 / p}}, {0, 0}};

	if (rot90) { /* u = y/p, v = -x/p + 200 */
		m.a[0][0] = 0, m.a[0][1] = 1 / p;
		m.a[1][0] = -1 / p, m.a[1][1] = 0;
		m.b[1] = 200;
	}
	if (mirror) {
		m.a[0][0] = -m.a[0][0], m.a[0][1] = -m.a[0][1];
		m.b[0] = 300;
	}
	return m;
}

/* Signed distance-like field: positive inside circles (cx, cy, r) in pixels. */
static void circle_field(float *f, int w, int h, double cx, double cy, double r)
{
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++)
			f[(size_t)j * w + i] = (float)(r - hypot(i + 0.5 - cx, j + 0.5 - cy));
}

static void test_circle(void)
{
	const int w = 160, h = 120;
	float *f = malloc((size_t)w * h * sizeof *f);
	struct paths reg;
	struct err e;

	paths_init(&reg);
	err_clear(&e);
	circle_field(f, w, h, 70.3, 55.8, 40);
	for (int k = 0; k < 4; k++) {
		struct raster_map m = map_pitch(0.05, k & 1, k >> 1);
		double maxdev = 0;
		REQUIRE_OK(slice_field_contours(f, w, h, 0, &m, &reg, &e), &e);
		REQUIRE(reg.n == 1);
		CHECK_NUM(path_area_mm2(&reg.v[0]), >, 0); /* outer CCW in the printer frame */
		CHECK_REL(paths_area_mm2(&reg), M_PI * 40 * 40 * 0.05 * 0.05, 1e-3);
		for (size_t i = 0; i < reg.v[0].n; i++) {
			double u, v;
			raster_map_apply(&m, geom_nm_to_mm(reg.v[0].pts[i].x),
					 geom_nm_to_mm(reg.v[0].pts[i].y), &u, &v);
			maxdev = fmax(maxdev, fabs(hypot(u - 70.3, v - 55.8) - 40));
		}
		CHECK_NUM(maxdev, <, 0.01); /* pixels */
	}
	paths_fini(&reg);
	free(f);
}

static void test_annulus_and_iso(void)
{
	const int w = 100, h = 100;
	float *f = malloc((size_t)w * h * sizeof *f);
	struct raster_map m = map_pitch(0.1, 0, 0);
	struct paths reg;
	struct err e;
	int pos = 0, neg = 0;

	paths_init(&reg);
	err_clear(&e);
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++) {
			double d = hypot(i + 0.5 - 50, j + 0.5 - 50);
			f[(size_t)j * w + i] = (float)fmin(40 - d, d - 15);
		}
	REQUIRE_OK(slice_field_contours(f, w, h, 0, &m, &reg, &e), &e);
	REQUIRE(reg.n == 2);
	for (size_t i = 0; i < reg.n; i++) {
		pos += path_area_mm2(&reg.v[i]) > 0;
		neg += path_area_mm2(&reg.v[i]) < 0;
	}
	CHECK_EQ_INT(pos, 1);
	CHECK_EQ_INT(neg, 1);
	CHECK_REL(paths_area_mm2(&reg), M_PI * (40 * 40 - 15 * 15) * 0.01, 2e-3);
	/* a non-zero iso: the region f > 5 is the annulus 20 < d < 35 */
	REQUIRE_OK(slice_field_contours(f, w, h, 5, &m, &reg, &e), &e);
	CHECK_REL(paths_area_mm2(&reg), M_PI * (35 * 35 - 20 * 20) * 0.01, 2e-3);
	paths_fini(&reg);
	free(f);
}

/* Every sample is classified like the field says: centres with f > iso
 * inside the region, the others outside. */
static void test_random_fields(void)
{
	const int w = 90, h = 70;
	float *f = malloc((size_t)w * h * sizeof *f);
	struct paths reg;
	struct err e;
	uint64_t s = 12345;
	long wrong = 0, in = 0;

	paths_init(&reg);
	err_clear(&e);
	for (int trial = 0; trial < 12; trial++) {
		struct raster_map m = map_pitch(0.1, trial & 1, (trial >> 1) & 1);
		double gx[8], gy[8], gs[8];
		for (int g = 0; g < 8; g++) {
			s = s * 6364136223846793005ull + 1442695040888963407ull;
			gx[g] = (double)(s >> 40) / (1 << 24) * w;
			s = s * 6364136223846793005ull + 1442695040888963407ull;
			gy[g] = (double)(s >> 40) / (1 << 24) * h;
			s = s * 6364136223846793005ull + 1442695040888963407ull;
			gs[g] = 3 + (double)(s >> 40) / (1 << 24) * 12;
		}
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				double v = 0;
				for (int g = 0; g < 8; g++)
					v += exp(-(pow(i - gx[g], 2) + pow(j - gy[g], 2)) /
						 (2 * gs[g] * gs[g]));
				/* noise makes saddles and single-sample islands */
				s = s * 6364136223846793005ull + 1442695040888963407ull;
				v += ((double)(s >> 40) / (1 << 24) - 0.5) * 0.3;
				f[(size_t)j * w + i] = (float)v;
			}
		REQUIRE_OK(slice_field_contours(f, w, h, 0.4f, &m, &reg, &e), &e);
		for (size_t k = 0; k < reg.n; k++)
			CHECK_INT(reg.v[k].n, >=, 3);
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				double x, y;
				int want = f[(size_t)j * w + i] > 0.4f, got;
				raster_map_invert(&m, i + 0.5, j + 0.5, &x, &y);
				got = paths_winding(&reg, (struct pt2){geom_mm_to_nm(x),
								      geom_mm_to_nm(y)}) != 0;
				wrong += want != got;
				in += want;
			}
	}
	CHECK_EQ_INT(wrong, 0);
	CHECK_INT(in, >, 1000);
	paths_fini(&reg);
	free(f);
}

/* Saddle: the centre value (mean of the corners) decides. */
static void test_saddle(void)
{
	float sep[4] = {1, 0, 0, 1}, con[4] = {1, 0.2f, 0.2f, 1};
	struct raster_map m = map_pitch(1, 0, 0);
	struct paths reg;
	struct err e;

	paths_init(&reg);
	err_clear(&e);
	REQUIRE_OK(slice_field_contours(sep, 2, 2, 0.5f, &m, &reg, &e), &e);
	CHECK_EQ_INT(reg.n, 2); /* centre 0.5 is not above 0.5: apart */
	REQUIRE_OK(slice_field_contours(con, 2, 2, 0.5f, &m, &reg, &e), &e);
	CHECK_EQ_INT(reg.n, 1); /* centre 0.6: joined */
	paths_fini(&reg);
}

/* The field counts as below iso outside the grid, with crossings on the
 * image border: a field above iso everywhere gives the image rectangle
 * with its four corners chamfered by half a pixel (the corner cells have
 * one sample inside); NaN counts as below. */
static void test_border_and_nan(void)
{
	float f[12] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
	struct raster_map m = map_pitch(0.5, 0, 0);
	struct paths reg;
	struct err e;

	paths_init(&reg);
	err_clear(&e);
	REQUIRE_OK(slice_field_contours(f, 4, 3, 0, &m, &reg, &e), &e);
	CHECK_EQ_INT(reg.n, 1);
	CHECK_NEAR(paths_area_mm2(&reg), (12 - 4 * 0.125) * 0.25, 1e-9);
	f[5] = NAN; /* an interior sample below iso: a diamond hole */
	REQUIRE_OK(slice_field_contours(f, 4, 3, 0, &m, &reg, &e), &e);
	CHECK_NEAR(paths_area_mm2(&reg), (12 - 4 * 0.125 - 0.5) * 0.25, 1e-9);
	for (int i = 0; i < 12; i++)
		f[i] = -1;
	REQUIRE_OK(slice_field_contours(f, 4, 3, 0, &m, &reg, &e), &e);
	CHECK_EQ_INT(reg.n, 0);
	CHECK_EQ_INT(slice_field_contours(f, 0, 3, 0, &m, &reg, &e), ERR_PARAM);
	m.a[0][0] = 0;
	CHECK_EQ_INT(slice_field_contours(f, 4, 3, 0, &m, &reg, &e), ERR_PARAM);
	paths_fini(&reg);
}

static void test_alloc_failures(void)
{
	const int w = 60, h = 60;
	float *f = malloc((size_t)w * h * sizeof *f);
	struct raster_map m = map_pitch(0.1, 0, 0);
	int n, failed = 0;

	circle_field(f, w, h, 30, 30, 20);
	for (n = 1; n < 60; n++) {
		struct paths reg;
		struct err e;
		int rc;
		paths_init(&reg);
		err_clear(&e);
		mem_fail_after(n);
		rc = slice_field_contours(f, w, h, 0, &m, &reg, &e);
		mem_fail_after(-1);
		paths_fini(&reg);
		if (!rc)
			break;
		CHECK_EQ_INT(rc, ERR_NOMEM);
		failed++;
	}
	CHECK_INT(failed, >=, 3);
	CHECK_INT(n, <, 60);
	free(f);
}

int main(void)
{
	RUN(test_circle);
	RUN(test_annulus_and_iso);
	RUN(test_random_fields);
	RUN(test_saddle);
	RUN(test_border_and_nan);
	RUN(test_alloc_failures);
	return harness_report();
}
