/* test_transient.c - the hybrid engine's transient layer and extended
 * support region (engine/hybrid/transient.c, paper 003 section 6) on
 * synthetic images, checked with a flood fill and a morphological
 * erosion written here: after bridging, US has one 8-connected region
 * wherever the mask connects, contains (MFS | TCS) & mask and nothing
 * outside the mask; a bridge is at least bridge_px wide, which is tested
 * as "the regions stay connected after eroding US by a disc of diameter
 * bridge_px"; its area stays near length x width; a single region is left
 * exactly as it was.  The support region keeps (TCS & US) regions of at
 * least min_px pixels and drops the rest.
 */
#include "harness.h"

#include <stdint.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hybrid/structure.h"

#define W 96
#define H 72
#define N (W * H)

static void disc(uint8_t *img, double cx, double cy, double r)
{
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++)
			if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r)
				img[y * W + x] = 1;
}

static void rect(uint8_t *img, int x0, int y0, int x1, int y1, uint8_t v)
{
	for (int y = y0; y <= y1; y++)
		for (int x = x0; x <= x1; x++)
			if (x >= 0 && y >= 0 && x < W && y < H)
				img[y * W + x] = v;
}

/* 8-connected components of img (nonzero), flood fill; lab may be NULL. */
static int components(const uint8_t *img, int *lab_out)
{
	static int lab[N], st[N];
	int c = 0;

	memset(lab, 0, sizeof lab);
	for (int i = 0; i < N; i++) {
		int sp = 0;
		if (!img[i] || lab[i])
			continue;
		lab[i] = ++c;
		st[sp++] = i;
		while (sp) {
			int q = st[--sp], qx = q % W, qy = q / W;
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					int x = qx + dx, y = qy + dy;
					if (x < 0 || y < 0 || x >= W || y >= H)
						continue;
					if (img[y * W + x] && !lab[y * W + x]) {
						lab[y * W + x] = c;
						st[sp++] = y * W + x;
					}
				}
		}
	}
	if (lab_out)
		memcpy(lab_out, lab, sizeof lab);
	return c;
}

/* Pixels all of whose pixels within r (centre distance) are set. */
static void erode(const uint8_t *img, double r, uint8_t *out)
{
	int ri = (int)floor(r);
	for (int y = 0; y < H; y++)
		for (int x = 0; x < W; x++) {
			int ok = img[y * W + x] != 0;
			for (int dy = -ri; ok && dy <= ri; dy++)
				for (int dx = -ri; ok && dx <= ri; dx++) {
					int a = x + dx, b = y + dy;
					if (dx * dx + dy * dy > r * r * (1 + 1e-12))
						continue;
					if (a < 0 || b < 0 || a >= W || b >= H || !img[b * W + a])
						ok = 0;
				}
			out[y * W + x] = (uint8_t)ok;
		}
}

/* us contains (mfs | tcs) & mask and lies inside mask; returns the
 * number of pixels added. */
static int check_subsets(const uint8_t *mfs, const uint8_t *tcs, const uint8_t *mask,
                         const uint8_t *us)
{
	int added = 0, lost = 0, outside = 0;
	for (int i = 0; i < N; i++) {
		int base = (mfs[i] || tcs[i]) && mask[i];
		lost += base && !us[i];
		outside += us[i] && !mask[i];
		added += us[i] && !base;
		CHECK(us[i] == 0 || us[i] == 1);
	}
	CHECK_EQ_INT(lost, 0);
	CHECK_EQ_INT(outside, 0);
	return added;
}

static uint8_t g_mfs[N], g_tcs[N], g_mask[N], g_us[N], g_er[N];

static void clear_all(void)
{
	memset(g_mfs, 0, N);
	memset(g_tcs, 0, N);
	memset(g_mask, 1, N);
	memset(g_us, 0xAA, N);
}

