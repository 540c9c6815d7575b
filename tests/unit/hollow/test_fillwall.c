/* test_fillwall.c - the fill's prune step (engine/hollow/fill/fillwall.c) on
 * synthetic windows: icicles (one-pixel lines of kept R hanging from a
 * wall) peel from their tips only as far as the overhang rule allows,
 * nothing solid is cut off from the wall, and pixels that are not R stay.
 * The rule is re-checked by brute force on the result: every pixel solid
 * in layer k + 1 and void in layer k has a solid pixel of layer k within
 * dg.  Random icicle forests check the same on many shapes.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/fill/fill_int.h"

#define W 40
#define H 40
#define PX 0.05

static uint64_t rng = 0x853c49e6748fea9bULL;

static struct hl_geo geo(void)
{
	struct hl_geo g;

	memset(&g, 0, sizeof g);
	g.dd = 0.05;
	g.dg = 0.12; /* 2.4 px */
	g.wall = 0.8;
	g.mv = 16;
	g.lean = 1;
	g.half = 0.5 * g.wall / cos(44.5 * M_PI / 180);
	g.px = g.py = g.pmax = PX;
	return g;
}

/* Layer k + 1: solid (void_above = 0) where up[] is set, void elsewhere;
 * layer k: the wall rows y < 3 solid, up[] pixels below y >= 3 solid as R,
 * the rest void.  No bisector (bisector_side = 0), no void above within mv
 * layers. */
static void setup(struct hl_win *s, const uint8_t *up)
{
	for (int i = 0; i < W * H; i++) {
		int y = i / W;
		s->region[i] = 1;
		s->void_above[i] = !up[i];
		s->void_out[i] = !(y < 3 || up[i]);
		s->keep[i] = y < 3 ? HL_KEEP_E : up[i] ? HL_KEEP_R : 0;
		s->near_void_d2_mm2[i] = 0;
		s->bisector_d2_mm2[i] = INFINITY;
		s->bisector_side[i] = 0;
		s->last_void[i] = INT32_MAX;
		s->sig_out_mm[i] = 0;
	}
}

/* The rule on the result, by brute force: pixels checked. */
static int rule_holds(const struct hl_win *s, double dg)
{
	for (int i = 0; i < W * H; i++) {
		int ok = 0;
		if (s->void_above[i] || !s->void_out[i])
			continue;
		for (int j = 0; j < W * H && !ok; j++) {
			double dx = (j % W - i % W) * PX, dy = (j / W - i / W) * PX;
			ok = !s->void_out[j] && dx * dx + dy * dy <= dg * dg;
		}
		if (!ok)
			return 0;
	}
	return 1;
}

/* Every solid pixel of layer k is 8-connected to the wall rows. */
static int all_attached(const struct hl_win *s)
{
	static int st[W * H];
	static uint8_t seen[W * H];
	int n = 0;

	memset(seen, 0, sizeof seen);
	for (int i = 0; i < 3 * W; i++) {
		seen[i] = 1;
		st[n++] = i;
	}
	while (n) {
		int i = st[--n], x = i % W, y = i / W;
		for (int dy = -1; dy <= 1; dy++)
			for (int dx = -1; dx <= 1; dx++) {
				int xn = x + dx, yn = y + dy, j = yn * W + xn;
				if (xn < 0 || yn < 0 || xn >= W || yn >= H || seen[j] ||
				    s->void_out[j])
					continue;
				seen[j] = 1;
				st[n++] = j;
			}
	}
	for (int i = 0; i < W * H; i++)
		if (!s->void_out[i] && !seen[i])
			return 0;
	return 1;
}

/* Layer k + 1: the wall rows and, with icicle set, a line 9 px long
 * hanging from it at x = 20. */
static void wall_above(uint8_t *up, int icicle)
{
	memset(up, 0, W * H);
	for (int i = 0; i < 3 * W; i++)
		up[i] = 1;
	for (int y = 3; icicle && y < 12; y++)
		up[y * W + 20] = 1;
}

static void test_icicle_peels_to_support(void)
{
	struct hl_geo g = geo();
	struct hl_win s;
	uint8_t up[W * H];

	REQUIRE(hl_win_init(&s, W * H));
	wall_above(up, 1);
	setup(&s, up);
	CHECK(rule_holds(&s, g.dg));
	CHECK_EQ_INT(hl_step_prune(&s, W, H, &g, 100), 0);
	CHECK(rule_holds(&s, g.dg));
	CHECK(all_attached(&s));
	/* the tip goes; pixels of layer k + 1 more than dg past the wall
	 * need icicle pixels below them, every 2 dg at most */
	CHECK(s.void_out[11 * W + 20]);
	{
		int kept = 0;
		for (int y = 3; y < 12; y++)
			kept += !s.void_out[y * W + 20];
		CHECK_INT(kept, >=, 2);
		CHECK_INT(kept, <, 9);
	}
	/* the wall (E) and void never change */
	for (int i = 0; i < 3 * W; i++)
		CHECK(!s.void_out[i]);
	hl_win_fini(&s);
}

/* Not R: an icicle grown kept as E stays whole. */
static void test_only_r_pruned(void)
{
	struct hl_geo g = geo();
	struct hl_win s;
	uint8_t up[W * H];

	REQUIRE(hl_win_init(&s, W * H));
	wall_above(up, 1);
	setup(&s, up);
	for (int y = 3; y < 12; y++)
		s.keep[y * W + 20] = HL_KEEP_E;
	CHECK_EQ_INT(hl_step_prune(&s, W, H, &g, 100), 0);
	for (int y = 3; y < 12; y++)
		CHECK(!s.void_out[y * W + 20]);
	hl_win_fini(&s);
}

/* Random forests of icicles, branches and blobs (all R) under a wall:
 * the rule holds and nothing is cut off, whatever is pruned. */
static void test_random_forests(void)
{
	struct hl_geo g = geo();
	int removed = 0;

	for (int t = 0; t < 40; t++) {
		struct hl_win s;
		uint8_t up[W * H];
		REQUIRE(hl_win_init(&s, W * H));
		wall_above(up, 0);
		/* random walks down from the wall */
		for (int w = 0; w < 6; w++) {
			int x = 2 + (int)(harness_xorshift64(&rng) % (W - 4)), y = 3;
			int len = 2 + (int)(harness_xorshift64(&rng) % 25);
			for (int q = 0; q < len && y < H - 1; q++) {
				up[y * W + x] = 1;
				switch (harness_xorshift64(&rng) % 4) {
				case 0: x += x < W - 2; break;
				case 1: x -= x > 1; break;
				default: y++; break;
				}
			}
		}
		setup(&s, up);
		CHECK(rule_holds(&s, g.dg) && all_attached(&s));
		{
			int before = 0, after = 0;
			for (int i = 0; i < W * H; i++)
				before += !s.void_out[i];
			CHECK_EQ_INT(hl_step_prune(&s, W, H, &g, 100), 0);
			for (int i = 0; i < W * H; i++)
				after += !s.void_out[i];
			removed += before - after;
		}
		CHECK(rule_holds(&s, g.dg));
		CHECK(all_attached(&s));
		hl_win_fini(&s);
	}
	CHECK_INT(removed, >, 0);
}

int main(void)
{
	RUN(test_icicle_peels_to_support);
	RUN(test_only_r_pruned);
	RUN(test_random_forests);
	return harness_report();
}
