/* bench_sl1.c - SL1 archive throughput: 1000 frames of a 50 mm disk at
 * the SL1's 1440 x 2560 pixels through the real writer, with 1 and 2
 * encoder threads, plus the PNG encoder alone against libpng/zlib
 * (Z_RLE and level 1).  Prints figures; asserts nothing.
 *
 *   bench_sl1 [FRAMES] [OUT_DIR] [writer]   ("writer": skip the encoder table)
 *
 * Two ways in: "raster" frames are rendered by the "engine" straight
 * into the writer's images (spans with anti-aliased ends), as the lattice
 * engine does, so the figures are the writer's cost (encode + measure +
 * zip + sink); "region" frames are polygons (a 50 mm disk, 720 vertices)
 * the writer rasterises with slice_rasterize on its workers, as for a
 * sliced mesh (rasterise + encode + measure + zip + sink).
 */
#include "engine/core/err.h"
#include "engine/core/metrics.h"
#include "engine/core/progress.h"
#include "engine/core/sink.h"
#include "engine/geom/path.h"
#include "engine/output/image/image.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/writer.h"
#include "engine/slice/layer.h"

#include <fcntl.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>
#include <zlib.h>

#define DISK_R_MM 25.0

/* A disk of radius r_px centred at (cx, cy) pixels, coverage-shaded at
 * the ends of each row's span. */
static void render_disk(struct raster *r, double cx, double cy, double r_px)
{
	for (int y = (int)(cy - r_px) - 1; y <= (int)(cy + r_px) + 1; y++) {
		double dy = y + 0.5 - cy, dx, a, b;
		uint8_t *row;
		int ia, ib;
		if (y < 0 || y >= r->h || fabs(dy) >= r_px)
			continue;
		dx = sqrt(r_px * r_px - dy * dy);
		a = cx - dx;
		b = cx + dx;
		ia = (int)floor(a);
		ib = (int)floor(b);
		row = r->px + (size_t)y * r->stride;
		if (ib > ia + 1)
			memset(row + ia + 1, 255, (size_t)(ib - ia - 1));
		row[ia] = (uint8_t)lround(255 * (ia + 1 - a));
		row[ib] = (uint8_t)lround(255 * (b - ib));
	}
}

