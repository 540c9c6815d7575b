/* test_sl1.c - the SL1/SL1S and generic zip writers, end to end.
 *
 * Archives are written through the real writer into files and verified
 * by tests/support/sl1check.py (zipfile + its own PNG decoder): keys,
 * names, image sizes, pixel sums, orientation of an L-shaped part
 * against REFERENCE.md's formula, mirroring, usedMaterial against an
 * analytic area; plus memory independent of the layer count, failing
 * sinks, cancellation, determinism across thread counts and misuse.
 */
#include "engine/core/mem.h"
#include "engine/slice/slice.h"
#include "sl1_fixture.h"

#include <malloc.h>
#if defined(__SANITIZE_ADDRESS__)
/* ASan's allocator statistics (libasan; gcc ships no header for it) */
size_t __sanitizer_get_current_allocated_bytes(void);
#endif

/* SL1 display as REFERENCE.md states it (independent of the profile code). */
#define SL1_PITCH_MM 0.04725
#define SL1_LONG_MM 120.96

/* ---- shapes (printer frame, mm) ---- */

struct disk {
	double cx, cy, r;
};

static int in_disk(double x, double y, const void *arg)
{
	const struct disk *d = arg;
	return (x - d->cx) * (x - d->cx) + (y - d->cy) * (y - d->cy) < d->r * d->r;
}

/* L: a long arm along +X ([x0, x0+20] x [y0, y0+5]) and a short arm
 * along +Y ([x0, x0+5] x [y0, y0+12]). */
struct ell {
	double x0, y0;
};

static int in_ell(double x, double y, const void *arg)
{
	const struct ell *l = arg;
	double u = x - l->x0, v = y - l->y0;
	return (u >= 0 && u < 20 && v >= 0 && v < 5) || (u >= 0 && u < 5 && v >= 0 && v < 12);
}

/* ---- one archive through the writer ---- */

struct job {
	enum out_format fmt;
	const struct printer *printer;
	int layers, threads;
	double layer_mm;
	fixture_shape shape;
	const void *arg;
	double box[4]; /* mm box of the shape */
	int ss;        /* supersampling, 1 = binary */
	int stop_after; /* > 0: abandon the archive after this many layers */
	const struct paths *region; /* set: layers carry it, the writer rasterises */
	uint64_t sum;   /* out: pixel sum of every layer (all equal) */
	struct metrics m;
};

static int write_job(const char *path, struct job *j, struct err *e)
{
	const struct writer_ops *ops = j->fmt == OUT_ZIP ? &zip_writer_ops : &sl1_writer_ops;
	struct out_info oi = fixture_info(j->fmt, j->printer, j->layers, j->layer_mm, j->threads);
	struct sink s;
	void *st = NULL;
	int fd, rc;

	metrics_init(&j->m);
	oi.part_bbox.lo = v3(j->box[0], j->box[1], 0);
	oi.part_bbox.hi = v3(j->box[2], j->box[3], j->layers * j->layer_mm);
	if (fixture_open_file(path, &s, &fd))
		return ERR_SET(e, ERR_IO, "cannot create %s", path);
	rc = ops->open(&oi, &s, &st, e);
	for (int k = 0; !rc && k < j->layers; k++) {
		struct layer ly;
		if (j->stop_after > 0 && k == j->stop_after)
			break;
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.count = j->layers;
		ly.height_mm = j->layer_mm;
		ly.z_mm = (k + 0.5) * j->layer_mm;
		ly.z_top_mm = (k + 1) * j->layer_mm;
		rc = ops->raster_get(st, &ly.raster, e);
		if (rc)
			break;
		if (j->region) {
			if (paths_copy(&ly.region, j->region)) {
				raster_free(ly.raster);
				rc = ERR_SET(e, ERR_NOMEM, "out of memory");
				break;
			}
		} else {
			j->sum = fixture_paint(ly.raster, ops->raster_map(st), j->shape, j->arg,
					       j->box[0], j->box[1], j->box[2], j->box[3], j->ss);
			ly.raster_ready = 1;
		}
		rc = ops->layer(st, &ly, e);
	}
	if (!rc && j->stop_after == 0)
		rc = ops->close(st, &j->m, e);
	if (st)
		ops->free_state(st);
	close(fd);
	return rc;
}

