/* test_capsule.c - capsule sections (geom/capsule.h) against a brute-force
 * point-in-capsule test: row intervals of random capsules and rows, the
 * union raster on random capsules through axis-aligned, rotated and
 * mirrored maps, balls, horizontal and vertical segments, segments along
 * the rows; the z index gives the same images; threads do not change
 * them; bad maps are refused.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/capsule.h"
#include "engine/geom/raster.h"

static uint64_t rng = 0x2545f4914f6cdd1dULL;
static double uni(void)
{
	return (double)(harness_xorshift64(&rng) >> 11) / 9007199254740992.0;
}

/* Signed distance of p from the capsule's surface (< 0 inside), mm. */
static double capsule_sd(const struct capsule *c, struct vec3 p)
{
	struct vec3 d = v3_sub(c->b, c->a), w = v3_sub(p, c->a);
	double l2 = v3_len2(d), t = l2 > 0 ? v3_dot(w, d) / l2 : 0;

	t = fmin(fmax(t, 0), 1);
	return v3_dist(p, v3_madd(c->a, d, t)) - c->r_mm;
}

static struct capsule random_capsule(int kind)
{
	struct capsule c;
	double r = 0.2 + 1.5 * uni();

	c.a = v3(20 * uni() - 10, 20 * uni() - 10, 10 * uni() - 5);
	c.b = v3_add(c.a, v3(8 * uni() - 4, 8 * uni() - 4, 8 * uni() - 4));
	switch (kind) {
	case 1: c.b = c.a; break;            /* ball */
	case 2: c.b.z = c.a.z; break;        /* horizontal */
	case 3: c.b.x = c.a.x, c.b.y = c.a.y; break; /* vertical */
	case 4: c.b = v3(c.a.x + 5, c.a.y, c.a.z); break; /* along x */
	default: break;
	}
	c.r_mm = r;
	return c;
}

/* Every sampled point of the row agrees with the interval, except within
 * 1e-9 mm of the surface. */
static void test_row_interval(void)
{
	int bad = 0, hits = 0;

	for (int it = 0; it < 3000; it++) {
		struct capsule c = random_capsule(it % 5);
		double ang = 2 * M_PI * uni(), p = 0.05 + 0.3 * uni();
		struct vec3 s = v3(p * cos(ang), p * sin(ang), 0);
		struct vec3 o;
		double lo, hi;
		int hit;

		if (it % 7 == 0 && hypot(c.b.x - c.a.x, c.b.y - c.a.y) > 1e-6)
			/* a row along the axis's projection */
			s = v3_scale(v3_normalize(v3(c.b.x - c.a.x, c.b.y - c.a.y, 0)), p);
		o = v3_add(c.a, v3(6 * uni() - 3, 6 * uni() - 3, 4 * uni() - 2));
		o = v3_madd(o, s, -100);
		hit = capsule_row_interval(&c, o, s, &lo, &hi);
		hits += hit;
		for (int k = 0; k < 400; k++) {
			double u = k * 0.5 + 0.25 * uni();
			double sd = capsule_sd(&c, v3_madd(o, s, u));
			int in = hit && u > lo && u < hi;
			if (fabs(sd) > 1e-9 && in != (sd < 0))
				bad++;
		}
	}
	CHECK_EQ_INT(bad, 0);
	CHECK_INT(hits, >, 500);
	{
		/* zero radius never hits; a zero step is a point test */
		struct capsule c = {{0, 0, 0}, {1, 0, 0}, 0};
		double lo, hi;
		CHECK_EQ_INT(capsule_row_interval(&c, v3(0.5, 0, 0), v3(1, 0, 0), &lo, &hi), 0);
		c.r_mm = 0.5;
		CHECK_EQ_INT(capsule_row_interval(&c, v3(0.5, 0.2, 0), v3(0, 0, 0), &lo, &hi), 1);
		CHECK_EQ_INT(capsule_row_interval(&c, v3(0.5, 0.7, 0), v3(0, 0, 0), &lo, &hi), 0);
	}
}

/* Map of pitch p (mm), rotated by ang, optionally mirrored, with pixel
 * coordinates (uc, vc) at printer point (xc, yc). */
static struct raster_map make_map(double p, double ang, int mirror, double xc, double yc,
				  double uc, double vc)
{
	double c = cos(ang) / p, s = sin(ang) / p, m = mirror ? -1 : 1;
	struct raster_map mp = {{{c, -s}, {m * s, m * c}}, {0, 0}};

	mp.b[0] = uc - (mp.a[0][0] * xc + mp.a[0][1] * yc);
	mp.b[1] = vc - (mp.a[1][0] * xc + mp.a[1][1] * yc);
	return mp;
}

/* Pixels that disagree with the brute force by more than 1e-9 mm. */
static size_t brute_mismatch(const struct capsule *caps, size_t n, double z,
			     const struct raster_map *m, int w, int h, const uint8_t *img,
			     size_t *inside)
{
	size_t bad = 0;

	*inside = 0;
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++) {
			double x, y, sd = INFINITY;
			raster_map_invert(m, i + 0.5, j + 0.5, &x, &y);
			for (size_t k = 0; k < n; k++)
				sd = fmin(sd, capsule_sd(&caps[k], v3(x, y, z)));
			*inside += sd < 0;
			if (fabs(sd) > 1e-9 && (img[(size_t)j * w + i] != 0) != (sd < 0))
				bad++;
		}
	return bad;
}