static double cpu_s(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec +
	       1e-6 * (double)(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

static double peak_rss_mb(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_maxrss / 1024.0;
}

/* A CCW polygon approximating a disk of radius r_mm at (cx, cy), in nm. */
static int disk_region(struct paths *ps, double cx, double cy, double r_mm, int n)
{
	struct path *p;

	paths_clear(ps);
	p = paths_add(ps);
	if (!p)
		return -1;
	for (int i = 0; i < n; i++) {
		double a = 2 * M_PI * i / n;
		struct pt2 q = {geom_mm_to_nm(cx + r_mm * cos(a)), geom_mm_to_nm(cy + r_mm * sin(a))};
		if (path_push(p, q))
			return -1;
	}
	return 0;
}

static int run_writer(int frames, int threads, int region, const char *path)
{
	const struct printer *p = &printer_resin_profiles[0]; /* sl1 */
	const struct writer_ops *ops = &sl1_writer_ops;
	struct out_info oi;
	struct metrics m;
	struct sink s;
	struct err e;
	void *st = NULL;
	double t0, t1, c0, c1, cx, cy, rpx;
	int fd, rc;

	memset(&oi, 0, sizeof oi);
	oi.format = OUT_SL1;
	oi.printer = p;
	oi.layer_count = frames;
	oi.layer_mm = 0.05;
	oi.part_bbox.lo = v3(60.48 - DISK_R_MM, 34.02 - DISK_R_MM, 0);
	oi.part_bbox.hi = v3(60.48 + DISK_R_MM, 34.02 + DISK_R_MM, frames * 0.05);
	oi.job_name = "bench";
	oi.engine_name = "solid";
	oi.threads = threads;
	oi.created = 1700000000;
	fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	if (fd < 0) {
		perror(path);
		return 1;
	}
	sink_init_fd(&s, fd);
	metrics_init(&m);
	err_clear(&e);
	t0 = progress_now_s();
	c0 = cpu_s();
	rc = ops->open(&oi, &s, &st, &e);
	for (int k = 0; !rc && k < frames; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.count = frames;
		ly.height_mm = 0.05;
		ly.z_top_mm = (k + 1) * 0.05;
		ly.z_mm = ly.z_top_mm - 0.025;
		rc = ops->raster_get(st, &ly.raster, &e);
		if (rc)
			break;
		raster_map_apply(ops->raster_map(st), 60.48, 34.02, &cx, &cy);
		rpx = DISK_R_MM / 0.04725 * (1.0 - 0.2 * (k % 100) / 100.0); /* varying size */
		if (region) {
			paths_init(&ly.region);
			if (disk_region(&ly.region, 60.48, 34.02, rpx * 0.04725, 720)) {
				paths_fini(&ly.region);
				raster_free(ly.raster);
				rc = ERR_SET(&e, ERR_NOMEM, "out of memory");
				break;
			}
		} else {
			render_disk(ly.raster, cx, cy, rpx);
			ly.raster_ready = 1;
		}
		rc = ops->layer(st, &ly, &e);
	}
	if (!rc)
		rc = ops->close(st, &m, &e);
	t1 = progress_now_s();
	c1 = cpu_s();
	if (st)
		ops->free_state(st);
	close(fd);
	if (rc) {
		fprintf(stderr, "bench_sl1: %s\n", e.msg);
		metrics_fini(&m);
		return 1;
	}
	printf("writer %-6s threads %d: %d frames in %.2f s = %.0f layers/s, %.0f Mpx/s, "
	       "CPU %.2f ms/layer, archive %.1f MB (%.1f KB/layer), peak RSS %.0f MB\n",
	       region ? "region" : "raster", threads, frames, t1 - t0, frames / (t1 - t0),
	       frames * 1440.0 * 2560.0 / (t1 - t0) / 1e6, (c1 - c0) / frames * 1e3,
	       metrics_get(&m, "sl1.archive_bytes")->ival / 1e6,
	       metrics_get(&m, "sl1.png_bytes")->ival / 1e3 / frames, peak_rss_mb());
	metrics_fini(&m);
	return 0;
}

/* ---- encoder alone: ours against libpng + zlib ---- */

struct mem_out {
	unsigned char *d;
	size_t n, cap;
};

static void mem_write(png_structp p, png_bytep data, size_t len)
{
	struct mem_out *b = png_get_io_ptr(p);
	if (b->n + len > b->cap) {
		b->cap = 2 * (b->n + len);
		b->d = realloc(b->d, b->cap);
	}
	memcpy(b->d + b->n, data, len);
	b->n += len;
}

static void mem_flush(png_structp p)
{
	(void)p;
}

static size_t libpng_gray(const struct raster *r, int level, int strategy, struct mem_out *b)
{
	png_structp p = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
	png_infop info = png_create_info_struct(p);

	b->n = 0;
	if (setjmp(png_jmpbuf(p))) {
		png_destroy_write_struct(&p, &info);
		return 0;
	}
	png_set_write_fn(p, b, mem_write, mem_flush);
	png_set_IHDR(p, info, (png_uint_32)r->w, (png_uint_32)r->h, 8, PNG_COLOR_TYPE_GRAY,
		     PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	png_set_filter(p, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
	png_set_compression_level(p, level);
	png_set_compression_strategy(p, strategy);
	png_write_info(p, info);
	for (int y = 0; y < r->h; y++)
		png_write_row(p, r->px + (size_t)y * r->stride);
	png_write_end(p, info);
	png_destroy_write_struct(&p, &info);
	return b->n;
}

static void encoders(int reps)
{
	struct raster *r = raster_new(1440, 2560);
	struct mem_out mo = {NULL, 0, 0};
	struct out_png_scratch scratch;
	struct buf b;
	struct err e;
	double t;
	size_t n = 0;

	render_disk(r, 720, 1280, DISK_R_MM / 0.04725);
	memset(&scratch, 0, sizeof scratch);
	buf_init(&b);
	t = progress_now_s();
	for (int i = 0; i < reps; i++) {
		buf_reset(&b);
		out_png_gray(r, NULL, &scratch, &b, NULL, &e);
	}
	t = progress_now_s() - t;
	printf("encoder infilld run-length deflate: %6.2f ms/frame, %6.0f Mpx/s, %zu bytes\n",
	       t / reps * 1e3, reps * 1440.0 * 2560.0 / t / 1e6, b.len);
	{
		const struct {
			const char *name;
			int level, strategy;
		} z[] = {{"libpng zlib level 1      ", 1, Z_DEFAULT_STRATEGY},
			 {"libpng zlib level 1 Z_RLE", 1, Z_RLE},
			 {"libpng zlib level 6 Z_RLE", 6, Z_RLE}};
		for (size_t k = 0; k < sizeof z / sizeof z[0]; k++) {
			t = progress_now_s();
			for (int i = 0; i < reps / 4 + 1; i++)
				n = libpng_gray(r, z[k].level, z[k].strategy, &mo);
			t = progress_now_s() - t;
			printf("encoder %s: %6.2f ms/frame, %6.0f Mpx/s, %zu bytes\n", z[k].name,
			       t / (reps / 4 + 1) * 1e3, (reps / 4 + 1) * 1440.0 * 2560.0 / t / 1e6,
			       n);
		}
	}
	free(mo.d);
	out_png_scratch_fini(&scratch);
	buf_fini(&b);
	raster_free(r);
}

int main(int argc, char **argv)
{
	int frames = argc > 1 ? atoi(argv[1]) : 1000;
	const char *dir = argc > 2 ? argv[2] : "/tmp";
	char path[1024];
	int rc = 0;

	if (frames < 1)
		frames = 1000;
	printf("SL1 frames 1440 x 2560, 50 mm disk (20%% size variation), %d frames\n", frames);
	if (!(argc > 3 && strcmp(argv[3], "writer") == 0))
		encoders(200);
	snprintf(path, sizeof path, "%s/bench_sl1.sl1", dir);
	for (int region = 0; region <= 1; region++)
		for (int threads = 1; threads <= 2; threads++)
			rc |= run_writer(frames, threads, region, path);
	remove(path);
	return rc;
}