static double metric(const struct metrics *m, const char *key)
{
	const struct metric *v = metrics_get(m, key);
	if (!v)
		return NAN;
	return v->type == METRIC_NUM ? v->num : (double)v->ival;
}

/* A 10 mm disk at the display centre, 24 layers: keys, sizes, sums,
 * usedMaterial against the analytic volume, metrics, thumbnails. */
static void test_sl1_disk(void)
{
	struct disk d = {60.48, 34.02, 10};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 24,
			.threads = 2, .layer_mm = 0.05, .shape = in_disk, .arg = &d,
			.box = {50, 24, 71, 45}, .ss = 4};
	const char *path = fixture_path("disk.sl1");
	double vol = M_PI * 100 * 0.05 * 24, t_exp = 0;
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--printer sl1 --expect-layers 24 --expect-sum 0:%llu "
				   "--expect-sum 23:%llu --expect-volume-mm3 %.6f --volume-rel 0.002 "
				   "--expect-key jobDir=fixture_part --expect-key layerHeight=0.05 "
				   "--expect-key numFade=10 --expect-key numFast=24 "
				   "--expect-key numSlow=0 --expect-key expTime=7.5 "
				   "--expect-key expTimeFirst=35 --expect-key hollow=0 "
				   "--expect-key 'fileCreationTimestamp=2023-11-14 at 22:13:20 UTC'",
				   (unsigned long long)j.sum, (unsigned long long)j.sum, vol),
		     0);
	/* the writer's own figures: volume from the same coverage */
	CHECK_REL(metric(&j.m, "material_volume_mm3"), j.sum / 255.0 * SL1_PITCH_MM *
							       SL1_PITCH_MM * 0.05 * 24,
		  1e-9);
	CHECK_REL(metric(&j.m, "sl1.used_material_ml"), metric(&j.m, "material_volume_mm3") / 1000,
		  1e-12);
	CHECK_EQ_INT(metric(&j.m, "sl1.layers"), 24);
	CHECK_EQ_INT(metric(&j.m, "sl1.image_width_px"), 1440);
	CHECK_EQ_INT(metric(&j.m, "sl1.image_height_px"), 2560);
	/* print time: layers 0-2 at 35 s, 10 layers fading to 7.5 s in steps
	 * of 27.5 / 11, the rest at 7.5 s; fast tilt 5 s; tower 5 s/mm */
	for (int k = 0; k < 24; k++)
		t_exp += k <= 2 ? 35 : k <= 12 ? 35 - (k - 2) * 27.5 / 11 : 7.5;
	CHECK_NEAR(metric(&j.m, "sl1.print_time_s"), t_exp + 24 * (5 + 5 * 0.05), 1e-6);
	CHECK(metric(&j.m, "sl1.archive_bytes") > metric(&j.m, "sl1.png_bytes"));
	metrics_fini(&j.m);
	remove(path);
}

/* The L lands where REFERENCE.md says: column = Y / 0.04725, row =
 * (120.96 - X) / 0.04725 on a 1440 x 2560 image. */
