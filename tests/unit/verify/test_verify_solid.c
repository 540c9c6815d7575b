/* test_verify_solid.c - the checker on the `solid` engine's uniform
 * hollowing (shell_mm), the reference every slicer offers: its sealed
 * cavity has a flat ceiling, which the checker must report as an interior
 * overhang (proving it can fail), while the same part without a shell has
 * none.  The cube is built here as a mesh (no reader needed) and run
 * through the engine's own prepare/layer calls, rasterised like a writer.
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/engine.h"
#include "engine/slice/slice.h"
#include "engine/solid/solid.h"
#include "engine/verify/verify.h"

/* Axis-aligned cube [0, s]^3 as 12 outward triangles (storage from mem_alloc). */
static void cube(struct mesh *m, double s)
{
	static const int f[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
				     {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
	m->nv = 8;
	m->nt = 12;
	m->v = mem_alloc(8 * sizeof *m->v);
	m->tri = mem_alloc(36 * sizeof *m->tri);
	for (int i = 0; i < 8; i++)
		m->v[i] = v3((i == 1 || i == 2 || i == 5 || i == 6) ? s : 0,
			     (i == 2 || i == 3 || i == 6 || i == 7) ? s : 0, i >= 4 ? s : 0);
	for (int t = 0; t < 12; t++)
		for (int k = 0; k < 3; k++)
			m->tri[3 * t + k] = (uint32_t)f[t][k];
}

static void run_solid(double shell_mm, struct verify_report *rep)
{
	struct mesh m;
	struct mesh_report mr;
	struct common_params cp;
	struct printer pr;
	struct engine_ctx ctx;
	struct raster_map map;
	struct progress prog;
	struct verify_params vp = {0.1, 45, 0.1, 0.1, 0, 0, 0, 0};
	struct verify *v = NULL;
	struct raster *r = raster_new(160, 160);
	void *params, *state = NULL;
	struct err e;
	int n;

	memset(rep, 0, sizeof *rep);
	err_clear(&e);
	cube(&m, 12);
	memset(&mr, 0, sizeof mr);
	mr.bbox.lo = v3(0, 0, 0);
	mr.bbox.hi = v3(12, 12, 12);
	memset(&cp, 0, sizeof cp);
	cp.alpha_deg = 45;
	cp.shell_mm = shell_mm;
	memset(&pr, 0, sizeof pr);
	memset(&map, 0, sizeof map);
	map.a[0][0] = map.a[1][1] = 10; /* 0.1 mm pixels, part at (2, 2) px offset */
	map.b[0] = map.b[1] = 20;
	progress_init(&prog, NULL);
	memset(&ctx, 0, sizeof ctx);
	ctx.mesh = &m;
	ctx.report = &mr;
	ctx.common = &cp;
	ctx.printer = &pr;
	ctx.layer_mm = 0.1;
	ctx.threads = 1;
	ctx.want_raster = 1;
	ctx.map = &map;
	ctx.progress = &prog;
	params = mem_calloc(1, solid_engine.params_size);
	param_defaults(&solid_engine.params, params);
	REQUIRE_OK(solid_engine.prepare(&ctx, params, &state, &e), &e);
	REQUIRE_OK(verify_new(&vp, &v, &e), &e);
	n = layer_count_for(12, 0.1);
	for (int k = 0; k < n; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		paths_init(&ly.region);
		layer_place(&ly, k, n, 0.1);
		REQUIRE_OK(solid_engine.layer(state, &ly, &e), &e);
		raster_clear(r);
		REQUIRE_OK(slice_rasterize(&ly.region, &map, 0, r, &e), &e);
		REQUIRE_OK(verify_layer(v, r, &e), &e);
		paths_fini(&ly.region);
	}
	REQUIRE_OK(verify_finish(v, rep, &e), &e);
	verify_free(v);
	solid_engine.release(state);
	mem_free(params);
	mem_free(m.v);
	mem_free(m.tri);
	raster_free(r);
}

static void test_uniform_shell_has_overhangs(void)
{
	struct verify_report rep;

	/* 12 mm cube, 1 mm shell: a 10 x 10 mm sealed ceiling at z = 11 */
	run_solid(1.0, &rep);
	fprintf(stderr, "solid shell 1 mm: interior overhang %.1f mm2 on %d layers, walls %.2f / %.2f mm\n",
		rep.interior_overhang_mm2, rep.overhang_layers, rep.min_wall_mm,
		rep.min_wall_vertical_mm);
	CHECK(rep.interior_overhang_mm2 > 0.8 * 9.6 * 9.6);
	CHECK_EQ_INT(rep.overhang_layers, 1);
	CHECK_NEAR(rep.min_wall_mm, 1.0, 0.15);
	CHECK_NEAR(rep.min_wall_vertical_mm, 1.0, 0.15);
	CHECK_EQ_INT(rep.islands, 0);
	verify_report_fini(&rep);
	/* the same part solid: nothing enclosed, nothing to report */
	run_solid(0, &rep);
	CHECK_EQ_INT(rep.interior_overhang_px, 0);
	CHECK(isinf(rep.min_wall_mm));
	verify_report_fini(&rep);
}

int main(void)
{
	RUN(test_uniform_shell_has_overhangs);
	return harness_report();
}
