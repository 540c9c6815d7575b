/* test_slopes.c - the polygon check of the optimised voids' slopes
 * (engine/hollow/slopes.c) on hand-built parts, 0.05 mm layers:
 *  - a box cavity (a flat ceiling) fails at its last layer by the ceiling
 *    less an r-wide rim: (12 - 2r)^2 mm2, r = 0.05 (a convex section's
 *    erosion keeps sharp corners);
 *  - a cavity under a square pyramid whose sections shrink 0.04 mm a
 *    layer passes at r = 0.05 (as the rule allows) and fails at r = 0.03,
 *    by the ring the sections shrink beyond r, on every roof layer;
 *  - a pillar of solid in a cavity widening at 45 degrees fails at its
 *    corners only, by (4 - pi) r^2 a layer: the square growth of a convex
 *    corner where the rule allows the round one;
 *  - a part with no cavity checks nothing.
 * Expected values come from the geometry above, not from the code.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/slopes.h"
#include "engine/mesh/mesh.h"

#include "boxgen.h"

#define LAYER 0.05

static void alloc_mesh(struct mesh *m, size_t nv, size_t nt)
{
	m->v = mem_alloc(nv * sizeof *m->v);
	m->tri = mem_alloc(3 * nt * sizeof *m->tri);
	REQUIRE(m->v && m->tri);
	m->nv = m->nt = 0;
}

static void free_mesh(struct mesh *m)
{
	mem_free(m->v);
	mem_free(m->tri);
}

static void tri(struct mesh *m, uint32_t a, uint32_t b, uint32_t c, int inward)
{
	uint32_t *q = m->tri + 3 * m->nt++;
	q[0] = a;
	q[1] = inward ? c : b;
	q[2] = inward ? b : c;
}

/* The four side quads between square rings b (below) and t (above),
 * corners counter-clockwise seen from above. */
static void sides(struct mesh *m, const uint32_t b[4], const uint32_t t[4], int inward)
{
	for (int i = 0; i < 4; i++) {
		int j = (i + 1) % 4;
		tri(m, b[i], b[j], t[j], inward);
		tri(m, b[i], t[j], t[i], inward);
	}
}

/* A cavity: square [lo, hi]^2, vertical walls from z0 to z1, a square
 * pyramid roof to (centre, z1 + h); its surface faces into the cavity. */
static void add_pyramid_cavity(struct mesh *m, double lo, double hi, double z0, double z1,
			       double h)
{
	uint32_t v0 = (uint32_t)m->nv, b[4], t[4], ap;
	const double xs[4] = {lo, hi, hi, lo}, ys[4] = {lo, lo, hi, hi};

	for (int i = 0; i < 4; i++) {
		b[i] = v0 + (uint32_t)i;
		t[i] = v0 + 4 + (uint32_t)i;
		m->v[b[i]] = v3(xs[i], ys[i], z0);
		m->v[t[i]] = v3(xs[i], ys[i], z1);
	}
	ap = v0 + 8;
	m->v[ap] = v3(0.5 * (lo + hi), 0.5 * (lo + hi), z1 + h);
	m->nv += 9;
	/* outward orientation (CCW seen from outside), flipped: inward */
	tri(m, b[0], b[2], b[1], 1);
	tri(m, b[0], b[3], b[2], 1);
	sides(m, b, t, 1);
	for (int i = 0; i < 4; i++)
		tri(m, t[i], t[(i + 1) % 4], ap, 1);
}

static void test_flat_ceiling_fails(void)
{
	struct mesh m;
	struct hl_slopes s;
	struct err e;
	const double r = LAYER * tan(M_PI / 4);

	alloc_mesh(&m, 16, 24);
	add_box(&m, v3(0, 0, 0), v3(20, 20, 10), 0);
	add_box(&m, v3(4, 4, 2), v3(16, 16, 6), 1);
	REQUIRE_OK(hl_slopes_check(&m, 8, 12, LAYER, r, &s, &e), &e);
	/* layers 40..119 hold the cavity (centres 2.025..5.975) */
	CHECK_EQ_INT(s.layers_checked, 80);
	CHECK_EQ_INT(s.layers_over, 1);
	CHECK_EQ_INT(s.worst_layer, 120);
	/* an inner offset of a convex square keeps its corners sharp */
	CHECK_NEAR(s.excess_mm2, (12 - 2 * r) * (12 - 2 * r), 1e-6);
	free_mesh(&m);
}