static void test_sl1_orientation(void)
{
	struct ell l = {50, 20};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 3,
			.threads = 1, .layer_mm = 0.05, .shape = in_ell, .arg = &l,
			.box = {50, 20, 70, 32}, .ss = 1};
	const char *path = fixture_path("ell.sl1");
	/* nonzero box: X in [50, 70) -> rows (120.96-70)/p .. (120.96-50)/p,
	 * Y in [20, 32) -> columns 20/p .. 32/p (pixel centres inside) */
	int r0 = (int)ceil((SL1_LONG_MM - 70) / SL1_PITCH_MM - 0.5);
	int r1 = (int)floor((SL1_LONG_MM - 50) / SL1_PITCH_MM - 0.5);
	int c0 = (int)ceil(20 / SL1_PITCH_MM - 0.5), c1 = (int)floor(32 / SL1_PITCH_MM - 0.5);
	/* probes: far end of the long arm (X = 69, Y = 22), tip of the short
	 * arm (X = 52, Y = 31) and the empty corner (X = 69, Y = 31) */
	int rl = (int)((SL1_LONG_MM - 69) / SL1_PITCH_MM), cl = (int)(22 / SL1_PITCH_MM);
	int rs = (int)((SL1_LONG_MM - 52) / SL1_PITCH_MM), cs = (int)(31 / SL1_PITCH_MM);
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--printer sl1 --expect-layers 3 --expect-bbox 1:%d,%d,%d,%d "
				   "--expect-pixel 1:%d:%d:255 --expect-pixel 1:%d:%d:255 "
				   "--expect-pixel 1:%d:%d:0",
				   r0, c0, r1, c1, rl, cl, rs, cs, rl, cs),
		     0);
	metrics_fini(&j.m);
	remove(path);
}

/* SL1S: 1620 x 2560 images of 50 um pixels, model SL1S, same orientation. */
static void test_sl1s(void)
{
	struct ell l = {50, 20};
	struct job j = {.fmt = OUT_SL1S, .printer = fixture_printer("sl1s"), .layers = 2,
			.threads = 2, .layer_mm = 0.05, .shape = in_ell, .arg = &l,
			.box = {50, 20, 70, 32}, .ss = 1};
	const char *path = fixture_path("ell.sl1s");
	int rl = (int)((128 - 69) / 0.05), cl = (int)(22 / 0.05);
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--printer sl1s --expect-layers 2 --expect-key printerModel=SL1S "
				   "--expect-pixel 0:%d:%d:255 --expect-key expTime=2",
				   rl, cl),
		     0);
	CHECK_EQ_INT(metric(&j.m, "sl1s.image_width_px"), 1620);
	metrics_fini(&j.m);
	remove(path);
}

/* Flipping a mirror flag flips the image along the matching axis, and
 * prusaslicer.ini says so.  The L sits off-centre (X 20..40), so its
 * mirror image (X 81..101) cannot overlap it. */
static void test_mirror_and_landscape(void)
{
	struct printer p = *fixture_printer("sl1");
	struct ell l = {20, 20};
	struct job j = {.fmt = OUT_SL1, .printer = &p, .layers = 1, .threads = 1,
			.layer_mm = 0.05, .shape = in_ell, .arg = &l, .box = {20, 20, 40, 32},
			.ss = 1};
	const char *path = fixture_path("mirror.sl1");
	/* the far end of the long arm, X = 39, Y = 22 */
	int rl = (int)((SL1_LONG_MM - 39) / SL1_PITCH_MM), cl = (int)(22 / SL1_PITCH_MM);
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path, "--expect-pixel 0:%d:%d:255", rl, cl), 0);
	metrics_fini(&j.m);
	/* mirror_y: rows run with X instead of against it */
	p.resin.mirror_y = 1;
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--expect-key display_mirror_y=1 --expect-pixel 0:%d:%d:255 "
				   "--expect-pixel 0:%d:%d:0",
				   (int)(39 / SL1_PITCH_MM), cl, rl, cl),
		     0);
	metrics_fini(&j.m);
	/* mirror_x off: columns run against Y (1440 - Y / p) */
	p.resin.mirror_y = 0;
	p.resin.mirror_x = 0;
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--expect-key display_mirror_x=0 --expect-pixel 0:%d:%d:255 "
				   "--expect-pixel 0:%d:%d:0",
				   rl, 1440 - 1 - cl, rl, cl),
		     0);
	metrics_fini(&j.m);
	/* landscape, no mirror flags: image 2560 x 1440, column = X / p,
	 * row = (68.04 - Y) / p (PrusaSlicer's raster origin is top left) */
	p.resin.portrait = 0;
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--expect-key display_orientation=landscape "
				   "--expect-pixel 0:%d:%d:255",
				   (int)((68.04 - 22) / SL1_PITCH_MM), (int)(39 / SL1_PITCH_MM)),
		     0);
	metrics_fini(&j.m);
	remove(path);
}

