/* test_raster.c - slice_rasterize / slice_coverage: exact-area coverage
 * against polygon areas and per-pixel polygon/pixel intersections (Clipper),
 * binary centre sampling against point-in-polygon, rotated and mirrored
 * maps, clipping at the image border, max-combining, bad maps. */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/slice/slice.h"

static uint64_t rng = 0x2545F4914F6CDD1Dull;

static double urand(void) /* [0, 1) */
{
	return (double)(harness_xorshift64(&rng) >> 11) / 9007199254740992.0;
}

/* Star-shaped (hence simple) random polygon around (cx, cy) mm, CCW. */
static void star(struct paths *ps, double cx, double cy, double r0, double r1, int n)
{
	struct path *p = paths_add(ps);
	double a = 0;

	for (int i = 0; i < n; i++) {
		double r = r0 + (r1 - r0) * urand();
		a += 2 * M_PI / n * (0.5 + urand()) / 1.0001;
		if (a >= 2 * M_PI)
			break;
		path_push(p, (struct pt2){geom_mm_to_nm(cx + r * cos(a)), geom_mm_to_nm(cy + r * sin(a))});
	}
}

/* Maps used throughout: pixel pitch p mm, the image centred on (cx, cy). */
enum map_kind { MAP_PLAIN, MAP_ROT90, MAP_MIRROR, MAP_ROT30, MAP_SL1 };

static struct raster_map make_map(enum map_kind k, double p, int w, int h, double cx, double cy)
{
	struct raster_map m;
	double c = 1.0, s = 0.0, sx = 1.0;

	switch (k) {
	case MAP_PLAIN: break;
	case MAP_ROT90: c = 0, s = 1; break;
	case MAP_MIRROR: sx = -1; break;
	case MAP_ROT30: c = cos(M_PI / 6), s = sin(M_PI / 6); break;
	case MAP_SL1: /* column = Y / p, row = (W - X) / p (REFERENCE.md) */
		m.a[0][0] = 0, m.a[0][1] = 1 / p, m.a[1][0] = -1 / p, m.a[1][1] = 0;
		m.b[0] = w / 2.0 - cy / p;
		m.b[1] = h / 2.0 + cx / p;
		return m;
	}
	m.a[0][0] = sx * c / p, m.a[0][1] = -s / p;
	m.a[1][0] = sx * s / p, m.a[1][1] = c / p;
	m.b[0] = w / 2.0 - (m.a[0][0] * cx + m.a[0][1] * cy);
	m.b[1] = h / 2.0 - (m.a[1][0] * cx + m.a[1][1] * cy);
	return m;
}

/* The pixel square (i, j) as a polygon in printer nm (CCW). */
static void pixel_poly(const struct raster_map *m, int i, int j, struct paths *out)
{
	struct path *p;
	const double c[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];

	paths_clear(out);
	p = paths_add(out);
	for (int k = 0; k < 4; k++) {
		double x, y;
		raster_map_invert(m, i + c[k][0], j + c[k][1], &x, &y);
		path_push(p, (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)});
	}
	if (det < 0)
		path_reverse(p);
}

static double sum_f(const float *f, size_t n)
{
	double s = 0;
	for (size_t i = 0; i < n; i++)
		s += f[i];
	return s;
}

/* Coverage sums equal areas to 1e-6 for random regions through every
 * kind of map; sampled pixels equal the exact pixel/region overlap. */
