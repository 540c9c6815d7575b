/* test_repair.c - the optimised voids' images mended to the verifier's
 * reading (engine/hollow/repair.c) on a synthetic part: a 10 mm cube
 * holding a void with vertical walls under a hip roof that leans beta
 * from the vertical (a square pyramid frustum: its corners lean more, as
 * the diagonal).  Drawn at a resin printer's pitch (0.047 mm pixels,
 * 0.05 mm layers, alpha 45), the layers are checked by the verifier
 * (engine/verify), as drawn and as mended:
 * - beta 50 (too flat by 0.204 px a layer): the drawing fails, the
 *   mended layers pass with no island, and the gray the mending adds
 *   (its mm3) is the void the verifier finds lost; against a roof too
 *   flat everywhere that is far more than a 45 degree roof would cost
 *   (the front stands where it first read over): the mending is for the
 *   optimised voids' local misreadings, whose polygons keep the rule;
 * - beta 40 (support-free): both pass, and the mending adds almost
 *   nothing;
 * - nothing is ever added outside the part or where the part is not
 *   wholly solid (the ledger's pixels all lie inside the cube).
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"
#include "engine/hollow/repair.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"
#include "engine/verify/verify.h"

#include "boxgen.h"

#define PX 0.047
#define LAYER 0.05
#define SIDE 10.0
#define W 230 /* image pixels a side: the cube and a margin */
#define TOP 0.02 /* the roof's top, half-width (mm): flat over 0.85 px, in reach */

/* The cube, then the void: [2, 8]^2 from z 2 to 5, then a roof rising
 * at beta from the vertical to a 1 mm square top (normals into it). */