/* Generic stack: 1.png .. N.png and manifest.json. */
static void test_zip_stack(void)
{
	struct disk d = {60.48, 34.02, 5};
	struct job j = {.fmt = OUT_ZIP, .printer = fixture_printer("sl1"), .layers = 12,
			.threads = 3, .layer_mm = 0.1, .shape = in_disk, .arg = &d,
			.box = {55, 29, 66, 40}, .ss = 2};
	const char *path = fixture_path("stack.zip");
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path, "--expect-layers 12 --expect-sum 11:%llu "
					 "--expect-volume-mm3 %.6f --volume-rel 0.005",
				   (unsigned long long)j.sum, M_PI * 25 * 0.1 * 12),
		     0);
	CHECK_EQ_INT(metric(&j.m, "zip.layers"), 12);
	metrics_fini(&j.m);
	remove(path);
}

/* Thread counts change nothing: byte-identical archives. */
static void test_threads_deterministic(void)
{
	struct disk d = {60.48, 34.02, 8};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 16,
			.layer_mm = 0.05, .shape = in_disk, .arg = &d, .box = {52, 26, 69, 43},
			.ss = 2};
	const char *a = fixture_path("t1.sl1"), *b = fixture_path("t4.sl1");
	char cmd[1200];
	struct err e;

	err_clear(&e);
	j.threads = 1;
	REQUIRE_OK(write_job(a, &j, &e), &e);
	metrics_fini(&j.m);
	j.threads = 4;
	REQUIRE_OK(write_job(b, &j, &e), &e);
	metrics_fini(&j.m);
	snprintf(cmd, sizeof cmd, "cmp -s '%s' '%s'", a, b);
	CHECK_EQ_INT(system(cmd), 0);
	remove(a);
	remove(b);
}

/* ---- regions: the writer rasterises (slice_rasterize) ---- */

static void add_rect(struct paths *ps, double x0, double y0, double x1, double y1)
{
	struct pt2 q[4] = {{geom_mm_to_nm(x0), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y0)},
			   {geom_mm_to_nm(x1), geom_mm_to_nm(y1)},
			   {geom_mm_to_nm(x0), geom_mm_to_nm(y1)}};
	paths_add_pts(ps, q, 4);
}

/* The L as a polygon (CCW): the writer's rasteriser puts it where
 * REFERENCE.md says, with exact anti-aliased area. */