static void test_coverage_area(void)
{
	const int w = 400, h = 300;
	float *cov = malloc((size_t)w * h * sizeof *cov);
	struct paths raw, reg, px, ov;
	struct err e;

	paths_init(&raw);
	paths_init(&reg);
	paths_init(&px);
	paths_init(&ov);
	err_clear(&e);
	for (int trial = 0; trial < 40; trial++) {
		enum map_kind k = (enum map_kind)(trial % 5);
		double p = 0.05, cx = 30 + 10 * urand(), cy = 20 + 10 * urand();
		struct raster_map m = make_map(k, p, w, h, cx, cy);
		double area, got;

		paths_clear(&raw);
		star(&raw, cx, cy, 1 + 2 * urand(), 6, 5 + (int)(200 * urand()));
		if (trial % 2) /* a hole and an overlapping second body */
			star(&raw, cx + 0.3, cy - 0.2, 0.2, 0.8, 12), path_reverse(&raw.v[1]);
		if (trial % 4 == 3)
			star(&raw, cx + 4, cy + 1, 1, 2.5, 30);
		REQUIRE_OK(clip_union(&raw, CLIP_FILL_NONZERO, &reg, &e), &e);
		area = paths_area_mm2(&reg);
		memset(cov, 0, (size_t)w * h * sizeof *cov);
		REQUIRE_OK(slice_coverage(&reg, &m, cov, w, h, (size_t)w, &e), &e);
		got = sum_f(cov, (size_t)w * h) * raster_map_pixel_area_mm2(&m);
		CHECK_REL(got, area, 1e-6);
		/* per-pixel exactness on a few boundary and interior pixels */
		for (int q = 0; q < 60; q++) {
			int i = (int)(w * urand()), j = (int)(h * urand());
			double exact;
			pixel_poly(&m, i, j, &px);
			REQUIRE_OK(clip_boolean(CLIP_INTERSECTION, &reg, &px, CLIP_FILL_NONZERO, &ov, &e),
				   &e);
			exact = paths_area_mm2(&ov) / raster_map_pixel_area_mm2(&m);
			CHECK_NEAR(cov[(size_t)j * w + i], exact, 1e-4);
		}
	}
	paths_fini(&raw);
	paths_fini(&reg);
	paths_fini(&px);
	paths_fini(&ov);
	free(cov);
}

/* A region larger than the image: coverage equals the area of its part
 * inside the image (left/right/top/bottom clipping). */
static void test_clipped(void)
{
	const int w = 120, h = 80;
	float *cov = calloc((size_t)w * h, sizeof *cov);
	struct paths reg, img, ov;
	struct err e;
	struct raster_map m;

	paths_init(&reg);
	paths_init(&img);
	paths_init(&ov);
	err_clear(&e);
	for (int trial = 0; trial < 10; trial++) {
		m = make_map((enum map_kind)(trial % 5), 0.1, w, h, 0, 0);
		paths_clear(&reg);
		star(&reg, 8 * urand() - 4, 8 * urand() - 4, 3, 9, 40);
		pixel_poly(&m, 0, 0, &img); /* then widen to the whole image */
		{
			double x, y;
			const double c[4][2] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
			for (int k = 0; k < 4; k++) {
				raster_map_invert(&m, c[k][0], c[k][1], &x, &y);
				img.v[0].pts[k] = (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)};
			}
		}
		REQUIRE_OK(clip_boolean(CLIP_INTERSECTION, &reg, &img, CLIP_FILL_NONZERO, &ov, &e), &e);
		memset(cov, 0, (size_t)w * h * sizeof *cov);
		REQUIRE_OK(slice_coverage(&reg, &m, cov, w, h, (size_t)w, &e), &e);
		CHECK_REL(sum_f(cov, (size_t)w * h) * raster_map_pixel_area_mm2(&m),
			  paths_area_mm2(&ov), 1e-5);
	}
	/* entirely outside: nothing drawn */
	paths_clear(&reg);
	star(&reg, 500, 500, 1, 2, 10);
	memset(cov, 0, (size_t)w * h * sizeof *cov);
	REQUIRE_OK(slice_coverage(&reg, &m, cov, w, h, (size_t)w, &e), &e);
	CHECK_NEAR(sum_f(cov, (size_t)w * h), 0, 0);
	paths_fini(&reg);
	paths_fini(&img);
	paths_fini(&ov);
	free(cov);
}

/* 8-bit output: the sum matches the area within the quantisation of
 * the partial pixels, and interior pixels are exactly 255. */
static void test_raster_u8(void)
{
	struct raster *r = raster_new(1440, 2560);
	struct paths reg;
	struct err e;

	REQUIRE(r);
	paths_init(&reg);
	err_clear(&e);
	for (int trial = 0; trial < 6; trial++) {
		struct raster_map m = make_map(trial % 2 ? MAP_SL1 : MAP_ROT30, 0.04725, r->w, r->h,
					       60.48, 34.02);
		size_t partial = 0;
		double cx, cy, area;
		paths_clear(&reg);
		star(&reg, 60.48, 34.02, 5, 25, 300);
		area = paths_area_mm2(&reg);
		raster_clear(r);
		REQUIRE_OK(slice_rasterize(&reg, &m, 1, r, &e), &e);
		for (size_t i = 0; i < (size_t)r->w * r->h; i++)
			partial += r->px[i] != 0 && r->px[i] != 255;
		CHECK_NEAR(raster_coverage_px(r) * raster_map_pixel_area_mm2(&m), area,
			   (partial * 0.5 / 255 + 1) * raster_map_pixel_area_mm2(&m));
		/* the centre pixel is fully covered */
		raster_map_apply(&m, 60.48, 34.02, &cx, &cy);
		CHECK_EQ_INT(r->px[(size_t)cy * r->stride + (size_t)cx], 255);
	}
	paths_fini(&reg);
	raster_free(r);
}

