/* test_from_layers.c - voxel densities from layer images (from_layers.h):
 * a box of lit pixels gives the box's extent and, summed over the voxels,
 * exactly its material volume (pixels and layers split at voxel faces),
 * density 1 inside and a partial density on voxels the box half covers,
 * under a landscape, a mirrored and a portrait (u along y) pixel map;
 * anti-aliased values count as fractions. */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/fea/from_layers.h"

#define W 200
#define H 120
#define PX_MM 0.05
#define LAYER_MM 0.05

/* Lit pixels [u0, u1) x [v0, v1) of value val. */
static void fill(struct raster *r, int u0, int u1, int v0, int v1, int val)
{
	raster_clear(r);
	for (int v = v0; v < v1; v++)
		for (int u = u0; u < u1; u++)
			r->px[(size_t)v * r->stride + u] = (uint8_t)val;
}

static void run_map(const struct raster_map *map, int u_is_x)
{
	struct fea_layers_geom geo = {*map, W, H, LAYER_MM};
	struct raster *img = raster_new(W, H);
	struct box3 box = box3_empty();
	struct fea_layers *acc = NULL;
	struct fea_grid g;
	struct err e;
	int layers = 30; /* 1.5 mm */
	double sum = 0, want, h = 0.4;
	size_t n;

	REQUIRE(img);
	err_clear(&e);
	CHECK_EQ_INT(fea_layers_check(&geo, &e), 0);
	/* 50 x 30 pixels = 2.5 x 1.5 mm */
	for (int k = 0; k < layers; k++) {
		fill(img, 20, 70, 40, 70, 255);
		fea_layers_box(&geo, k, img, &box);
	}
	{
		struct vec3 s = box3_size(box);
		CHECK_NEAR(s.x, u_is_x ? 2.5 : 1.5, 1e-9);
		CHECK_NEAR(s.y, u_is_x ? 1.5 : 2.5, 1e-9);
		CHECK_NEAR(s.z, 1.5, 1e-9);
		CHECK_NEAR(box.lo.z, 0, 1e-12);
	}
	REQUIRE_OK(fea_layers_new(&geo, &box, h, 1000000, &acc, &e), &e);
	for (int k = 0; k < layers; k++) {
		fill(img, 20, 70, 40, 70, 255);
		if (k % 2)
			REQUIRE_OK(fea_layers_add(acc, k, -1, img, &e), &e);
	}
	/* even layers slab by slab, as engine_fea fills slabs in parallel */
	for (int iz = 0; iz < fea_layers_slabs(acc); iz++) {
		int k0, k1;
		fea_layers_slab_range(acc, iz, &k0, &k1);
		for (int k = k0; k < k1 && k < layers; k++)
			if (k % 2 == 0)
				REQUIRE_OK(fea_layers_add(acc, k, iz, img, &e), &e);
	}
	REQUIRE_OK(fea_layers_finish(acc, &g, &e), &e);
	fea_layers_free(acc);
	n = (size_t)g.nx * g.ny * g.nz;
	CHECK_EQ_INT(g.nx, (int)ceil((u_is_x ? 2.5 : 1.5) / h - 1e-9) + 2);
	CHECK_EQ_INT(g.nz, (int)ceil(1.5 / h - 1e-9) + 2);
	CHECK_NEAR(g.lo_mm.z, -h, 1e-12);
	for (size_t i = 0; i < n; i++) {
		CHECK(g.rho[i] >= 0 && g.rho[i] <= 1);
		sum += g.rho[i] * h * h * h;
	}
	want = 2.5 * 1.5 * 1.5;
	CHECK_REL(sum, want, 1e-5);
	/* the voxel one in from the box's min corner is full */
	CHECK_NEAR(g.rho[((size_t)1 * g.ny + 1) * g.nx + 1], 1.0, 1e-6);
	/* padding is empty */
	CHECK_NEAR(g.rho[0], 0.0, 0);
	mem_free(g.rho);
	raster_free(img);
}

static void test_maps(void)
{
	/* landscape, v flipped (rows grow towards -y), as printer_raster_geometry */
	struct raster_map land = {{{1 / PX_MM, 0}, {0, -1 / PX_MM}}, {0, H}};
	struct raster_map mirrored = {{{-1 / PX_MM, 0}, {0, -1 / PX_MM}}, {W, H}};
	struct raster_map portrait = {{{0, 1 / PX_MM}, {1 / PX_MM, 0}}, {0, 0}};

	run_map(&land, 1);
	run_map(&mirrored, 1);
	run_map(&portrait, 0);
}

static void test_fraction_and_limits(void)
{
	struct raster_map land = {{{1 / PX_MM, 0}, {0, 1 / PX_MM}}, {0, 0}};
	struct raster_map skew = {{{1 / PX_MM, 1}, {0, 1 / PX_MM}}, {0, 0}};
	struct fea_layers_geom geo = {land, W, H, LAYER_MM}, bad = {skew, W, H, LAYER_MM};
	struct raster *img = raster_new(W, H);
	struct box3 box = box3_empty();
	struct fea_layers *acc = NULL;
	struct fea_grid g;
	struct err e;
	double sum = 0;

	REQUIRE(img);
	err_clear(&e);
	CHECK_EQ_INT(fea_layers_check(&bad, &e), ERR_UNSUPPORTED);
	fill(img, 0, 40, 0, 40, 128); /* 2 x 2 mm at 128/255 */
	fea_layers_box(&geo, 0, img, &box);
	CHECK_EQ_INT(fea_layers_new(&geo, &box, 0.001, 1000, &acc, &e), ERR_LIMIT);
	CHECK_STR(e.field, "fea_voxel_mm");
	REQUIRE_OK(fea_layers_new(&geo, &box, 0.5, 1000000, &acc, &e), &e);
	REQUIRE_OK(fea_layers_add(acc, 0, -1, img, &e), &e);
	REQUIRE_OK(fea_layers_finish(acc, &g, &e), &e);
	fea_layers_free(acc);
	for (size_t i = 0; i < (size_t)g.nx * g.ny * g.nz; i++)
		sum += g.rho[i] * 0.125;
	CHECK_REL(sum, 2.0 * 2.0 * LAYER_MM * 128 / 255.0, 1e-5);
	mem_free(g.rho);
	raster_free(img);
}

int main(void)
{
	RUN(test_maps);
	RUN(test_fraction_and_limits);
	return harness_report();
}