static void test_region_orientation(void)
{
	const struct pt2 ell[6] = {
		{geom_mm_to_nm(50), geom_mm_to_nm(20)}, {geom_mm_to_nm(70), geom_mm_to_nm(20)},
		{geom_mm_to_nm(70), geom_mm_to_nm(25)}, {geom_mm_to_nm(55), geom_mm_to_nm(25)},
		{geom_mm_to_nm(55), geom_mm_to_nm(32)}, {geom_mm_to_nm(50), geom_mm_to_nm(32)}};
	struct paths region;
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 4,
			.threads = 2, .layer_mm = 0.05, .box = {50, 20, 70, 32},
			.region = &region};
	const char *path = fixture_path("region-ell.sl1");
	/* pixels the L touches: rows (120.96 - 70) / p .. (120.96 - 50) / p,
	 * columns 20 / p .. 32 / p, partial ones included */
	int r0 = (int)floor((SL1_LONG_MM - 70) / SL1_PITCH_MM);
	int r1 = (int)ceil((SL1_LONG_MM - 50) / SL1_PITCH_MM) - 1;
	int c0 = (int)floor(20 / SL1_PITCH_MM), c1 = (int)ceil(32 / SL1_PITCH_MM) - 1;
	int rl = (int)((SL1_LONG_MM - 69) / SL1_PITCH_MM), cl = (int)(22 / SL1_PITCH_MM);
	int rs = (int)((SL1_LONG_MM - 52) / SL1_PITCH_MM), cs = (int)(31 / SL1_PITCH_MM);
	double area = 20 * 5 + 5 * 7;
	struct err e;

	paths_init(&region);
	REQUIRE(paths_add_pts(&region, ell, 6) == 0);
	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--printer sl1 --expect-layers 4 --expect-bbox 2:%d,%d,%d,%d "
				   "--expect-pixel 2:%d:%d:255 --expect-pixel 2:%d:%d:255 "
				   "--expect-pixel 2:%d:%d:0 --expect-volume-mm3 %.6f --volume-rel 0.001",
				   r0, c0, r1, c1, rl, cl, rs, cs, rl, cs, area * 0.05 * 4),
		     0);
	/* anti-aliased coverage: the area to within 8-bit rounding */
	CHECK_REL(metric(&j.m, "material_volume_mm3"), area * 0.05 * 4, 2e-4);
	metrics_fini(&j.m);
	paths_fini(&region);
	remove(path);
}

/* A square with a square hole, binary pixels: centre sampling gives the
 * area to within the boundary pixels; the hole stays empty. */
static void test_region_hole_binary(void)
{
	struct printer p = *fixture_printer("sl1s");
	struct paths region;
	struct pt2 hole[4];
	struct job j = {.fmt = OUT_SL1S, .printer = &p, .layers = 2, .threads = 1,
			.layer_mm = 0.05, .box = {40, 20, 80, 60}, .region = &region};
	const char *path = fixture_path("region-hole.sl1s");
	struct err e;

	p.resin.antialias = 0;
	paths_init(&region);
	add_rect(&region, 40, 20, 80, 60);
	add_rect(&region, 50, 30, 70, 50);
	/* the hole runs clockwise */
	for (int k = 0; k < 4; k++)
		hole[k] = region.v[1].pts[3 - k];
	memcpy(region.v[1].pts, hole, sizeof hole);
	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK_EQ_INT(fixture_check(path,
				   "--printer sl1s --expect-layers 2 --expect-key gamma_correction=0 "
				   "--expect-pixel 0:%d:%d:0 --expect-pixel 0:%d:%d:255 "
				   "--expect-volume-mm3 %.6f --volume-rel 0.002",
				   (int)((128 - 60) / 0.05), (int)(40 / 0.05), (int)((128 - 45) / 0.05),
				   (int)(25 / 0.05), (1600.0 - 400.0) * 0.05 * 2),
		     0);
	metrics_fini(&j.m);
	paths_fini(&region);
	remove(path);
}

/* ---- memory independent of the layer count ---- */

static size_t heap_bytes(void)
{
#if defined(__SANITIZE_ADDRESS__)
	return __sanitizer_get_current_allocated_bytes();
#else
	struct mallinfo2 mi = mallinfo2();
	return mi.uordblks + mi.hblkhd;
#endif
}

/* A 256 x 256 display whose layers encode to ~2 KB PNGs of short runs. */
static int in_stripes(double x, double y, const void *arg)
{
	(void)arg;
	return ((int)floor(x * 7.3) + (int)floor(y * 3.1)) % 3 == 0;
}