static void part(struct mesh *m, double beta_deg)
{
	double h = (3 - TOP) / tan(beta_deg * M_PI / 180), zt = 5 + h;
	/* rings of four at z 2, 5 and zt; faces wound for outward normals,
	 * then flipped for the void */
	static const uint32_t f[20][3] = {
	    {0, 2, 1}, {0, 3, 2},                                   /* bottom */
	    {0, 1, 5}, {0, 5, 4}, {1, 2, 6}, {1, 6, 5},             /* walls */
	    {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7},
	    {4, 5, 9}, {4, 9, 8}, {5, 6, 10}, {5, 10, 9},           /* roof */
	    {6, 7, 11}, {6, 11, 10}, {7, 4, 8}, {7, 8, 11},
	    {8, 9, 10}, {8, 10, 11}};                               /* top */
	static const double sq[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
	uint32_t v0;

	m->v = mem_alloc(20 * sizeof *m->v);
	m->tri = mem_alloc(32 * 3 * sizeof *m->tri);
	REQUIRE(m->v && m->tri);
	m->nv = m->nt = 0;
	add_box(m, v3(0, 0, 0), v3(SIDE, SIDE, SIDE), 0);
	v0 = (uint32_t)m->nv;
	for (int r = 0; r < 3; r++)
		for (int q = 0; q < 4; q++) {
			double half = r < 2 ? 3 : TOP, z = r == 0 ? 2 : r == 1 ? 5 : zt;
			m->v[m->nv++] = v3(5 + half * sq[q][0], 5 + half * sq[q][1], z);
		}
	for (int t = 0; t < 20; t++) {
		uint32_t *q = m->tri + 3 * m->nt++;
		q[0] = v0 + f[t][0];
		q[1] = v0 + f[t][2];
		q[2] = v0 + f[t][1];
	}
}

static void map_of(struct raster_map *map)
{
	memset(map, 0, sizeof *map);
	map->a[0][0] = 1 / PX;
	map->a[1][1] = 1 / PX;
	map->b[0] = 7.3;
	map->b[1] = 6.6;
}

/* Draw every layer of m (as drawn, or mended by r) and check them;
 * *solid_mm3: the stack's solid from its gray (gray / 255 x pixel x
 * layer), summed here.  stepped: drawn as a mesh output with stepped voids
 * slices again (hl_layer_draw_stepped: the cube grey, the void at pixel
 * centres). */
static void check_stack_as(const struct mesh *m, int stepped, const struct hl_repair *r,
			   struct verify_report *rep, double *solid_mm3)
{
	struct mesh cube = {m->v, m->tri, 8, 12};
	struct slicer *sc = NULL;
	struct raster *cimg = raster_new(W, W);
	struct paths creg;
	struct verify_params p = {LAYER, 45, PX, PX, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct slicer *sl = NULL;
	struct raster *img = raster_new(W, W);
	struct raster_map map;
	struct paths reg;
	struct err e;
	int n = (int)ceil(SIDE / LAYER - 1e-9);

	err_clear(&e);
	memset(rep, 0, sizeof *rep); /* verify_finish replaces it */
	map_of(&map);
	paths_init(&reg);
	paths_init(&creg);
	*solid_mm3 = 0;
	REQUIRE(img && cimg);
	REQUIRE_OK(verify_new(&p, &v, &e), &e);
	REQUIRE_OK(slice_new(m, &sl, &e), &e);
	REQUIRE_OK(slice_new(&cube, &sc, &e), &e);
	for (int k = 0; k < n; k++) {
		double z = (k + 0.5) * LAYER;
		raster_clear(img);
		REQUIRE_OK(slice_at(sl, z, &reg, NULL, &e), &e);
		if (stepped) {
			raster_clear(cimg);
			REQUIRE_OK(slice_at(sc, z, &creg, NULL, &e), &e);
			REQUIRE_OK(hl_layer_draw_stepped(&reg, &creg, &map, 1, NULL, NULL, z, 0, 0, img,
							 cimg, &e),
				   &e);
		} else {
			REQUIRE_OK(hl_layer_draw(&reg, &map, 1, NULL, NULL, z, 0, 0, img, &e), &e);
		}
		if (r)
			hl_repair_apply(r, z, img);
		REQUIRE_OK(verify_layer(v, img, &e), &e);
		for (size_t i = 0; i < (size_t)W * W; i++)
			*solid_mm3 += img->px[i] / 255.0 * PX * PX * LAYER;
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	slice_free(sl);
	slice_free(sc);
	paths_fini(&reg);
	paths_fini(&creg);
	raster_free(img);
	raster_free(cimg);
}

static void check_stack(const struct mesh *m, const struct hl_repair *r,
			struct verify_report *rep, double *solid_mm3)
{
	check_stack_as(m, 0, r, rep, solid_mm3);
}

/* Mend m's layers (carve: carve its stepped layers, keeping wall_mm to
 * the cube's outside less the slack); every mended pixel inside the
 * cube's image. */
static void mend_as(const struct mesh *m, int carve, double wall_mm, struct hl_repair *r)
{
	struct raster_map map;
	struct slicer *sl = NULL;
	struct err e;
	double reach = LAYER + 0.5 * VERIFY_TOLERANCE_PX * PX;

	err_clear(&e);
	map_of(&map);
	memset(r, 0, sizeof *r);
	REQUIRE_OK(slice_new(m, &sl, &e), &e);
	REQUIRE_OK(hl_repair_build(m, sl, 8, 12, &map, 1, NULL, NULL, LAYER, PX, PX, reach, wall_mm,
				   carve, 1, r, &e),
		   &e);
	slice_free(sl);
	for (int k = 0; k < r->n; k++)
		for (size_t i = 0; i < r->layer[k].n; i++) {
			double u = r->layer[k].px[i].x + 0.5, v = r->layer[k].px[i].y + 0.5;
			double x = (u - map.b[0]) * PX, y = (v - map.b[1]) * PX;
			CHECK(x > 0 && x < SIDE && y > 0 && y < SIDE);
			CHECK((k + 0.5) * LAYER > 2 - LAYER); /* not below the void */
		}
}

static void mend(const struct mesh *m, struct hl_repair *r)
{
	mend_as(m, 0, 1.0, r);
}

static void test_flat_roof_mended(void)
{
	struct mesh m;
	struct hl_repair r;
	struct verify_report drawn, mended;
	/* the volume between the 50 and the 45 degree hip roofs over the
	 * 6 mm square (frusta up to the top square) */
	double t50 = tan(50 * M_PI / 180), between, sd, sm;

	part(&m, 50);
	between = (36 + 6 * 2 * TOP + 4 * TOP * TOP) / 3.0 * (3 - TOP) * (1 - 1 / t50);
	mend(&m, &r);
	check_stack(&m, NULL, &drawn, &sd);
	check_stack(&m, &r, &mended, &sm);
	printf("roof 50 deg: drawn %lld px over (excess %.3f px), mended %lld px over (excess %.3f "
	       "px), %lld pixels on %d layers, %.3f mm3 (the images: %.3f mm3 more solid; void "
	       "%.3f -> %.3f mm3 at the threshold; a 45 degree roof would cost %.3f mm3), %d "
	       "left\n",
	       drawn.interior_overhang_px, drawn.slope_excess_px, mended.interior_overhang_px,
	       mended.slope_excess_px, r.pixels, r.layers, r.mm3, sm - sd,
	       drawn.enclosed_void_mm3, mended.enclosed_void_mm3, between, r.layers_left);
	CHECK(drawn.interior_overhang_px > 0);
	CHECK(drawn.slope_excess_px > VERIFY_TOLERANCE_PX);
	CHECK_EQ_INT(mended.interior_overhang_px, 0);
	CHECK(mended.slope_excess_px <= VERIFY_TOLERANCE_PX);
	CHECK_EQ_INT(mended.islands, 0);
	CHECK_EQ_INT(r.layers_left, 0);
	/* the ledger is what the images hold: their solid grew by its mm3 */
	CHECK(r.mm3 >= between);
	CHECK_NEAR(sm - sd, r.mm3, 1e-6 * r.mm3);
	/* a safety net, not a design: against a roof too flat everywhere the
	 * mended front stands where the first layer read over left it, so
	 * most of the roof and the walls under it fill (docs/hollow.md), but
	 * the void stays */
	CHECK(mended.enclosed_void_mm3 > 0.25 * drawn.enclosed_void_mm3);
	verify_report_fini(&drawn);
	verify_report_fini(&mended);
	hl_repair_fini(&r);
	mem_free(m.v);
	mem_free(m.tri);
}

static void test_steep_roof_kept(void)
{
	struct mesh m;
	struct hl_repair r;
	struct verify_report drawn, mended;
	double sd, sm;

	part(&m, 40);
	mend(&m, &r);
	check_stack(&m, NULL, &drawn, &sd);
	check_stack(&m, &r, &mended, &sm);
	printf("roof 40 deg: drawn %lld px over (excess %.3f px), mended %lld pixels, %.4f mm3\n",
	       drawn.interior_overhang_px, drawn.slope_excess_px, r.pixels, r.mm3);
	CHECK_EQ_INT(drawn.interior_overhang_px, 0);
	CHECK_EQ_INT(mended.interior_overhang_px, 0);
	CHECK(r.mm3 < 0.01);
	CHECK_NEAR(sm, sd, 0.01);
	verify_report_fini(&drawn);
	verify_report_fini(&mended);
	hl_repair_fini(&r);
	mem_free(m.v);
	mem_free(m.tri);
}

/* Half-width (mm) of the void's square at height z under a roof at beta
 * from the vertical: 3 up to z 5, then receding by tan beta per mm up to
 * the top (TOP); -1 above the roof. */
static double void_half(double z, double beta_deg)
{
	double t = tan(beta_deg * M_PI / 180), zt = 5 + (3 - TOP) / t;

	if (z < 2 || z > zt)
		return -1;
	return z <= 5 ? 3 : 3 - (z - 5) * t;
}

/* Is pixel (x, y) of layer k void in the carved stack: its centre inside
 * the analytic void's square at the layer's mid-plane (the stepped
 * drawing), or carved by r? */
static int void_at(const struct hl_repair *r, int k, int x, int y, double beta_deg)
{
	double half = void_half((k + 0.5) * LAYER, beta_deg);
	struct raster_map map;

	if (k < 0 || k >= r->n)
		return 0;
	map_of(&map);
	if (fmax(fabs((x + 0.5 - map.b[0]) * PX - 5), fabs((y + 0.5 - map.b[1]) * PX - 5)) < half)
		return 1;
	for (size_t i = 0; i < r->layer[k].n; i++)
		if (r->layer[k].px[i].x == x && r->layer[k].px[i].y == y)
			return 1;
	return 0;
}

/* Carved pixels of r, against the analytic void (independent of the
 * drawing and of the verifier): each was solid in its layer's drawing (its
 * centre outside the void's square there), is cleared, hangs (the pixel
 * under it and its eight neighbours are void in the carved stack: farther
 * than the slope from the solid below), and keeps the wall to the cube's
 * outside less HL_CARVE_SLACK_PX pixels and a pixel of the guard's own
 * sampling.  *rise: layers carved above the analytic void's top. */
static void check_carved_over_void(const struct hl_repair *r, double beta_deg, double wall_mm,
				   int *rise)
{
	struct raster_map map;
	int top = -1;

	map_of(&map);
	for (int k = 0; k < r->n; k++) {
		if (void_half((k + 0.5) * LAYER, beta_deg) > 0)
			top = k;
		for (size_t i = 0; i < r->layer[k].n; i++) {
			const struct hl_mend *q = &r->layer[k].px[i];
			double x = (q->x + 0.5 - map.b[0]) * PX, y = (q->y + 0.5 - map.b[1]) * PX;
			double z = (k + 0.5) * LAYER;
			double out = fmin(fmin(fmin(x, SIDE - x), fmin(y, SIDE - y)), fmin(z, SIDE - z));
			int hangs = 1;
			CHECK_EQ_INT(q->g, 0);
			CHECK(fmax(fabs(x - 5), fabs(y - 5)) >= void_half(z, beta_deg) - 1e-9);
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++)
					hangs &= void_at(r, k - 1, q->x + dx, q->y + dy, beta_deg);
			CHECK(hangs);
			CHECK(out >= wall_mm - (HL_CARVE_SLACK_PX + 1) * PX);
		}
	}
	*rise = 0;
	for (int k = top + 1; k < r->n; k++)
		if (r->layer[k].n)
			*rise = k - top;
}

/* Carve m's stepped layers keeping wall_mm; report them drawn and
 * carved; *rise: layers carved above the analytic top. */
static void carve_roof(double beta_deg, double wall_mm, struct hl_repair *r,
		       struct verify_report *drawn, struct verify_report *carved,
		       double *carved_mm3, int *rise)
{
	struct mesh m;
	double sd, sc;

	part(&m, beta_deg);
	mend_as(&m, 1, wall_mm, r);
	check_stack_as(&m, 1, NULL, drawn, &sd);
	check_stack_as(&m, 1, r, carved, &sc);
	check_carved_over_void(r, beta_deg, wall_mm, rise);
	printf("roof %g deg, stepped, wall %g mm: drawn %lld px over (excess %.3f px), carved "
	       "%lld px over (excess %.3f px) on %d layers, %lld pixels on %d layers, %.4f mm3, "
	       "void %.3f -> %.3f mm3, %d left, top risen %d layers\n",
	       beta_deg, wall_mm, drawn->interior_overhang_px, drawn->slope_excess_px,
	       carved->interior_overhang_px, carved->slope_excess_px, carved->overhang_layers,
	       r->pixels, r->layers, r->mm3, drawn->enclosed_void_mm3, carved->enclosed_void_mm3,
	       r->layers_left, *rise);
	*carved_mm3 = sc - sd;
	mem_free(m.v);
	mem_free(m.tri);
}

/* A mesh output's stepped voids (pixel centres): a roof a degree inside
 * the rule (receding 1.03 px a layer along the walls) drawn so reads over
 * where two pixel steps fall in one layer; carved, every layer passes with
 * no island, taking only solid over the void near it, and the void grows
 * by what was taken. */
static void test_stepped_roof_carved(void)
{
	struct hl_repair r;
	struct verify_report drawn, carved;
	double mm3;
	int rise;

	carve_roof(44, 1.0, &r, &drawn, &carved, &mm3, &rise);
	CHECK(drawn.interior_overhang_px > 0);
	CHECK(drawn.slope_excess_px > VERIFY_TOLERANCE_PX);
	CHECK_EQ_INT(carved.interior_overhang_px, 0);
	CHECK(carved.slope_excess_px <= VERIFY_TOLERANCE_PX);
	CHECK_EQ_INT(carved.islands, 0);
	CHECK_EQ_INT(r.layers_left, 0);
	CHECK(r.pixels > 0);
	/* only solid taken: the ledger is what the images lost */
	CHECK(r.mm3 < 0);
	CHECK_NEAR(mm3, r.mm3, 1e-6 * -r.mm3);
	CHECK(carved.enclosed_void_mm3 > drawn.enclosed_void_mm3);
	verify_report_fini(&drawn);
	verify_report_fini(&carved);
	hl_repair_fini(&r);
}

/* A long roof exactly at the rule (1.06 px a layer, 60 layers): pixel
 * steps recede 1 px a layer at most (two read 2 px, over the 0.05 mm
 * slope plus 0.2 px), so the carved roof falls 0.06 px a layer behind the
 * design and its top ends a few pixels wide; carved on upward, the top
 * rises, narrowing a pixel and more a side a layer, until it closes: every
 * layer passes, and the top rose a few layers, no more. */
static void test_stepped_roof_at_the_rule(void)
{
	struct hl_repair r;
	struct verify_report drawn, carved;
	double mm3;
	int rise;

	carve_roof(45, 1.0, &r, &drawn, &carved, &mm3, &rise);
	CHECK(drawn.interior_overhang_px > 0);
	CHECK_EQ_INT(carved.interior_overhang_px, 0);
	CHECK(carved.slope_excess_px <= VERIFY_TOLERANCE_PX);
	CHECK_EQ_INT(carved.islands, 0);
	CHECK_EQ_INT(r.layers_left, 0);
	/* 60 layers 0.064 px behind: about 4 px at the top, closed within
	 * as many layers */
	CHECK(rise >= 1 && rise <= 5);
	verify_report_fini(&drawn);
	verify_report_fini(&carved);
	hl_repair_fini(&r);
}

/* The guard: where the top may not rise without thinning the wall to the
 * outside (here 2.1 mm asked over a roof whose top lies 2.02 mm under the
 * cube's top face), the cuts stop at the wall less its slack, and what
 * still reads over is left and counted (the check then fails: nothing is
 * hidden). */
static void test_stepped_roof_wall_kept(void)
{
	struct hl_repair r;
	struct verify_report drawn, carved;
	double mm3;
	int rise;

	carve_roof(45, 2.1, &r, &drawn, &carved, &mm3, &rise);
	CHECK(carved.interior_overhang_px > 0);
	CHECK(carved.interior_overhang_px < drawn.interior_overhang_px);
	CHECK(r.layers_left > 0);
	CHECK_EQ_INT(carved.islands, 0);
	CHECK(rise <= 1);
	verify_report_fini(&drawn);
	verify_report_fini(&carved);
	hl_repair_fini(&r);
}

int main(void)
{
	RUN(test_flat_roof_mended);
	RUN(test_steep_roof_kept);
	RUN(test_stepped_roof_carved);
	RUN(test_stepped_roof_at_the_rule);
	RUN(test_stepped_roof_wall_kept);
	return harness_report();
}