static void test_pyramid_roof(void)
{
	struct mesh m;
	struct hl_slopes s;
	struct err e;
	/* half-width 6 mm closing over h: 6 / h mm per mm, 0.04 mm a layer */
	const double h = 6 * LAYER / 0.04;

	alloc_mesh(&m, 17, 30);
	add_box(&m, v3(0, 0, 0), v3(20, 20, 14), 0);
	add_pyramid_cavity(&m, 4, 16, 2, 4, h);
	REQUIRE_OK(hl_slopes_check(&m, 8, 12, LAYER, LAYER, &s, &e), &e);
	CHECK(s.layers_checked > 180);
	CHECK_EQ_INT(s.layers_over, 0);
	CHECK_NEAR(s.excess_mm2, 0, 1e-12);
	CHECK_EQ_INT(s.worst_layer, -1);

	REQUIRE_OK(hl_slopes_check(&m, 8, 12, LAYER, 0.03, &s, &e), &e);
	/* every roof layer but the last few (where the section is under 2r
	 * wide and erodes to nothing): 150 layers of roof */
	CHECK_EQ_INT(s.layers_over, 149);
	/* a roof layer of side a: eroded (a - 0.06), next (a - 0.08), so the
	 * excess is the ring between them, about 4 a 0.01 mm2; over the roof
	 * a runs 12 -> 0 */
	{
		double want = 0;
		for (int k = 0; k < 150; k++) {
			double a = 12 - 2 * 0.04 * (k + 0.5), in = a - 0.08, er = a - 0.06;
			if (er <= 0)
				break;
			want += er * er - (in > 0 ? in * in : 0);
		}
		CHECK_NEAR(s.excess_mm2, want, 1e-3 * want);
	}
	free_mesh(&m);
}

/* A solid square frustum (outward faces) from (lo0, hi0)^2 at z0 to
 * (lo1, hi1)^2 at z1. */
static void add_frustum(struct mesh *m, double lo0, double hi0, double z0, double lo1,
			double hi1, double z1)
{
	uint32_t v0 = (uint32_t)m->nv, b[4], t[4];
	const int cx[4] = {0, 1, 1, 0}, cy[4] = {0, 0, 1, 1};

	for (int i = 0; i < 4; i++) {
		b[i] = v0 + (uint32_t)i;
		t[i] = v0 + 4 + (uint32_t)i;
		m->v[b[i]] = v3(cx[i] ? hi0 : lo0, cy[i] ? hi0 : lo0, z0);
		m->v[t[i]] = v3(cx[i] ? hi1 : lo1, cy[i] ? hi1 : lo1, z1);
	}
	m->nv += 8;
	tri(m, b[0], b[2], b[1], 0);
	tri(m, b[0], b[3], b[2], 0);
	tri(m, t[0], t[1], t[2], 0);
	tri(m, t[0], t[2], t[3], 0);
	sides(m, b, t, 0);
}

/* A pillar of solid standing in a cavity and widening at exactly 45
 * degrees: its sides advance r a layer (allowed), its four corners r sqrt 2
 * (mitred), where the rule allows only the round growth: each layer the
 * check finds the four corner pieces, 4 (r^2 - pi r^2 / 4) = (4 - pi) r^2. */
static void test_mitred_corner_fails(void)
{
	struct mesh m;
	struct hl_slopes s;
	struct err e;
	const double r = LAYER;

	alloc_mesh(&m, 24, 36);
	add_box(&m, v3(0, 0, 0), v3(20, 20, 10), 0);
	add_box(&m, v3(4, 4, 2), v3(16, 16, 7), 1);
	add_frustum(&m, 9, 11, 2, 4, 16, 7);
	REQUIRE_OK(hl_slopes_check(&m, 8, 12, LAYER, r, &s, &e), &e);
	/* 100 layers of cavity (40..139), 99 steps between them; the last
	 * few corners come within r of the cavity's own wall and pass */
	CHECK(s.layers_over >= 98 && s.layers_over <= 99);
	CHECK_NEAR(s.worst_mm2, (4 - M_PI) * r * r, 0.02 * (4 - M_PI) * r * r);
	CHECK_NEAR(s.excess_mm2, s.layers_over * (4 - M_PI) * r * r,
		   0.02 * s.layers_over * (4 - M_PI) * r * r);
	free_mesh(&m);
}

static void test_no_cavity(void)
{
	struct mesh m;
	struct hl_slopes s;
	struct err e;

	alloc_mesh(&m, 8, 12);
	add_box(&m, v3(0, 0, 0), v3(20, 20, 10), 0);
	REQUIRE_OK(hl_slopes_check(&m, 8, 12, LAYER, LAYER, &s, &e), &e);
	CHECK_EQ_INT(s.layers_checked, 0);
	CHECK_EQ_INT(s.worst_layer, -1);
	free_mesh(&m);
}

int main(void)
{
	RUN(test_flat_ceiling_fails);
	RUN(test_pyramid_roof);
	RUN(test_mitred_corner_fails);
	RUN(test_no_cavity);
	return harness_report();
}