/* Peak live heap while writing n layers (sampled after every layer). */
static size_t peak_heap(int n, struct err *e, int *rc)
{
	struct printer p = *fixture_printer("sl1");
	struct out_info oi;
	struct sink s;
	struct buf sinkbuf;
	struct metrics m;
	void *st = NULL;
	size_t base, peak = 0;

	p.resin.pixels_x = p.resin.pixels_y = 256;
	p.resin.display_w_mm = p.resin.display_h_mm = 12.8;
	oi = fixture_info(OUT_SL1, &p, n, 0.05, 2);
	oi.part_bbox.lo = v3(0, 0, 0);
	oi.part_bbox.hi = v3(12.8, 12.8, 100); /* same thumbnail grid for every n */
	/* the archive goes to /dev/null so only the writer's memory counts */
	{
		int fd = open("/dev/null", O_WRONLY);
		sink_init_fd(&s, fd);
		buf_init(&sinkbuf);
		metrics_init(&m);
		base = heap_bytes();
		*rc = sl1_writer_ops.open(&oi, &s, &st, e);
		for (int k = 0; !*rc && k < n; k++) {
			struct layer ly;
			size_t now;
			memset(&ly, 0, sizeof ly);
			ly.index = k;
			ly.count = n;
			ly.height_mm = 0.05;
			ly.z_top_mm = (k + 1) * 0.05;
			ly.z_mm = ly.z_top_mm - 0.025;
			*rc = sl1_writer_ops.raster_get(st, &ly.raster, e);
			if (*rc)
				break;
			fixture_paint(ly.raster, sl1_writer_ops.raster_map(st), in_stripes, NULL,
				      0.1 + k % 5 * 0.01, 0.1, 12.7, 12.7, 1);
			ly.raster_ready = 1;
			*rc = sl1_writer_ops.layer(st, &ly, e);
			now = heap_bytes();
			peak = now > peak ? now : peak;
		}
		if (!*rc)
			*rc = sl1_writer_ops.close(st, &m, e);
		if (st)
			sl1_writer_ops.free_state(st);
		metrics_fini(&m);
		buf_fini(&sinkbuf);
		close(fd);
	}
	return peak > base ? peak - base : 0;
}

static void test_memory_independent_of_layers(void)
{
	struct err e;
	int rc;
	size_t small, large;

	err_clear(&e);
	peak_heap(20, &e, &rc); /* one-time library initialisation */
	REQUIRE_OK(rc, &e);
	small = peak_heap(200, &e, &rc);
	REQUIRE_OK(rc, &e);
	large = peak_heap(4000, &e, &rc);
	REQUIRE_OK(rc, &e);
	fprintf(stderr, "peak heap: %zu bytes for 200 layers, %zu for 4000\n", small, large);
	/* What may grow is the zip central directory, about 90 bytes an
	 * entry: 300 bytes a layer allow for it and for how many images the
	 * pool happened to need (at most 6 x 64 KB), while any image or PNG
	 * (~2 KB) kept per layer fails. */
	CHECK((double)large - (double)small < 3800 * 300.0);
	CHECK(small < 4u * 1024 * 1024);
}

/* ---- failures ---- */

struct failing_sink {
	uint64_t budget; /* bytes accepted before the "disk" is full */
};

static int failing_write(void *ctx, const void *buf, size_t len, struct err *e)
{
	struct failing_sink *f = ctx;
	(void)buf;
	if (len > f->budget) {
		f->budget = 0;
		return ERR_SET(e, ERR_IO, "write failed: No space left on device");
	}
	f->budget -= len;
	return 0;
}

/* A disk that fills up at various points: a clean ERR_IO naming the
 * cause from whichever call hits it, nothing after, no leak. */