/* SL1 orientation: a 1 mm square at printer (X, Y) lands at column
 * Y / p, row (120.96 - X) / p (REFERENCE.md section 1). */
static void test_sl1_orientation(void)
{
	struct raster *r = raster_new(1440, 2560);
	struct raster_map m = make_map(MAP_SL1, 0.04725, 1440, 2560, 60.48, 34.02);
	struct paths reg;
	struct err e;
	const double X = 20, Y = 50;
	struct pt2 sq[4] = {{geom_mm_to_nm(X), geom_mm_to_nm(Y)},
			    {geom_mm_to_nm(X + 1), geom_mm_to_nm(Y)},
			    {geom_mm_to_nm(X + 1), geom_mm_to_nm(Y + 1)},
			    {geom_mm_to_nm(X), geom_mm_to_nm(Y + 1)}};
	int i0 = 1440, i1 = -1, j0 = 2560, j1 = -1;

	REQUIRE(r);
	paths_init(&reg);
	err_clear(&e);
	paths_add_pts(&reg, sq, 4);
	REQUIRE_OK(slice_rasterize(&reg, &m, 0, r, &e), &e);
	for (int j = 0; j < r->h; j++)
		for (int i = 0; i < r->w; i++)
			if (r->px[(size_t)j * r->stride + i]) {
				i0 = i < i0 ? i : i0, i1 = i > i1 ? i : i1;
				j0 = j < j0 ? j : j0, j1 = j > j1 ? j : j1;
			}
	CHECK_EQ_INT(i0, (int)floor(Y / 0.04725 + 0.5));
	CHECK_EQ_INT(i1, (int)floor((Y + 1) / 0.04725 - 0.5));
	CHECK_EQ_INT(j0, (int)floor((120.96 - X - 1) / 0.04725 + 0.5));
	CHECK_EQ_INT(j1, (int)floor((120.96 - X) / 0.04725 - 0.5));
	paths_fini(&reg);
	raster_free(r);
}

/* Binary mode: a pixel is lit iff its centre is inside (nonzero). */
static void test_binary(void)
{
	const int w = 200, h = 160;
	struct raster *r = raster_new(w, h);
	struct paths raw, reg;
	struct err e;
	long mismatches = 0, lit = 0, checked = 0;

	paths_init(&raw);
	paths_init(&reg);
	err_clear(&e);
	for (int trial = 0; trial < 20; trial++) {
		struct raster_map m = make_map((enum map_kind)(trial % 5), 0.1, w, h, 5, 5);
		paths_clear(&raw);
		star(&raw, 5, 5, 1, 7, 7 + (int)(100 * urand()));
		star(&raw, 4, 5.5, 0.5, 1.5, 9);
		path_reverse(&raw.v[1]);
		/* raw, not normalised: nonzero of a hole overlapping the body */
		raster_clear(r);
		REQUIRE_OK(slice_rasterize(&raw, &m, 0, r, &e), &e);
		for (int j = 0; j < h; j++) {
			for (int i = 0; i < w; i++) {
				double x, y;
				struct pt2 q;
				int in, px = r->px[(size_t)j * r->stride + i];
				raster_map_invert(&m, i + 0.5, j + 0.5, &x, &y);
				q = (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)};
				if (paths_distance_mm(&raw, q) < 1e-5)
					continue; /* centre on an edge: either answer is right */
				in = paths_winding(&raw, q) != 0;
				CHECK(px == 0 || px == 255);
				mismatches += in != (px == 255);
				lit += px == 255;
				checked++;
			}
		}
	}
	CHECK_EQ_INT(mismatches, 0);
	CHECK_INT(lit, >, checked / 10);
	paths_fini(&raw);
	paths_fini(&reg);
	raster_free(r);
}

