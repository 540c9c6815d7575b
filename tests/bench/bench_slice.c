/* bench_slice.c - figures for the slicing core (not part of make test):
 * contours of armadillo at 50 mm / 0.05 mm (1000 layers), rasterisation
 * of those layers on the SL1 image (1440 x 2560, portrait map), and the
 * 3D erosion of the stack by a 1 mm ball.  Prints figures only.
 * Usage: bench_slice MESH [y_up] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "unit/slice/meshio.h"

#include "engine/core/err.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/slice/erode.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

/* Process CPU time: the code is single-threaded and the build machine
 * is shared, so CPU time is the reproducible figure. */
static double now_s(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
	return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

struct src {
	struct slicer *s;
	double layer_mm;
};

static int src_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	struct src *c = ctx;
	return slice_at(c->s, (k + 0.5) * c->layer_mm, region, NULL, e);
}

static int bench_erode(const struct mesh *m, int n, double layer_mm, double pixel_mm, double r)
{
	struct src c = {NULL, layer_mm};
	struct slice_erode_source src = {src_layer, &c};
	struct slice_erode_params p = {r, pixel_mm, layer_mm, n, 0, 0, 0, 0};
	struct slice_eroder *er = NULL;
	struct slice_erode_info info;
	struct paths reg;
	struct err e;
	struct box3 bb = box3_empty();
	double t0, t, vol = 0, slice_t = 0;

	for (size_t i = 0; i < m->nv; i++)
		box3_add(&bb, m->v[i]);
	p.x0_mm = bb.lo.x, p.y0_mm = bb.lo.y, p.x1_mm = bb.hi.x, p.y1_mm = bb.hi.y;
	paths_init(&reg);
	err_clear(&e);
	if (slice_new(m, &c.s, &e) || slice_erode_new(&p, &src, &er, &e)) {
		fprintf(stderr, "erode: %s\n", e.msg);
		return 1;
	}
	/* time of the slicing the source does, measured apart */
	{
		struct slicer *s2 = NULL;
		slice_new(m, &s2, &e);
		t0 = now_s();
		for (int k = 0; k < n; k++)
			slice_at(s2, (k + 0.5) * layer_mm, &reg, NULL, &e);
		slice_t = now_s() - t0;
		slice_free(s2);
	}
	t0 = now_s();
	for (int k = 0; k < n; k++) {
		if (slice_erode_layer(er, k, &reg, &e)) {
			fprintf(stderr, "erode: %s\n", e.msg);
			return 1;
		}
		vol += paths_area_mm2(&reg) * layer_mm;
	}
	t = now_s() - t0 - slice_t;
	slice_erode_info(er, &info);
	printf("erode r=%.1f mm pixel=%.3f mm: grid %dx%d, window +-%d layers, %.1f MB, "
	       "%.2f ms/layer (%.2f s total, slicing excluded), %.0f Mpx/s, cavity %.0f mm3\n",
	       r, pixel_mm, info.w, info.h, info.window_layers, info.bytes / 1048576.0,
	       t * 1e3 / n, t, info.pixels / t * 1e-6, vol);
	slice_erode_free(er);
	slice_free(c.s);
	paths_fini(&reg);
	return 0;
}

/* Rasterising a large section: the 50 mm ball's equator (a 2,560-gon)
 * and a 50 mm square, on the SL1 frame. */
static void bench_big_sections(const struct raster_map *map, struct raster *r)
{
	struct paths ball, sq;
	struct err e;
	const int reps = 200;
	double t0, t_ball = 0, t_sq = 0;

	paths_init(&ball);
	paths_init(&sq);
	err_clear(&e);
	{
		struct path *p = paths_add(&ball);
		for (int i = 0; i < 2560; i++) {
			double a = 2 * M_PI * i / 2560;
			path_push(p, (struct pt2){geom_mm_to_nm(60.48 + 25 * cos(a)),
						  geom_mm_to_nm(34.02 + 25 * sin(a))});
		}
		struct pt2 q[4] = {{geom_mm_to_nm(35.48), geom_mm_to_nm(9.02)},
				   {geom_mm_to_nm(85.48), geom_mm_to_nm(9.02)},
				   {geom_mm_to_nm(85.48), geom_mm_to_nm(59.02)},
				   {geom_mm_to_nm(35.48), geom_mm_to_nm(59.02)}};
		paths_add_pts(&sq, q, 4);
	}
	for (int k = 0; k < reps; k++) {
		raster_clear(r);
		t0 = now_s();
		slice_rasterize(&ball, map, 1, r, &e);
		t_ball += now_s() - t0;
		raster_clear(r);
		t0 = now_s();
		slice_rasterize(&sq, map, 1, r, &e);
		t_sq += now_s() - t0;
	}
	printf("raster 1440x2560, anti-aliased: 50 mm disc %.3f ms/layer, 50 mm square %.3f ms/layer\n",
	       t_ball * 1e3 / reps, t_sq * 1e3 / reps);
	paths_fini(&ball);
	paths_fini(&sq);
}

