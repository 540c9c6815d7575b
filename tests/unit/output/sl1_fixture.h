/* sl1_fixture.h - shared helpers of the resin writer tests: archives
 * written through the real writer into files, checked by
 * tests/support/sl1check.py, and shapes painted through a printer's
 * pixel map.  Header-only (each test file is its own program).
 */
#ifndef INFILLD_SL1_FIXTURE_H
#define INFILLD_SL1_FIXTURE_H

#include "engine/core/err.h"
#include "engine/core/metrics.h"
#include "engine/core/sink.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/writer.h"
#include "engine/slice/layer.h"
#include "harness.h"

#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* A printer-frame shape (mm): nonzero when (x, y) is material. */
typedef int (*fixture_shape)(double x_mm, double y_mm, const void *arg);

static inline const struct printer *fixture_printer(const char *name)
{
	for (size_t i = 0; i < printer_resin_profile_count; i++)
		if (strcmp(printer_resin_profiles[i].name, name) == 0)
			return &printer_resin_profiles[i];
	return NULL;
}

/* Path of a scratch file "<dir>/<pid>-<name>" in a static buffer. */
static inline const char *fixture_path(const char *name)
{
	static char buf[4][512];
	static int k;
	const char *b = getenv("INFILLD_BUILD");
	char *p = buf[k++ & 3];

	if (b) {
		char dir[480];
		snprintf(dir, sizeof dir, "%s/tmp", b);
		mkdir(dir, 0755);
		snprintf(p, sizeof buf[0], "%s/%d-%s", dir, (int)getpid(), name);
	} else {
		snprintf(p, sizeof buf[0], "/tmp/%d-%s", (int)getpid(), name);
	}
	return p;
}

/* Run sl1check.py on path with extra arguments; its exit status. */
static inline int fixture_check(const char *path, const char *fmt, ...)
{
	char args[6000], cmd[7000];
	va_list ap;
	int rc;

	va_start(ap, fmt);
	vsnprintf(args, sizeof args, fmt, ap);
	va_end(ap);
	snprintf(cmd, sizeof cmd, "python3 tests/support/sl1check.py '%s' %s", path, args);
	rc = system(cmd);
	if (rc != 0)
		fprintf(stderr, "  (command: %s)\n", cmd);
	return rc == -1 ? -1 : WEXITSTATUS(rc);
}

/* Paint shape into r through map, binary (pixel centre inside -> 255)
 * or with ss x ss supersampled coverage, only within the pixel box of
 * the shape's mm box lo..hi.  Returns the pixel sum written. */
static inline uint64_t fixture_paint(struct raster *r, const struct raster_map *map,
				     fixture_shape inside, const void *arg, double lo_x,
				     double lo_y, double hi_x, double hi_y, int ss)
{
	double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;
	uint64_t sum = 0;

	for (int k = 0; k < 4; k++) {
		double u, v;
		raster_map_apply(map, k & 1 ? hi_x : lo_x, k & 2 ? hi_y : lo_y, &u, &v);
		u_lo = fmin(u_lo, u);
		u_hi = fmax(u_hi, u);
		v_lo = fmin(v_lo, v);
		v_hi = fmax(v_hi, v);
	}
	for (int y = (int)fmax(0, floor(v_lo) - 1); y <= (int)fmin(r->h - 1, ceil(v_hi) + 1); y++)
		for (int x = (int)fmax(0, floor(u_lo) - 1); x <= (int)fmin(r->w - 1, ceil(u_hi) + 1);
		     x++) {
			int hits = 0;
			for (int sy = 0; sy < ss; sy++)
				for (int sx = 0; sx < ss; sx++) {
					double xm, ym;
					raster_map_invert(map, x + (sx + 0.5) / ss, y + (sy + 0.5) / ss,
							  &xm, &ym);
					hits += inside(xm, ym, arg) != 0;
				}
			r->px[(size_t)y * r->stride + (size_t)x] =
				(uint8_t)((255 * hits + ss * ss / 2) / (ss * ss));
			sum += r->px[(size_t)y * r->stride + (size_t)x];
		}
	return sum;
}

/* A file sink on a fresh file; fd in *fd. */
static inline int fixture_open_file(const char *path, struct sink *s, int *fd)
{
	*fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	if (*fd < 0)
		return -1;
	sink_init_fd(s, *fd);
	return 0;
}

/* out_info for a printer with n layers of layer_mm, no mesh. */
static inline struct out_info fixture_info(enum out_format f, const struct printer *p, int n,
					   double layer_mm, int threads)
{
	struct out_info oi;

	memset(&oi, 0, sizeof oi);
	oi.format = f;
	oi.printer = p;
	oi.layer_count = n;
	oi.layer_mm = layer_mm;
	oi.part_bbox.lo = v3(40, 20, 0);
	oi.part_bbox.hi = v3(80, 50, n * layer_mm);
	oi.job_name = "fixture part";
	oi.engine_name = "solid";
	oi.threads = threads;
	oi.created = 1700000000; /* 2023-11-14 at 22:13:20 UTC */
	return oi;
}

#endif
