/* test_label.c - 8-connected labelling (engine/geom/label.c) against a
 * flood fill written here: on random images of several densities and
 * shapes, both partitions agree (same pixels together), labels run
 * 1..count in raster order of each component's first pixel, and
 * label_sizes adds up.  Hand cases: corner contact joins, an empty image,
 * a U whose arms meet only in the last row (one label despite the first
 * pass giving two), allocation failure.
 */
#include "harness.h"

#include <stdint.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/label.h"

/* Flood labels in raster order of first pixel; returns the count. */
static int32_t flood(const uint8_t *m, int w, int h, int32_t *lab)
{
	size_t n = (size_t)w * (size_t)h, *st = malloc((n + 1) * sizeof *st);
	int32_t c = 0;

	for (size_t i = 0; i < n; i++)
		lab[i] = 0;
	for (size_t i = 0; i < n; i++) {
		size_t sp = 0;
		if (!m[i] || lab[i])
			continue;
		lab[i] = ++c;
		st[sp++] = i;
		while (sp) {
			size_t q = st[--sp];
			int x = (int)(q % (size_t)w), y = (int)(q / (size_t)w);
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					int a = x + dx, b = y + dy;
					size_t r;
					if (a < 0 || b < 0 || a >= w || b >= h)
						continue;
					r = (size_t)b * (size_t)w + (size_t)a;
					if (m[r] && !lab[r]) {
						lab[r] = c;
						st[sp++] = r;
					}
				}
		}
	}
	free(st);
	return c;
}

static void test_random(void)
{
	static const int dims[4][2] = {{1, 1}, {1, 37}, {53, 1}, {61, 47}};
	uint64_t seed = 88172645463325252ull;

	for (int d = 0; d < 4; d++)
		for (int k = 0; k < 5; k++) {
			int w = dims[d][0], h = dims[d][1];
			size_t n = (size_t)w * (size_t)h;
			uint8_t *m = malloc(n);
			int32_t *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), ca = -1, cb;
			size_t *sz;
			struct err e;
			for (size_t i = 0; i < n; i++)
				m[i] = (harness_xorshift64(&seed) % 100) < (uint64_t)(20 * k + 5)
				           ? 7
				           : 0;
			REQUIRE_OK(label_components8(m, w, h, a, &ca, &e), &e);
			cb = flood(m, w, h, b);
			CHECK_EQ_INT(ca, cb);
			/* same numbering rule, so the labels agree pixel for pixel */
			for (size_t i = 0; i < n; i++)
				if (a[i] != b[i]) {
					CHECK_EQ_INT(a[i], b[i]);
					break;
				}
			sz = malloc(((size_t)ca + 1) * sizeof *sz);
			label_sizes(a, n, ca, sz);
			{
				size_t tot = 0, off = 0;
				for (int32_t l = 0; l <= ca; l++)
					tot += sz[l];
				for (size_t i = 0; i < n; i++)
					off += !m[i];
				CHECK_EQ_INT(tot, n);
				CHECK_EQ_INT(sz[0], off);
			}
			free(sz);
			free(m);
			free(a);
			free(b);
		}
}

static void test_cases(void)
{
	/* U shape: arms 0 and 4 meet only in row 3; (5, 4) touches (4, 3)
	 * at a corner; (6, 0) is alone */
	static const char *img[5] = {"x...x.x", "x...x..", "x...x..", "xxxxx..", ".....x."};
	uint8_t m[35];
	int32_t lab[35], count = -1;
	struct err e;
	long fails = 0;

	for (int y = 0; y < 5; y++)
		for (int x = 0; x < 7; x++)
			m[y * 7 + x] = img[y][x] == 'x';
	REQUIRE_OK(label_components8(m, 7, 5, lab, &count, &e), &e);
	CHECK_EQ_INT(count, 2);
	CHECK_EQ_INT(lab[0], 1);
	CHECK_EQ_INT(lab[4], 1);
	CHECK_EQ_INT(lab[6], 2);
	CHECK_EQ_INT(lab[4 * 7 + 5], 1);
	memset(m, 0, sizeof m);
	REQUIRE_OK(label_components8(m, 7, 5, lab, &count, &e), &e);
	CHECK_EQ_INT(count, 0);
	/* allocation failure: ERR_NOMEM, count untouched */
	for (int i = 0; i < 35; i++)
		m[i] = (uint8_t)(i % 3 == 0);
	for (long n = 1; n < 10; n++) {
		int rc;
		count = -5;
		mem_fail_after(n);
		rc = label_components8(m, 7, 5, lab, &count, &e);
		mem_fail_after(-1);
		if (rc == 0)
			break;
		CHECK_EQ_INT(rc, ERR_NOMEM);
		CHECK_EQ_INT(count, -5);
		fails++;
	}
	CHECK(fails >= 1);
}

int main(void)
{
	RUN(test_random);
	RUN(test_cases);
	return harness_report();
}
