/* bench_gcode.c - G-code writer throughput (toolpath planning + formatting)
 * on realistic synthetic layer stacks of 50 mm parts at 0.2 mm (250
 * layers), the setting of the PrusaSlicer 2.5 figure in REFERENCE.md
 * (54-187 layers/s on 2 cores, 15% infill).  Prints layers/s, MB/s of
 * G-code and peak RSS; not part of `make test`.
 *
 *   bench_gcode [threads] [layers] [gear|dome|lattice]
 */
#include "engine/core/err.h"
#include "engine/core/metrics.h"
#include "engine/core/pipeline.h"
#include "engine/core/progress.h"
#include "engine/core/sink.h"
#include "engine/geom/clip.h"
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/writer.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

static struct pt2 P(double x, double y)
{
	return (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)};
}

static int circle(struct paths *ps, double cx, double cy, double r, int n, int hole)
{
	struct pt2 *p = malloc((size_t)n * sizeof *p);
	int rc;

	if (!p)
		return ERR_NOMEM;
	for (int k = 0; k < n; k++) {
		double a = 2 * M_PI * (hole ? n - k : k) / n;
		p[k] = P(cx + r * cos(a), cy + r * sin(a));
	}
	rc = paths_add_pts(ps, p, (size_t)n);
	free(p);
	return rc;
}

/* A gear of 24 teeth (1440 vertices, like a fine mesh slice) whose teeth
 * twist with height, with three bores, on a round foot: 50 mm tall. */
static int gear_layer(int k, struct paths *out, enum layer_fill *fill, struct err *e)
{
	struct paths raw;
	double z = (k + 0.5) * 0.2;
	struct pt2 p[1440];
	int rc;

	paths_init(&raw);
	*fill = LAYER_FILL_PART;
	for (int i = 0; i < 1440; i++) {
		double a = 2 * M_PI * i / 1440;
		double r = 20 + 1.6 * tanh(3 * sin(24 * a + z * 0.08)) + (z < 4 ? 3 - z * 0.5 : 0);
		p[i] = P(110 + r * cos(a), 110 + r * sin(a));
	}
	rc = paths_add_pts(&raw, p, 1440);
	for (int h = 0; !rc && h < 3; h++)
		rc = circle(&raw, 110 + 9 * cos(2 * M_PI * h / 3), 110 + 9 * sin(2 * M_PI * h / 3),
			    z > 30 ? 3 : 2.5, 180, 1);
	if (!rc)
		rc = circle(&raw, 110, 110, 4, 240, 1);
	if (!rc)
		rc = clip_union(&raw, CLIP_FILL_NONZERO, out, e);
	paths_fini(&raw);
	return rc;
}

/* A dome: every layer has sloped walls, so skins everywhere near the top. */
static int dome_layer(int k, struct paths *out, enum layer_fill *fill, struct err *e)
{
	struct paths raw;
	double z = (k + 0.5) * 0.2, r = sqrt(fmax(0, 50.0 * 50.0 - z * z)) * 0.5;
	int rc;

	(void)e;
	paths_init(&raw);
	*fill = LAYER_FILL_PART;
	rc = r > 0.3 ? circle(&raw, 110, 110, r, 720, 0) : 0;
	if (!rc)
		rc = paths_append_move(out, &raw);
	paths_fini(&raw);
	return rc;
}

/* A lattice: 12 x 12 struts of 1.2 mm leaning across a 50 mm cube,
 * designed material (solid). */
static int lattice_layer(int k, struct paths *out, enum layer_fill *fill, struct err *e)
{
	struct paths raw;
	double z = (k + 0.5) * 0.2;
	int rc = 0;

	paths_init(&raw);
	*fill = LAYER_FILL_SOLID;
	for (int i = 0; !rc && i < 12; i++)
		for (int j = 0; !rc && j < 12; j++) {
			double s = ((i + j) % 2 ? 1 : -1) * 0.08 * fmod(z, 12.5);
			rc = circle(&raw, 85 + 4.5 * i + s, 85 + 4.5 * j - s, 0.6, 48, 0);
		}
	if (!rc)
		rc = clip_union(&raw, CLIP_FILL_NONZERO, out, e);
	paths_fini(&raw);
	return rc;
}

