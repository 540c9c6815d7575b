/* bench_structs.c - speeds of the hybrid engine's structure generators.
 *
 *   bench_structs [THREADS]
 * A diamond lattice (hy_tcs_build, cell 3.2 mm, balls 0.5 mm, sticks
 * 0.6 mm, about 1e5 capsules) over a 50 mm cube rendered at 1000 x 1000
 * pixels of 0.05 mm on 1000 layers, through capsule_union_raster (every
 * capsule culled per layer) and capsule_zindex_raster; then
 * hy_mfs_solid over a 2000 x 2000 raster of a Voronoi section (cell 2 mm,
 * wall 0.3 mm, extent 100 mm).  Prints `key value` lines.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/capsule.h"
#include "engine/geom/raster.h"
#include "engine/hybrid/structure.h"

static double now_s(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
	int threads = argc > 1 ? atoi(argv[1]) : 1, w = 1000, h = 1000, layers = 1000;
	struct capsule *c = NULL;
	struct capsule_zindex *ix = NULL;
	size_t n = 0;
	double steep, t0, t_plain, t_index, px_set = 0;
	struct raster_map m = {{{20, 0}, {0, 20}}, {0, 0}};
	uint8_t *img = mem_alloc((size_t)w * h);
	struct err e;

	if (!img || hy_tcs_build(v3(0, 0, 0), v3(50, 50, 50), 3.2, 0.5, 0.6, v3(0.1, 0.2, 0.3),
				 10000000, &c, &n, &steep, &e) ||
	    capsule_zindex_new(c, n, 0, &ix, &e)) {
		fprintf(stderr, "bench_structs: %s\n", e.msg);
		return 1;
	}
	printf("capsules %zu\nthreads %d\n", n, threads);
	/* plain: 100 layers are enough to time it */
	t0 = now_s();
	for (int k = 0; k < 100; k++) {
		memset(img, 0, (size_t)w * h);
		if (capsule_union_raster(c, n, 0.025 + 0.5 * k, &m, w, h, img, threads, &e))
			return 1;
	}
	t_plain = (now_s() - t0) / 100;
	t0 = now_s();
	for (int k = 0; k < layers; k++) {
		memset(img, 0, (size_t)w * h);
		if (capsule_zindex_raster(ix, 0.025 + 0.05 * k, &m, w, h, img, threads, &e))
			return 1;
	}
	t_index = (now_s() - t0) / layers;
	/* pixels set: every 10th layer again, untimed */
	for (int k = 0; k < layers; k += 10) {
		memset(img, 0, (size_t)w * h);
		if (capsule_zindex_raster(ix, 0.025 + 0.05 * k, &m, w, h, img, threads, &e))
			return 1;
		for (size_t q = 0; q < (size_t)w * h; q++)
			px_set += 10 * img[q];
	}
	printf("union_raster_ms_per_layer %.3f\nzindex_raster_ms_per_layer %.3f\n", 1e3 * t_plain,
	       1e3 * t_index);
	printf("solid_fraction %.4f\nns_per_section_pixel %.2f\n",
	       px_set / ((double)w * h * layers), 1e9 * t_index / (px_set / layers));
	capsule_zindex_free(ix);
	mem_free(c);
	{
		struct hy_mfs *f = NULL;
		long s = 0;
		int W = 2000;
		t0 = now_s();
		if (hy_mfs_new_voronoi(v3(0, 0, 1), v3(0, 0, 0), 100, 2, 0.3, 1, &f, &e)) {
			fprintf(stderr, "bench_structs: %s\n", e.msg);
			return 1;
		}
		printf("mfs_build_s %.3f\n", now_s() - t0);
		t0 = now_s();
		for (int j = 0; j < W; j++)
			for (int i = 0; i < W; i++)
				s += hy_mfs_solid(f, v3(-50 + 0.05 * i, -50 + 0.05 * j, 3));
		printf("mfs_solid_ns_per_call %.2f\nmfs_wall_fraction %.4f\n",
		       1e9 * (now_s() - t0) / ((double)W * W), (double)s / ((double)W * W));
		hy_mfs_free(f);
	}
	mem_free(img);
	return 0;
}
