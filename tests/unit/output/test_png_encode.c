/* test_png_encode.c - the layer PNG encoder against libpng's decoder.
 *
 * Every image is encoded by out_png_gray() and decoded by libpng (which
 * inflates with zlib and checks the Adler-32 and chunk CRCs); pixels must
 * round-trip exactly and the measured coverage/box must match a direct
 * count.  Shapes cover each code path: long runs, literals, multi-block
 * streams, widths not a multiple of 8, padded strides, content hints.
 */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"
#include "engine/output/image/image.h"
#include "harness.h"

#include <png.h>
#include <stdint.h>

/* xorshift: deterministic test data */
static uint32_t rng_state = 2463534242u;
static uint32_t rnd(void)
{
	rng_state ^= rng_state << 13;
	rng_state ^= rng_state >> 17;
	rng_state ^= rng_state << 5;
	return rng_state;
}

static struct raster *make(int w, int h, size_t stride)
{
	struct raster *r = mem_calloc(1, sizeof *r);
	r->w = w;
	r->h = h;
	r->stride = stride;
	r->px = mem_calloc((size_t)h, stride);
	return r;
}

static void drop(struct raster *r)
{
	mem_free(r->px);
	mem_free(r);
}

/* Encode, decode with libpng, compare; returns 0 when all matched. */
static int roundtrip(const struct raster *r, const struct out_px_rect *hint, size_t *png_len)
{
	struct buf png;
	struct err e;
	struct out_png_stats st;
	png_image img;
	uint8_t *dec;
	uint64_t sum = 0;
	int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1, bad = 0;

	buf_init(&png);
	err_clear(&e);
	if (out_png_gray(r, hint, NULL, &png, &st, &e) != 0) {
		fprintf(stderr, "encode failed: %s\n", e.msg);
		buf_fini(&png);
		return 1;
	}
	if (png_len)
		*png_len = png.len;
	memset(&img, 0, sizeof img);
	img.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&img, png.data, png.len)) {
		fprintf(stderr, "libpng: %s\n", img.message);
		buf_fini(&png);
		return 1;
	}
	CHECK_EQ_INT(img.width, r->w);
	CHECK_EQ_INT(img.height, r->h);
	CHECK_EQ_INT(img.format, PNG_FORMAT_GRAY);
	img.format = PNG_FORMAT_GRAY;
	dec = malloc((size_t)r->w * (size_t)r->h);
	if (!png_image_finish_read(&img, NULL, dec, r->w, NULL)) {
		fprintf(stderr, "libpng: %s\n", img.message);
		free(dec);
		buf_fini(&png);
		return 1;
	}
	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++) {
			uint8_t v = r->px[(size_t)y * r->stride + (size_t)x];
			if (dec[(size_t)y * (size_t)r->w + (size_t)x] != v)
				bad++;
			if (v) {
				sum += v;
				x0 = x < x0 ? x : x0;
				x1 = x > x1 ? x : x1;
				y0 = y < y0 ? y : y0;
				y1 = y > y1 ? y : y1;
			}
		}
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.sum, sum);
	if (x1 >= 0) {
		CHECK_EQ_INT(st.nz.x0, x0);
		CHECK_EQ_INT(st.nz.x1, x1);
		CHECK_EQ_INT(st.nz.y0, y0);
		CHECK_EQ_INT(st.nz.y1, y1);
	} else {
		CHECK(st.nz.x0 > st.nz.x1);
	}
	free(dec);
	buf_fini(&png);
	return bad;
}

static void test_black_and_white(void)
{
	int sizes[][2] = {{1, 1}, {7, 3}, {8, 8}, {9, 2}, {1440, 64}, {33, 1}};

	for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
		struct raster *r = make(sizes[k][0], sizes[k][1], (size_t)sizes[k][0]);
		CHECK_EQ_INT(roundtrip(r, NULL, NULL), 0);
		memset(r->px, 255, r->stride * (size_t)r->h);
		CHECK_EQ_INT(roundtrip(r, NULL, NULL), 0);
		drop(r);
	}
}

/* An anti-aliased disk: the typical layer, mostly runs. */
static void test_disk_with_edges(void)
{
	struct raster *r = make(1440, 400, 1440);
	size_t len = 0;

	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++) {
			double d = hypot(x + 0.5 - 700, y + 0.5 - 210) - 150;
			double c = d < -0.5 ? 1 : d > 0.5 ? 0 : 0.5 - d;
			r->px[(size_t)y * r->stride + (size_t)x] = (uint8_t)lround(c * 255);
		}
	CHECK_EQ_INT(roundtrip(r, NULL, &len), 0);
	CHECK(len < 8000); /* runs compress: 576 KB of pixels */
	drop(r);
}

/* Noise: every byte a literal, several deflate blocks; a padded stride. */
static void test_noise_multiblock(void)
{
	struct raster *r = make(301, 257, 320);

	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++)
			r->px[(size_t)y * r->stride + (size_t)x] = (uint8_t)rnd();
	CHECK_EQ_INT(roundtrip(r, NULL, NULL), 0);
	/* skewed noise: few values, long Huffman codes get limited */
	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++) {
			uint32_t v = rnd();
			int k = __builtin_ctz(v | 0x80000u);
			r->px[(size_t)y * r->stride + (size_t)x] = (uint8_t)(k * 13 + (v >> 30));
		}
	CHECK_EQ_INT(roundtrip(r, NULL, NULL), 0);
	drop(r);
}