/* Marching squares on a full SL1 frame of a lattice-like field (many
 * small loops), as the lattice engine uses it. */
static void bench_contours(void)
{
	const int w = 1440, h = 2560, reps = 5;
	float *f = malloc((size_t)w * h * sizeof *f);
	struct raster_map map = {{{1 / 0.04725, 0}, {0, 1 / 0.04725}}, {0, 0}};
	struct paths reg;
	struct err e;
	double t0, t;
	size_t pts = 0;

	paths_init(&reg);
	err_clear(&e);
	for (int j = 0; j < h; j++)
		for (int i = 0; i < w; i++)
			f[(size_t)j * w + i] = (float)(sin(i / 7.3) * sin(j / 9.1) + 0.2 * sin(i / 31.0));
	t0 = now_s();
	for (int r = 0; r < reps; r++) {
		if (slice_field_contours(f, w, h, 0.3f, &map, &reg, &e)) {
			fprintf(stderr, "contours: %s\n", e.msg);
			break;
		}
	}
	t = (now_s() - t0) / reps;
	pts = paths_point_count(&reg);
	printf("marching squares 1440x2560 lattice-like field: %.1f ms/frame, %zu loops, %zu points\n",
	       t * 1e3, reg.n, pts);
	paths_fini(&reg);
	free(f);
}

int main(int argc, char **argv)
{
	const char *path = argc > 1 ? argv[1] : "../shared/meshes/armadillo.off";
	int y_up = argc > 2 ? atoi(argv[2]) : 1;
	const double layer_mm = 0.05, H = 50, pitch = 0.04725;
	struct mesh *m = tm_load(path, y_up, H, 60.48, 34.02);
	struct slicer *s = NULL;
	struct slice_stats st = {0, 0, 0};
	struct paths *layers;
	struct raster *r = raster_new(1440, 2560);
	/* SL1 portrait: column = Y / p, row = (120.96 - X) / p */
	struct raster_map map = {{{0, 1 / pitch}, {-1 / pitch, 0}}, {0, 120.96 / pitch}};
	struct err e;
	int n = layer_count_for(H, layer_mm);
	double t0, t_new, t_slice, t_clear, t_aa, t_bin, area = 0, cov = 0;

	if (!m || !r) {
		fprintf(stderr, "cannot read %s\n", path);
		return 1;
	}
	err_clear(&e);
	printf("mesh %s: %zu triangles, %d layers of %.2f mm\n", path, m->nt, n, layer_mm);
	layers = calloc((size_t)n, sizeof *layers);
	t0 = now_s();
	if (slice_new(m, &s, &e)) {
		fprintf(stderr, "%s\n", e.msg);
		return 1;
	}
	t_new = now_s() - t0;
	t0 = now_s();
	for (int k = 0; k < n; k++) {
		paths_init(&layers[k]);
		if (slice_at(s, (k + 0.5) * layer_mm, &layers[k], &st, &e)) {
			fprintf(stderr, "%s\n", e.msg);
			return 1;
		}
		area += paths_area_mm2(&layers[k]);
	}
	t_slice = now_s() - t0;
	printf("contours: slice_new %.1f ms, %d layers %.1f ms (%.3f ms/layer), %zu segments, "
	       "%zu loops, %zu chains closed, volume %.1f mm3\n",
	       t_new * 1e3, n, t_slice * 1e3, t_slice * 1e3 / n, st.segments, st.loops,
	       st.chains_closed, area * layer_mm);

	t0 = now_s();
	for (int k = 0; k < n; k++)
		raster_clear(r);
	t_clear = now_s() - t0;
	t_aa = t_bin = 0;
	for (int pass = 0; pass < 2; pass++) {
		for (int k = 0; k < n; k++) {
			double t1;
			raster_clear(r);
			t1 = now_s();
			if (slice_rasterize(&layers[k], &map, pass == 0, r, &e)) {
				fprintf(stderr, "%s\n", e.msg);
				return 1;
			}
			*(pass == 0 ? &t_aa : &t_bin) += now_s() - t1;
			if (pass == 0 && k % 10 == 0)
				cov += raster_coverage_px(r) * pitch * pitch * layer_mm * 10;
		}
	}
	printf("raster 1440x2560 (SL1 portrait): anti-aliased %.3f ms/layer (%.0f Mpx/s), binary "
	       "%.3f ms/layer (%.0f Mpx/s); clearing the image %.3f ms/layer; AA volume %.1f mm3\n",
	       t_aa * 1e3 / n, 1440.0 * 2560 * n / t_aa * 1e-6, t_bin * 1e3 / n,
	       1440.0 * 2560 * n / t_bin * 1e-6, t_clear * 1e3 / n, cov);
	bench_big_sections(&map, r);
	for (int k = 0; k < n; k++)
		paths_fini(&layers[k]);
	free(layers);
	slice_free(s);
	raster_free(r);

	bench_contours();
	bench_erode(m, n, layer_mm, 0.1, 1.0);
	bench_erode(m, n, layer_mm, 0.05, 1.0);
	tm_free(m);
	return 0;
}
