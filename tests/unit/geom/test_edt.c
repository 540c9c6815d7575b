/* test_edt.c - exact Euclidean distance and feature transforms (geom/edt.h)
 * against brute force: random seed images of several densities and
 * shapes, unequal pixel pitches, no seeds, one seed, a scratch reused
 * across sizes.  The feature transform's pixel must be a seed at exactly
 * the brute-force distance (any of them on ties).
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"

static uint64_t rng = 0x9e3779b97f4a7c15ULL;
static uint64_t xs(void)
{
	return harness_xorshift64(&rng);
}

/* Brute-force squared distance from (x, y) to the nearest seed, mm^2. */
static double brute(const uint8_t *seed, int w, int h, int x, int y, double px, double py)
{
	double best = INFINITY;

	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++)
			if (seed[(size_t)j * (size_t)w + (size_t)i]) {
				double dx = (i - x) * px, dy = (j - y) * py;
				best = fmin(best, dx * dx + dy * dy);
			}
	return best;
}

static void check_image(const uint8_t *seed, int w, int h, double px, double py,
			struct edt_scratch *s)
{
	size_t n = (size_t)w * (size_t)h;
	float *d2 = mem_alloc(n * sizeof *d2), *d2b = mem_alloc(n * sizeof *d2b);
	int32_t *near = mem_alloc(n * sizeof *near);
	struct err e;
	int bad = 0;

	err_clear(&e);
	REQUIRE(d2 && d2b && near);
	REQUIRE_OK(edt_sq(seed, (size_t)w, w, h, px, py, d2, s, &e), &e);
	REQUIRE_OK(edt_nearest_sq(seed, (size_t)w, w, h, px, py, d2b, near, s, &e), &e);
	for (int y = 0; y < h && bad < 5; y++)
		for (int x = 0; x < w && bad < 5; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			double b = brute(seed, w, h, x, y, px, py);
			if (!isfinite(b)) {
				CHECK(!isfinite(d2[i]) && !isfinite(d2b[i]) && near[i] == -1);
				bad += !(!isfinite(d2[i]) && near[i] == -1);
				continue;
			}
			/* float storage: relative 1e-6 */
			if (fabs(d2[i] - b) > 1e-6 * b + 1e-12 || fabs(d2b[i] - b) > 1e-6 * b + 1e-12 ||
			    near[i] < 0 || (size_t)near[i] >= n || !seed[near[i]]) {
				CHECK_NEAR(d2[i], b, 1e-6 * b + 1e-12);
				CHECK_NEAR(d2b[i], b, 1e-6 * b + 1e-12);
				CHECK(near[i] >= 0 && (size_t)near[i] < n && seed[near[i]]);
				bad++;
				continue;
			}
			{
				double dx = (near[i] % w - x) * px, dy = (near[i] / w - y) * py;
				CHECK_NEAR(dx * dx + dy * dy, b, 1e-9 * b + 1e-15);
				bad += fabs(dx * dx + dy * dy - b) > 1e-9 * b + 1e-15;
			}
		}
	mem_free(d2);
	mem_free(d2b);
	mem_free(near);
}

static void test_random_images(void)
{
	/* widths across the column pass's blocks of 16: one partial block,
	 * whole blocks, whole blocks and a partial one (101, 16 x 6 + 5) */
	static const int size[][2] = {{1, 1},  {1, 17},  {23, 1}, {31, 19},
				      {40, 40}, {64, 37}, {101, 9}, {16, 70}};
	static const int permille[] = {0, 1, 20, 300, 950};
	struct edt_scratch s;

	edt_scratch_init(&s);
	for (size_t k = 0; k < sizeof size / sizeof size[0]; k++)
		for (size_t d = 0; d < sizeof permille / sizeof permille[0]; d++)
			for (int pitch = 0; pitch < 2; pitch++) {
				int w = size[k][0], h = size[k][1];
				uint8_t *seed = mem_calloc((size_t)w * (size_t)h, 1);
				REQUIRE(seed);
				for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
					seed[i] = (int)(xs() % 1000) < permille[d];
				check_image(seed, w, h, pitch ? 0.05 : 0.047, pitch ? 0.07 : 0.047,
					    &s);
				mem_free(seed);
			}
	edt_scratch_fini(&s);
}

/* One seed in a corner, and a ring: ties everywhere on the diagonal and
 * the ring's centre. */
static void test_shapes(void)
{
	enum { W = 45, H = 45 };
	static uint8_t seed[W * H];
	struct edt_scratch s;

	edt_scratch_init(&s);
	memset(seed, 0, sizeof seed);
	seed[0] = 1;
	check_image(seed, W, H, 0.1, 0.1, &s);
	memset(seed, 0, sizeof seed);
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			int r2 = (x - 22) * (x - 22) + (y - 22) * (y - 22);
			seed[y * W + x] = r2 >= 15 * 15 && r2 < 17 * 17;
		}
	check_image(seed, W, H, 0.1, 0.1, &s);
	check_image(seed, W, H, 0.03, 0.11, &s);
	edt_scratch_fini(&s);
}