static void test_two_blobs(void)
{
	static const double widths[4] = {1, 3, 4, 6.5};
	static const double pos[3][4] = {{22, 36, 70, 36}, {20, 18, 72, 54}, {24, 50, 66, 20}};

	for (int p = 0; p < 3; p++)
		for (int k = 0; k < 4; k++) {
			struct err e;
			int added, lab[N];
			double gap;
			clear_all();
			disc(g_mfs, pos[p][0], pos[p][1], 9); /* one blob from MFS, one from TCS */
			disc(g_tcs, pos[p][2], pos[p][3], 7.5);
			CHECK_EQ_INT(components(g_mfs, NULL) + components(g_tcs, NULL), 2);
			REQUIRE_OK(
			    hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, widths[k], g_us, &e),
			    &e);
			added = check_subsets(g_mfs, g_tcs, g_mask, g_us);
			CHECK_EQ_INT(components(g_us, NULL), 1);
			/* width: the blobs' cores stay connected after eroding by the
			 * bridge's half width */
			erode(g_us, widths[k] / 2, g_er);
			components(g_er, lab);
			CHECK(lab[(int)pos[p][1] * W + (int)pos[p][0]] != 0);
			CHECK_EQ_INT(lab[(int)pos[p][1] * W + (int)pos[p][0]],
			             lab[(int)pos[p][3] * W + (int)pos[p][2]]);
			/* material: about gap x width (a digital line of a diagonal
			 * gap has gap / sqrt 2 pixels), at most (gap + w + 2)(w + 2) */
			gap = hypot(pos[p][2] - pos[p][0], pos[p][3] - pos[p][1]) - 9 - 7.5;
			CHECK_NUM(added, >=, gap / sqrt(2.0) * fmin(widths[k], 1) * 0.9);
			CHECK_NUM(added, <=, (gap + widths[k] + 2) * (widths[k] + 2));
			if (p == 1 && k == 2)
				fprintf(stderr,
				        "transient: diagonal gap %.1f px, bridge 4 px: %d pixels "
				        "added\n",
				        gap, added);
		}
}

static void test_single_blob_unchanged(void)
{
	struct err e;

	clear_all();
	disc(g_mfs, 40, 30, 12);
	disc(g_tcs, 52, 36, 9); /* overlaps: one region */
	rect(g_mask, 0, 0, W - 1, 5, 0);
	REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 5, g_us, &e), &e);
	CHECK_EQ_INT(check_subsets(g_mfs, g_tcs, g_mask, g_us), 0);
	CHECK_EQ_INT(components(g_us, NULL), 1);
	/* empty input: empty output */
	clear_all();
	REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 5, g_us, &e), &e);
	CHECK_EQ_INT(components(g_us, NULL), 0);
	CHECK_EQ_INT(check_subsets(g_mfs, g_tcs, g_mask, g_us), 0);
}

/* The paper's Fig. 5(b) situation: small regions inside the zero region
 * enclosed by the largest one (a ring), one of them nested inside a
 * smaller ring. */
static void test_islands_in_ring(void)
{
	struct err e;
	int added;

	clear_all();
	disc(g_mfs, 48, 36, 34);
	{
		uint8_t hole[N];
		memset(hole, 0, N);
		disc(hole, 48, 36, 28);
		for (int i = 0; i < N; i++)
			if (hole[i])
				g_mfs[i] = 0;
	}
	disc(g_tcs, 40, 30, 8);
	{
		uint8_t hole[N];
		memset(hole, 0, N);
		disc(hole, 40, 30, 5);
		for (int i = 0; i < N; i++)
			if (hole[i])
				g_tcs[i] = 0;
	}
	disc(g_tcs, 40, 30, 2); /* inside the small ring */
	disc(g_tcs, 62, 44, 3);
	g_tcs[36 * W + 56] = 1; /* a single pixel */
	CHECK_EQ_INT(components(g_mfs, NULL) + components(g_tcs, NULL), 5);
	REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 3, g_us, &e), &e);
	added = check_subsets(g_mfs, g_tcs, g_mask, g_us);
	CHECK_EQ_INT(components(g_us, NULL), 1);
	fprintf(stderr, "transient: ring with 4 inner regions, bridge 3 px: %d pixels added\n",
	        added);
}