/* Nonzero rule on raw input: overlapping bodies count once, a lone
 * clockwise loop is material too; pixels combine by max. */
static void test_fill_rule_and_max(void)
{
	const int w = 100, h = 100;
	float *cov = calloc((size_t)w * h, sizeof *cov);
	struct raster *r = raster_new(w, h);
	struct raster_map m = make_map(MAP_PLAIN, 0.1, w, h, 5, 5);
	struct paths raw;
	struct err e;
	struct pt2 a[4] = {{0, 0}, {4000000, 0}, {4000000, 4000000}, {0, 4000000}};
	struct pt2 b[4] = {{2000000, 2000000}, {6000000, 2000000}, {6000000, 6000000},
			   {2000000, 6000000}};

	paths_init(&raw);
	err_clear(&e);
	paths_add_pts(&raw, a, 4);
	paths_add_pts(&raw, b, 4);
	REQUIRE_OK(slice_coverage(&raw, &m, cov, w, h, (size_t)w, &e), &e);
	CHECK_REL(sum_f(cov, (size_t)w * h) * 0.01, 28, 1e-9);
	path_reverse(&raw.v[0]);
	path_reverse(&raw.v[1]);
	memset(cov, 0, (size_t)w * h * sizeof *cov);
	REQUIRE_OK(slice_coverage(&raw, &m, cov, w, h, (size_t)w, &e), &e);
	CHECK_REL(sum_f(cov, (size_t)w * h) * 0.01, 28, 1e-9);
	/* max-combining: a pre-set 100 survives where coverage is smaller */
	memset(r->px, 100, (size_t)w * h);
	raw.n = 1;
	REQUIRE_OK(slice_rasterize(&raw, &m, 1, r, &e), &e);
	CHECK_EQ_INT(r->px[(size_t)99 * w + 99], 100); /* outside square a */
	CHECK_EQ_INT(r->px[(size_t)10 * w + 10], 255); /* inside it (clockwise) */
	raw.n = 2;
	paths_fini(&raw);
	raster_free(r);
	free(cov);
}

static void test_bad_map(void)
{
	struct raster *r = raster_new(10, 10);
	struct raster_map m = {{{1, 2}, {2, 4}}, {0, 0}};
	struct paths reg;
	struct err e;
	struct pt2 a[3] = {{0, 0}, {1000000, 0}, {0, 1000000}};

	paths_init(&reg);
	err_clear(&e);
	paths_add_pts(&reg, a, 3);
	CHECK_EQ_INT(slice_rasterize(&reg, &m, 1, r, &e), ERR_PARAM);
	m.a[1][1] = 5;
	m.b[0] = NAN;
	CHECK_EQ_INT(slice_rasterize(&reg, &m, 1, r, &e), ERR_PARAM);
	m.b[0] = 0;
	CHECK_EQ_INT(slice_coverage(&reg, &m, NULL, 0, 10, 10, &e), ERR_PARAM);
	/* empty region: nothing to do */
	paths_clear(&reg);
	CHECK_EQ_INT(slice_rasterize(&reg, &m, 1, r, &e), 0);
	paths_fini(&reg);
	raster_free(r);
}

static void test_alloc_failures(void)
{
	struct raster *r = raster_new(300, 300);
	struct raster_map m = make_map(MAP_ROT30, 0.05, 300, 300, 0, 0);
	struct paths reg;
	int n, failed = 0;

	paths_init(&reg);
	star(&reg, 0, 0, 2, 6, 100);
	for (n = 1; n < 50; n++) {
		struct err e;
		int rc;
		err_clear(&e);
		mem_fail_after(n);
		rc = slice_rasterize(&reg, &m, n & 1, r, &e);
		mem_fail_after(-1);
		if (!rc)
			break;
		CHECK_EQ_INT(rc, ERR_NOMEM);
		failed++;
	}
	CHECK_INT(failed, >=, 2);
	CHECK_INT(n, <, 50);
	paths_fini(&reg);
	raster_free(r);
}

int main(void)
{
	RUN(test_coverage_area);
	RUN(test_clipped);
	RUN(test_raster_u8);
	RUN(test_sl1_orientation);
	RUN(test_binary);
	RUN(test_fill_rule_and_max);
	RUN(test_bad_map);
	RUN(test_alloc_failures);
	return harness_report();
}