static void test_union_vs_brute(void)
{
	enum { W = 160, H = 140, N = 60 };
	struct capsule caps[N];
	uint8_t *img = mem_alloc(W * H), *img4 = mem_alloc(W * H);
	struct err e;

	REQUIRE(img && img4);
	for (int trial = 0; trial < 12; trial++) {
		int kind = trial % 6; /* 0, 5: mixed; 1-4: all of one kind (4: along x) */
		/* axis-aligned maps first and for the segments along x (rows) */
		double ang = trial < 4 || kind == 4 ? 0 : 2 * M_PI * uni();
		struct raster_map m = make_map(0.1 + 0.05 * (trial % 3), ang, trial % 2,
					       2 * uni() - 1, 2 * uni() - 1, W / 2, H / 2);
		double z = 6 * uni() - 3;
		size_t inside, bad;

		for (int k = 0; k < N; k++)
			caps[k] = random_capsule(kind == 0 || kind == 5 ? k % 5 : kind);
		memset(img, 0, W * H);
		memset(img4, 0, W * H);
		REQUIRE_OK(capsule_union_raster(caps, N, z, &m, W, H, img, 1, &e), &e);
		REQUIRE_OK(capsule_union_raster(caps, N, z, &m, W, H, img4, 4, &e), &e);
		CHECK(memcmp(img, img4, W * H) == 0);
		bad = brute_mismatch(caps, N, z, &m, W, H, img, &inside);
		CHECK_EQ_INT(bad, 0);
		CHECK_INT(inside, >, 100);
		for (size_t q = 0; q < (size_t)W * H; q++)
			CHECK_INT(img[q], <=, 1);
	}
	/* pixels outside every section keep their value */
	{
		struct raster_map m = make_map(0.1, 0, 0, 0, 0, W / 2, H / 2);
		struct capsule c = {{0, 0, 0}, {0, 0, 0}, 1};
		size_t twos = 0;
		memset(img, 2, W * H);
		REQUIRE_OK(capsule_union_raster(&c, 1, 0, &m, W, H, img, 2, &e), &e);
		for (size_t q = 0; q < (size_t)W * H; q++)
			twos += img[q] == 2;
		/* a disc of radius 10 px: about 314 pixels set */
		CHECK_NEAR((double)(W * H - twos), M_PI * 100, 20);
	}
	mem_free(img);
	mem_free(img4);
}

/* A stack of planes through the z index equals the plain union raster. */
static void test_zindex(void)
{
	enum { W = 120, H = 100, N = 400 };
	struct capsule *caps = mem_alloc(N * sizeof *caps);
	uint8_t *a = mem_alloc(W * H), *b = mem_alloc(W * H);
	struct raster_map m = make_map(0.2, 0.3, 0, 0, 0, W / 2, H / 2);
	struct capsule_zindex *ix = NULL;
	struct err e;
	size_t set = 0;

	REQUIRE(caps && a && b);
	for (int k = 0; k < N; k++) {
		caps[k] = random_capsule(k % 5);
		caps[k].a.z *= 4; /* spread over z in [-20, 20] */
		caps[k].b.z = caps[k].a.z + (caps[k].b.z - caps[k].a.z) * 0.5;
	}
	caps[7].r_mm = 0;              /* unusable: skipped */
	caps[8].a.x = NAN;
	for (int s = 0; s < 3; s++) {
		double slab = s == 0 ? 0 : s == 1 ? 0.01 : 100;
		REQUIRE_OK(capsule_zindex_new(caps, N, slab, &ix, &e), &e);
		for (double z = -30; z < 30; z += 0.7) {
			memset(a, 0, W * H);
			memset(b, 0, W * H);
			REQUIRE_OK(capsule_union_raster(caps, N, z, &m, W, H, a, 2, &e), &e);
			REQUIRE_OK(capsule_zindex_raster(ix, z, &m, W, H, b, 2, &e), &e);
			CHECK(memcmp(a, b, W * H) == 0);
			for (size_t q = 0; q < (size_t)W * H; q++)
				set += a[q];
		}
		capsule_zindex_free(ix);
		ix = NULL;
	}
	CHECK_INT(set, >, 10000);
	capsule_zindex_free(NULL);
	REQUIRE_OK(capsule_zindex_new(caps, 0, 0, &ix, &e), &e);
	REQUIRE_OK(capsule_zindex_raster(ix, 0, &m, W, H, b, 1, &e), &e);
	capsule_zindex_free(ix);
	mem_free(caps);
	mem_free(a);
	mem_free(b);
}

static void test_errors(void)
{
	struct raster_map sing = {{{1, 2}, {2, 4}}, {0, 0}};
	struct capsule c = {{0, 0, 0}, {1, 0, 0}, 1};
	uint8_t img[4];
	struct err e;

	CHECK_EQ_INT(capsule_union_raster(&c, 1, 0, &sing, 2, 2, img, 1, &e), ERR_PARAM);
	CHECK_EQ_INT(capsule_union_raster(&c, 1, 0, &sing, 0, 2, img, 1, &e), ERR_PARAM);
	/* allocation failures are reported, nothing leaks (ASan) */
	{
		struct raster_map m = make_map(0.5, 0, 0, 0, 0, 1, 1);
		struct capsule_zindex *ix = NULL;
		for (long k = 1; k < 6; k++) {
			mem_fail_after(k);
			int rc = capsule_union_raster(&c, 1, 0, &m, 2, 2, img, 1, &e);
			mem_fail_after(-1);
			CHECK(rc == 0 || rc == ERR_NOMEM);
			mem_fail_after(k);
			rc = capsule_zindex_new(&c, 1, 0, &ix, &e);
			mem_fail_after(-1);
			CHECK(rc == 0 || rc == ERR_NOMEM);
			if (rc == 0)
				capsule_zindex_free(ix);
			ix = NULL;
		}
	}
}

int main(void)
{
	RUN(test_row_interval);
	RUN(test_union_vs_brute);
	RUN(test_zindex);
	RUN(test_errors);
	return harness_report();
}