static void test_disk_full(void)
{
	double fractions[] = {0, 0.01, 0.3, 0.6, 0.99};
	struct disk d = {60.48, 34.02, 15};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 40,
			.threads = 2, .layer_mm = 0.05, .shape = in_disk, .arg = &d,
			.box = {45, 19, 76, 50}, .ss = 1};
	const char *path = fixture_path("full.sl1");
	struct stat sb;
	struct err e0;

	/* the whole archive's size, to fail at fractions of it */
	err_clear(&e0);
	REQUIRE_OK(write_job(path, &j, &e0), &e0);
	metrics_fini(&j.m);
	REQUIRE(stat(path, &sb) == 0);
	remove(path);
	for (size_t b = 0; b < sizeof fractions / sizeof fractions[0]; b++) {
		uint64_t budget = (uint64_t)(fractions[b] * (double)sb.st_size);
		const struct writer_ops *ops = &sl1_writer_ops;
		struct out_info oi = fixture_info(OUT_SL1, fixture_printer("sl1"), 40, 0.05, 2);
		struct failing_sink f = {budget};
		struct sink s;
		struct metrics m;
		struct err e;
		void *st = NULL;
		int rc, k = 0;

		memset(&s, 0, sizeof s);
		s.write = failing_write;
		s.ctx = &f;
		metrics_init(&m);
		err_clear(&e);
		rc = ops->open(&oi, &s, &st, &e);
		for (; !rc && k < 40; k++) {
			struct layer ly;
			memset(&ly, 0, sizeof ly);
			ly.index = k;
			ly.count = 40;
			ly.height_mm = 0.05;
			ly.z_top_mm = (k + 1) * 0.05;
			rc = ops->raster_get(st, &ly.raster, &e);
			if (rc)
				break;
			fixture_paint(ly.raster, ops->raster_map(st), in_disk, &d, 45, 19, 76, 50, 1);
			ly.raster_ready = 1;
			rc = ops->layer(st, &ly, &e);
		}
		if (!rc)
			rc = ops->close(st, &m, &e);
		CHECK_EQ_INT(rc, ERR_IO);
		CHECK_CONTAINS(e.msg, "No space left on device");
		if (st) {
			/* the writer stays failed */
			struct raster *r = NULL;
			CHECK_EQ_INT(ops->raster_get(st, &r, &e), ERR_IO);
			ops->free_state(st);
		}
		metrics_fini(&m);
	}
}

/* Output size limit of the sink: ERR_LIMIT, cleanly. */
static void test_sink_limit(void)
{
	struct disk d = {60.48, 34.02, 15};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 30,
			.threads = 2, .layer_mm = 0.05, .shape = in_disk, .arg = &d,
			.box = {45, 19, 76, 50}, .ss = 1};
	struct out_info oi = fixture_info(OUT_SL1, j.printer, 30, 0.05, 2);
	struct buf b;
	struct sink s;
	void *st = NULL;
	struct err e;
	int rc;

	buf_init(&b);
	sink_init_buf(&s, &b);
	s.limit = 150000;
	err_clear(&e);
	rc = sl1_writer_ops.open(&oi, &s, &st, &e);
	for (int k = 0; !rc && k < 30; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.height_mm = 0.05;
		ly.z_top_mm = (k + 1) * 0.05;
		rc = sl1_writer_ops.raster_get(st, &ly.raster, &e);
		if (!rc) {
			fixture_paint(ly.raster, sl1_writer_ops.raster_map(st), in_disk, &d, 45, 19,
				      76, 50, 1);
			ly.raster_ready = 1;
			rc = sl1_writer_ops.layer(st, &ly, &e);
		}
	}
	metrics_init(&j.m);
	if (!rc)
		rc = sl1_writer_ops.close(st, &j.m, &e);
	CHECK_EQ_INT(rc, ERR_LIMIT);
	CHECK(b.len <= 150000);
	sl1_writer_ops.free_state(st);
	metrics_fini(&j.m);
	buf_fini(&b);
}

/* Cancelled mid-archive (freed without close, layers in flight): no
 * crash, no leak, and the file is not a readable archive. */