/* A U-shaped mask: the straight line between blobs in the two arms
 * leaves the mask, so the bridge follows the mask around the bend; a
 * blob on a separate piece of the mask stays apart, and nothing is
 * painted off the mask. */
static void test_mask(void)
{
	struct err e;
	int lab[N];

	clear_all();
	memset(g_mask, 0, N);
	rect(g_mask, 5, 5, 25, 66, 1);  /* left arm */
	rect(g_mask, 55, 5, 75, 66, 1); /* right arm */
	rect(g_mask, 5, 50, 75, 66, 1); /* base */
	rect(g_mask, 84, 5, 94, 66, 1); /* a separate piece */
	disc(g_mfs, 15, 14, 8);
	disc(g_tcs, 65, 12, 6);
	disc(g_tcs, 89, 30, 4);
	disc(g_mfs, 40, 10, 6); /* off the mask: never in US */
	REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 4, g_us, &e), &e);
	check_subsets(g_mfs, g_tcs, g_mask, g_us);
	CHECK_EQ_INT(components(g_us, lab), 2);
	CHECK_EQ_INT(lab[14 * W + 15], lab[12 * W + 65]);
	CHECK(lab[30 * W + 89] != lab[14 * W + 15]);
	CHECK_EQ_INT(g_us[10 * W + 40], 0);
	/* the detour is bridge wide too, where the mask is wide enough */
	erode(g_us, 2, g_er);
	components(g_er, lab);
	CHECK(lab[14 * W + 15] != 0);
	CHECK_EQ_INT(lab[14 * W + 15], lab[12 * W + 65]);
}

/* A notch of the mask 2 px from the straight line between two blobs: a
 * 6 px bridge along that line would be clipped to 5 px there, so the
 * bridge swings away from the notch and keeps its full width. */
static void test_notch(void)
{
	struct err e;
	int lab[N];

	clear_all();
	rect(g_mask, 40, 0, 52, 17, 0);
	disc(g_mfs, 18, 20, 8);
	disc(g_tcs, 76, 20, 8);
	REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 6, g_us, &e), &e);
	check_subsets(g_mfs, g_tcs, g_mask, g_us);
	CHECK_EQ_INT(components(g_us, NULL), 1);
	erode(g_us, 3, g_er);
	components(g_er, lab);
	CHECK(lab[20 * W + 18] != 0);
	CHECK_EQ_INT(lab[20 * W + 18], lab[20 * W + 76]);
}

/* Many random specks around a central blob: all joined. */
static void test_random_specks(void)
{
	uint64_t s = 0x1234567ull;
	struct err e;

	for (int round = 0; round < 3; round++) {
		int before;
		clear_all();
		disc(g_mfs, 48, 36, 10);
		for (int k = 0; k < 40; k++) {
			int x = (int)(harness_xorshift64(&s) % W),
			    y = (int)(harness_xorshift64(&s) % H);
			(k % 2 ? g_tcs : g_mfs)[y * W + x] = 1;
		}
		/* a mask with holes */
		for (int k = 0; k < 30; k++) {
			int x = (int)(harness_xorshift64(&s) % W),
			    y = (int)(harness_xorshift64(&s) % H);
			rect(g_mask, x, y, x + 2, y + 1, 0);
		}
		rect(g_mask, 38, 26, 58, 46, 1);
		{
			uint8_t base[N];
			for (int i = 0; i < N; i++)
				base[i] = (g_mfs[i] || g_tcs[i]) && g_mask[i];
			before = components(base, NULL);
		}
		REQUIRE_OK(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 2 + round, g_us, &e), &e);
		check_subsets(g_mfs, g_tcs, g_mask, g_us);
		/* the mask is one piece here (holes are 3 x 2): so is US */
		CHECK_EQ_INT(components(g_mask, NULL), 1);
		CHECK_EQ_INT(components(g_us, NULL), 1);
		CHECK(before > 10);
	}
}