/* edt3_sq against brute force on random 3D grids (the rhombic engine's
 * classification distance), with no seed and one seed. */
static void test_3d(void)
{
	static const int size[][3] = {{1, 1, 1}, {7, 5, 9}, {12, 10, 11}, {1, 16, 3}};
	static const int permille[] = {0, 2, 40, 500};
	struct err e;

	err_clear(&e);
	for (size_t k = 0; k < sizeof size / sizeof size[0]; k++)
		for (size_t p = 0; p < sizeof permille / sizeof permille[0]; p++) {
			int w = size[k][0], h = size[k][1], d = size[k][2], bad = 0;
			size_t n = (size_t)w * (size_t)h * (size_t)d;
			uint8_t *seed = mem_calloc(n, 1);
			float *out = mem_alloc(n * sizeof *out);
			REQUIRE(seed && out);
			for (size_t i = 0; i < n; i++)
				seed[i] = (int)(xs() % 1000) < permille[p];
			if (p == 1)
				seed[n / 2] = 1;
			REQUIRE_OK(edt3_sq(seed, w, h, d, 0.25, out, &e), &e);
			for (int z = 0; z < d && bad < 5; z++)
				for (int y = 0; y < h && bad < 5; y++)
					for (int x = 0; x < w && bad < 5; x++) {
						double best = INFINITY;
						for (size_t i = 0; i < n; i++)
							if (seed[i]) {
								double dx = ((int)(i % (size_t)w) - x) * 0.25;
								double dy = ((int)(i / (size_t)w % (size_t)h) - y) * 0.25;
								double dz = ((int)(i / ((size_t)w * (size_t)h)) - z) * 0.25;
								best = fmin(best, dx * dx + dy * dy + dz * dz);
							}
						float got = out[((size_t)z * (size_t)h + (size_t)y) * (size_t)w + (size_t)x];
						if (!isfinite(best)) {
							CHECK(!isfinite(got));
							bad += isfinite(got);
						} else if (fabs(got - best) > 1e-6 * best + 1e-12) {
							CHECK_NEAR(got, best, 1e-6 * best + 1e-12);
							bad++;
						}
					}
			mem_free(seed);
			mem_free(out);
		}
}

/* Threads: an image above the one-thread size (700 x 500) with 1 and 3
 * threads gives the same distances and features bit for bit, and 400
 * pixels of it agree with brute force; sparse seeds (long columns of
 * INFINITY) and dense ones. */
static void test_threads(void)
{
	enum { W = 700, H = 500, N = W * H };
	static const int permille[] = {1, 200};
	uint8_t *seed = mem_alloc(N);
	float *d1 = mem_alloc(N * sizeof *d1), *d3 = mem_alloc(N * sizeof *d3);
	int32_t *n1 = mem_alloc(N * sizeof *n1), *n3 = mem_alloc(N * sizeof *n3);
	struct edt_scratch s1, s3;
	struct err e;

	REQUIRE(seed && d1 && d3 && n1 && n3);
	err_clear(&e);
	edt_scratch_init(&s1);
	edt_scratch_init(&s3);
	s3.threads = 3;
	for (size_t d = 0; d < sizeof permille / sizeof permille[0]; d++) {
		for (size_t i = 0; i < N; i++)
			seed[i] = (int)(xs() % 1000) < permille[d];
		REQUIRE_OK(edt_nearest_sq(seed, W, W, H, 0.047, 0.05, d1, n1, &s1, &e), &e);
		REQUIRE_OK(edt_nearest_sq(seed, W, W, H, 0.047, 0.05, d3, n3, &s3, &e), &e);
		CHECK(memcmp(d1, d3, N * sizeof *d1) == 0);
		CHECK(memcmp(n1, n3, N * sizeof *n1) == 0);
		REQUIRE_OK(edt_sq(seed, W, W, H, 0.047, 0.05, d3, &s3, &e), &e);
		CHECK(memcmp(d1, d3, N * sizeof *d1) == 0);
		for (int k = 0; k < 400; k++) {
			int x = (int)(xs() % W), y = (int)(xs() % H);
			double b = brute(seed, W, H, x, y, 0.047, 0.05);
			CHECK_NEAR(d3[y * W + x], b, 1e-6 * b + 1e-12);
		}
	}
	edt_scratch_fini(&s1);
	edt_scratch_fini(&s3);
	mem_free(seed);
	mem_free(d1);
	mem_free(d3);
	mem_free(n1);
	mem_free(n3);
}

int main(void)
{
	RUN(test_random_images);
	RUN(test_threads);
	RUN(test_shapes);
	RUN(test_3d);
	return harness_report();
}