static void test_cancel_mid_archive(void)
{
	struct disk d = {60.48, 34.02, 12};
	struct job j = {.fmt = OUT_SL1, .printer = fixture_printer("sl1"), .layers = 100,
			.threads = 3, .layer_mm = 0.05, .shape = in_disk, .arg = &d,
			.box = {48, 22, 73, 47}, .ss = 1, .stop_after = 37};
	const char *path = fixture_path("cancel.sl1");
	struct err e;

	err_clear(&e);
	REQUIRE_OK(write_job(path, &j, &e), &e);
	CHECK(fixture_check(path, "") != 0);
	metrics_fini(&j.m);
	remove(path);
}

/* Misuse is reported, never crashes or leaks. */
static void test_misuse(void)
{
	struct printer fdm;
	struct out_info oi = fixture_info(OUT_SL1S, fixture_printer("sl1"), 3, 0.05, 1);
	struct buf b;
	struct sink s;
	struct metrics m;
	struct layer ly;
	struct raster *r;
	void *st = NULL;
	struct err e;

	buf_init(&b);
	sink_init_buf(&s, &b);
	metrics_init(&m);
	err_clear(&e);
	/* sl1s archive for the SL1 */
	CHECK_EQ_INT(sl1_writer_ops.open(&oi, &s, &st, &e), ERR_PARAM);
	CHECK_STR(e.field, "format");
	/* an FDM printer */
	memset(&fdm, 0, sizeof fdm);
	fdm.kind = PRINTER_FDM;
	snprintf(fdm.name, sizeof fdm.name, "generic-fdm");
	oi.printer = &fdm;
	CHECK_EQ_INT(sl1_writer_ops.open(&oi, &s, &st, &e), ERR_PARAM);
	CHECK_STR(e.field, "printer");
	/* layers out of order, a foreign image, too few layers at close */
	oi = fixture_info(OUT_SL1, fixture_printer("sl1"), 3, 0.05, 1);
	REQUIRE_OK(sl1_writer_ops.open(&oi, &s, &st, &e), &e);
	memset(&ly, 0, sizeof ly);
	ly.index = 1;
	ly.height_mm = 0.05;
	ly.z_top_mm = 0.1;
	CHECK_EQ_INT(sl1_writer_ops.layer(st, &ly, &e), ERR_INTERNAL);
	CHECK_CONTAINS(e.msg, "expected 0");
	sl1_writer_ops.free_state(st);

	REQUIRE_OK(sl1_writer_ops.open(&oi, &s, &st, &e), &e);
	memset(&ly, 0, sizeof ly);
	ly.raster = raster_new(1440, 2560);
	ly.raster_ready = 1;
	CHECK_EQ_INT(sl1_writer_ops.layer(st, &ly, &e), ERR_INTERNAL);
	CHECK(ly.raster == NULL); /* taken (and freed) all the same */
	sl1_writer_ops.free_state(st);

	REQUIRE_OK(sl1_writer_ops.open(&oi, &s, &st, &e), &e);
	REQUIRE_OK(sl1_writer_ops.raster_get(st, &r, &e), &e);
	memset(&ly, 0, sizeof ly);
	ly.raster = r;
	ly.raster_ready = 1;
	ly.height_mm = 0.05;
	ly.z_top_mm = 0.05;
	REQUIRE_OK(sl1_writer_ops.layer(st, &ly, &e), &e);
	CHECK_EQ_INT(sl1_writer_ops.close(st, &m, &e), ERR_INTERNAL);
	CHECK_CONTAINS(e.msg, "1 of 3 layers");
	sl1_writer_ops.free_state(st);
	metrics_fini(&m);
	buf_fini(&b);
}

int main(void)
{
	RUN(test_sl1_disk);
	RUN(test_sl1_orientation);
	RUN(test_sl1s);
	RUN(test_mirror_and_landscape);
	RUN(test_zip_stack);
	RUN(test_region_orientation);
	RUN(test_region_hole_binary);
	RUN(test_threads_deterministic);
	RUN(test_memory_independent_of_layers);
	RUN(test_disk_full);
	RUN(test_sink_limit);
	RUN(test_cancel_mid_archive);
	RUN(test_misuse);
	return harness_report();
}