static void test_errors(void)
{
	struct err e;
	long fails = 0;

	clear_all();
	disc(g_mfs, 20, 20, 5);
	disc(g_tcs, 60, 40, 5);
	CHECK_EQ_INT(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 0, g_us, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, NAN, g_us, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_transient_layer(g_mfs, g_tcs, g_mask, 0, H, 3, g_us, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_support_region(g_tcs, g_us, W, -1, 3, g_er, &e), ERR_PARAM);
	for (long n = 1; n < 100; n++) {
		int rc;
		mem_fail_after(n);
		rc = hy_transient_layer(g_mfs, g_tcs, g_mask, W, H, 3, g_us, &e);
		mem_fail_after(-1);
		if (rc == 0)
			break;
		CHECK_EQ_INT(rc, ERR_NOMEM);
		fails++;
	}
	CHECK(fails >= 5);
	CHECK_EQ_INT(components(g_us, NULL), 1);
}

static void test_support_region(void)
{
	struct err e;
	uint8_t out[N];
	int lab[N], n;

	clear_all();
	memset(g_us, 0, N);
	/* TCS projection: a big block, a 6 x 5 block, a 2 x 2 block, a single
	 * pixel; US: everything but a stripe cutting the big block into two
	 * pieces of 20 x 10 and 20 x 3 */
	rect(g_tcs, 10, 10, 29, 23, 1);
	rect(g_tcs, 50, 10, 55, 14, 1);
	rect(g_tcs, 70, 40, 71, 41, 1);
	g_tcs[60 * W + 80] = 1;
	rect(g_us, 0, 0, W - 1, H - 1, 1);
	rect(g_us, 0, 20, W - 1, 20, 0);
	REQUIRE_OK(hy_support_region(g_tcs, g_us, W, H, 30, out, &e), &e);
	/* kept: 20 x 10 = 200, 20 x 3 = 60, 6 x 5 = 30 (exactly min_px) */
	n = components(out, lab);
	CHECK_EQ_INT(n, 3);
	CHECK_EQ_INT(out[15 * W + 15], 1);
	CHECK_EQ_INT(out[22 * W + 15], 1);
	CHECK_EQ_INT(out[12 * W + 52], 1);
	CHECK_EQ_INT(out[40 * W + 70], 0);
	CHECK_EQ_INT(out[60 * W + 80], 0);
	for (int i = 0; i < N; i++)
		if (out[i] && !(g_tcs[i] && g_us[i])) {
			CHECK(g_tcs[i] && g_us[i]);
			break;
		}
	/* kept regions are whole: every pixel of tcs & us in a kept region */
	for (int i = 0; i < N; i++)
		if (g_tcs[i] && g_us[i] && lab[i] == 0 && (i / W < 30)) {
			CHECK_EQ_INT(i % W >= 50 ? 1 : 0, 2);
			break;
		}
	/* min_px 61: the 60 piece goes too; in place over us */
	memcpy(out, g_us, N);
	REQUIRE_OK(hy_support_region(g_tcs, out, W, H, 61, out, &e), &e);
	CHECK_EQ_INT(components(out, NULL), 1);
	CHECK_EQ_INT(out[22 * W + 15], 0);
	/* min_px 0 and 1: the plain AND */
	REQUIRE_OK(hy_support_region(g_tcs, g_us, W, H, 1, out, &e), &e);
	CHECK_EQ_INT(components(out, NULL), 5);
	CHECK_EQ_INT(out[60 * W + 80], 1);
}

int main(void)
{
	RUN(test_two_blobs);
	RUN(test_single_blob_unchanged);
	RUN(test_islands_in_ring);
	RUN(test_mask);
	RUN(test_notch);
	RUN(test_random_specks);
	RUN(test_errors);
	RUN(test_support_region);
	return harness_report();
}