/* Runs of every length around the 258-byte match limit. */
static void test_run_lengths(void)
{
	struct raster *r = make(1100, 1, 1100);

	for (int len = 1; len <= 530; len += 1) {
		memset(r->px, 0, r->stride);
		memset(r->px + 5, 200, (size_t)len);
		if (roundtrip(r, NULL, NULL)) {
			fprintf(stderr, "run length %d failed\n", len);
			break;
		}
	}
	drop(r);
}

/* Content hint: pixels outside are promised zero and not read. */
static void test_content_hint(void)
{
	struct raster *r = make(200, 120, 200);
	struct out_px_rect hint = {40, 30, 150, 99}, empty = {10, 10, 5, 5};

	for (int y = 30; y <= 99; y++)
		for (int x = 40; x <= 150; x++)
			if ((x - 95) * (x - 95) + (y - 64) * (y - 64) < 900)
				r->px[(size_t)y * r->stride + (size_t)x] = (uint8_t)(x + y);
	CHECK_EQ_INT(roundtrip(r, &hint, NULL), 0);
	memset(r->px, 0, r->stride * (size_t)r->h);
	CHECK_EQ_INT(roundtrip(r, &empty, NULL), 0);
	drop(r);
}

/* One scratch across images of different sizes and content. */
static void test_scratch_reuse(void)
{
	struct out_png_scratch sc;
	struct raster *a = make(500, 300, 500), *b = make(37, 11, 40);
	struct buf pa, pb, ref;
	struct err e;

	memset(&sc, 0, sizeof sc);
	for (size_t i = 0; i < (size_t)a->h * a->stride; i++)
		a->px[i] = (uint8_t)(rnd() & 0x81);
	memset(b->px + 40 * 3, 7, 30);
	buf_init(&pa);
	buf_init(&pb);
	buf_init(&ref);
	REQUIRE_OK(out_png_gray(a, NULL, &sc, &pa, NULL, &e), &e);
	REQUIRE_OK(out_png_gray(b, NULL, &sc, &pb, NULL, &e), &e);
	REQUIRE_OK(out_png_gray(b, NULL, NULL, &ref, NULL, &e), &e);
	CHECK_EQ_INT(pb.len, ref.len);
	CHECK(memcmp(pb.data, ref.data, ref.len) == 0);
	buf_reset(&pa);
	REQUIRE_OK(out_png_gray(a, NULL, &sc, &pa, NULL, &e), &e);
	CHECK_EQ_INT(roundtrip(a, NULL, NULL), 0);
	out_png_scratch_fini(&sc);
	buf_fini(&pa);
	buf_fini(&pb);
	buf_fini(&ref);
	drop(a);
	drop(b);
}

static void test_rgba(void)
{
	int w = 40, h = 30;
	uint8_t *rgba = malloc((size_t)w * (size_t)h * 4), *dec = malloc((size_t)w * (size_t)h * 4);
	struct buf png;
	struct err e;
	png_image img;

	for (int i = 0; i < w * h * 4; i++)
		rgba[i] = (uint8_t)(i * 7);
	buf_init(&png);
	REQUIRE_OK(out_png_rgba(rgba, w, h, &png, &e), &e);
	memset(&img, 0, sizeof img);
	img.version = PNG_IMAGE_VERSION;
	REQUIRE(png_image_begin_read_from_memory(&img, png.data, png.len));
	CHECK_EQ_INT(img.format, PNG_FORMAT_RGBA);
	img.format = PNG_FORMAT_RGBA;
	REQUIRE(png_image_finish_read(&img, NULL, dec, 0, NULL));
	CHECK_EQ_INT(memcmp(dec, rgba, (size_t)w * (size_t)h * 4), 0);
	buf_fini(&png);
	free(rgba);
	free(dec);
}

/* Every allocation failing in turn: ERR_NOMEM, buffer unchanged, no leak. */
static void test_alloc_failures(void)
{
	struct raster *r = make(300, 200, 300);
	struct buf png;
	struct err e;
	int ok = 0;

	for (int y = 50; y < 150; y++)
		memset(r->px + (size_t)y * r->stride + 20, 255, 200);
	buf_init(&png);
	REQUIRE(buf_append(&png, "xyz", 3) == 0);
	for (long n = 1; n < 200 && !ok; n++) {
		int rc;
		mem_fail_after(n);
		rc = out_png_gray(r, NULL, NULL, &png, NULL, &e);
		mem_fail_after(-1);
		if (rc == 0) {
			ok = 1;
		} else {
			CHECK_EQ_INT(rc, ERR_NOMEM);
			CHECK_EQ_INT(png.len, 3);
		}
	}
	CHECK(ok);
	buf_fini(&png);
	drop(r);
}

int main(void)
{
	RUN(test_black_and_white);
	RUN(test_disk_with_edges);
	RUN(test_noise_multiblock);
	RUN(test_run_lengths);
	RUN(test_content_hint);
	RUN(test_scratch_reuse);
	RUN(test_rgba);
	RUN(test_alloc_failures);
	return harness_report();
}