static double cpu_s(void)
{
	struct rusage ru;

	getrusage(RUSAGE_SELF, &ru);
	return (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec +
	       ru.ru_stime.tv_usec / 1e6;
}

static int count_write(void *ctx, const void *p, size_t n, struct err *e)
{
	(void)p;
	(void)e;
	*(size_t *)ctx += n;
	return 0;
}

typedef int (*layer_fn)(int, struct paths *, enum layer_fill *, struct err *);

static int run(const char *name, layer_fn fn, int threads, int n)
{
	struct printer pr = printer_fdm_profiles[0];
	struct out_info info;
	struct sink s;
	struct metrics m;
	struct err e;
	size_t bytes = 0;
	void *st = NULL;
	double t0, t_regions = 0, t, c0, c_regions = 0, cpu;
	int rc;

	memset(&info, 0, sizeof info);
	info.format = OUT_GCODE;
	info.printer = &pr;
	info.layer_count = n;
	info.layer_mm = 0.2;
	info.part_bbox.lo = v3(85, 85, 0);
	info.part_bbox.hi = v3(135, 135, n * 0.2);
	info.threads = threads;
	info.job_name = name;
	info.created = 1700000000;
	memset(&s, 0, sizeof s);
	s.write = count_write;
	s.ctx = &bytes;
	metrics_init(&m);
	err_clear(&e);
	t0 = progress_now_s();
	c0 = cpu_s();
	rc = gcode_writer_ops.open(&info, &s, &st, &e);
	for (int k = 0; !rc && k < n; k++) {
		struct layer ly;
		double a = progress_now_s(), ca = cpu_s();
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.count = n;
		ly.height_mm = info.layer_mm;
		ly.z_mm = (k + 0.5) * info.layer_mm;
		ly.z_top_mm = (k + 1) * info.layer_mm;
		paths_init(&ly.region);
		rc = fn(k, &ly.region, &ly.fill, &e);
		t_regions += progress_now_s() - a;
		c_regions += cpu_s() - ca;
		if (!rc)
			rc = gcode_writer_ops.layer(st, &ly, &e);
		paths_fini(&ly.region);
	}
	if (!rc)
		rc = gcode_writer_ops.close(st, &m, &e);
	t = progress_now_s() - t0 - t_regions;
	cpu = cpu_s() - c0 - c_regions;
	gcode_writer_ops.free_state(st);
	if (rc) {
		fprintf(stderr, "%s: %s\n", name, e.msg);
		metrics_fini(&m);
		return rc;
	}
	printf("%-8s threads %d: %4d layers in %6.3f s = %7.1f layers/s (cpu %6.3f s = %6.1f "
	       "layers/cpu-s), %5.1f MB G-code, print %4.0f min, %5.1f g, %ld retractions\n",
	       name, threads, n, t, n / t, cpu, n / cpu, bytes / 1e6,
	       metrics_get(&m, "gcode.print_time_s")->num / 60,
	       metrics_get(&m, "gcode.filament_g")->num,
	       (long)metrics_get(&m, "gcode.retractions")->ival);
	metrics_fini(&m);
	return 0;
}

int main(int argc, char **argv)
{
	int threads = argc > 1 ? atoi(argv[1]) : pipeline_cpu_count();
	int n = argc > 2 ? atoi(argv[2]) : 250;
	const char *only = argc > 3 ? argv[3] : NULL;
	struct rusage ru;

	if (only) {
		layer_fn fn = !strcmp(only, "gear") ? gear_layer : !strcmp(only, "dome") ? dome_layer
											    : lattice_layer;
		return run(only, fn, threads, n) ? 1 : 0;
	}

	if (run("gear", gear_layer, threads, n) || run("dome", dome_layer, threads, n) ||
	    run("lattice", lattice_layer, threads, n))
		return 1;
	if (threads > 1 && (run("gear", gear_layer, 1, n) || run("lattice", lattice_layer, 1, n)))
		return 1;
	getrusage(RUSAGE_SELF, &ru);
	printf("peak RSS %.1f MB (the generators' regions included)\n", ru.ru_maxrss / 1024.0);
	printf("PrusaSlicer 2.5 on 50 mm parts at 0.2 mm, 2 cores: 54-187 layers/s "
	       "(REFERENCE.md); goal >= 2x\n");
	return 0;
}
