/* gcode_fixture.h - synthetic layer stacks for the G-code tests.
 *
 * A stack is a list of layer ranges, each a set of analytic shapes (rect,
 * circle, polygon; added or cut out).  The same description is turned
 * into integer-nm regions for the writer (circles as polygons on the
 * material side: inscribed when added, circumscribed when cut) and into
 * the JSON that tests/support/gcodecheck.py reads, so the checker gets
 * the geometry independently of what the writer was fed.
 */
#ifndef GCODE_FIXTURE_H
#define GCODE_FIXTURE_H

#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/core/sink.h"
#include "engine/geom/clip.h"
#include "engine/mesh/mesh.h"
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/output/writer.h"

#include <math.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>
#if defined(__SANITIZE_ADDRESS__)
/* libasan's allocator statistics (its header is not always installed). */
size_t __sanitizer_get_current_allocated_bytes(void);
#else
#include <malloc.h>
#endif

enum fx_kind { FX_RECT, FX_CIRCLE, FX_POLY };

struct fx_shape {
	enum fx_kind kind;
	int sub;          /* cut out instead of added */
	double a[4];      /* rect x0 y0 x1 y1; circle cx cy r */
	const double *pts; /* polygon: x0 y0 x1 y1 ..., CCW */
	int npts;
};

struct fx_range {
	int from, to; /* layer indices, inclusive */
	enum layer_fill fill;
	struct fx_shape shapes[64];
	int n;
};

struct fx_stack {
	struct fx_range r[8];
	int nr;
	int layers;
	double layer_mm;
};

static inline struct fx_range *fx_range_add(struct fx_stack *s, int from, int to)
{
	struct fx_range *r = &s->r[s->nr++];

	memset(r, 0, sizeof *r);
	r->from = from;
	r->to = to;
	return r;
}

static inline struct fx_shape *fx_shape_new(struct fx_range *r)
{
	struct fx_shape *s;

	if (r->n >= (int)(sizeof r->shapes / sizeof r->shapes[0])) {
		fprintf(stderr, "gcode_fixture: too many shapes\n");
		abort();
	}
	s = &r->shapes[r->n++];
	memset(s, 0, sizeof *s);
	return s;
}

static inline void fx_rect(struct fx_range *r, double x0, double y0, double x1, double y1, int sub)
{
	struct fx_shape *s = fx_shape_new(r);

	s->kind = FX_RECT;
	s->sub = sub;
	s->a[0] = x0;
	s->a[1] = y0;
	s->a[2] = x1;
	s->a[3] = y1;
}

static inline void fx_circle(struct fx_range *r, double cx, double cy, double rad, int sub)
{
	struct fx_shape *s = fx_shape_new(r);

	s->kind = FX_CIRCLE;
	s->sub = sub;
	s->a[0] = cx;
	s->a[1] = cy;
	s->a[2] = rad;
}

static inline void fx_poly(struct fx_range *r, const double *pts, int npts, int sub)
{
	struct fx_shape *s = fx_shape_new(r);

	s->kind = FX_POLY;
	s->sub = sub;
	s->pts = pts;
	s->npts = npts;
}

static inline struct pt2 fx_pt(double x, double y)
{
	return (struct pt2){geom_mm_to_nm(x), geom_mm_to_nm(y)};
}

/* Region of layer k: union of adds minus union of subs, normalised. */
static inline int fx_region(const struct fx_stack *st, int k, struct paths *out,
			    enum layer_fill *fill, struct err *e)
{
	struct paths add, sub;
	int rc;

	paths_init(&add);
	paths_init(&sub);
	*fill = LAYER_FILL_PART;
	for (int i = 0; i < st->nr; i++) {
		const struct fx_range *r = &st->r[i];
		if (k < r->from || k > r->to)
			continue;
		*fill = r->fill;
		for (int j = 0; j < r->n; j++) {
			const struct fx_shape *s = &r->shapes[j];
			struct paths *dst = s->sub ? &sub : &add;
			struct pt2 p[512];
			int n = 0;
			if (s->kind == FX_RECT) {
				p[0] = fx_pt(s->a[0], s->a[1]);
				p[1] = fx_pt(s->a[2], s->a[1]);
				p[2] = fx_pt(s->a[2], s->a[3]);
				p[3] = fx_pt(s->a[0], s->a[3]);
				n = 4;
			} else if (s->kind == FX_CIRCLE) {
				double rr = s->sub ? s->a[2] / cos(M_PI / 256) : s->a[2];
				for (n = 0; n < 256; n++)
					p[n] = fx_pt(s->a[0] + rr * cos(2 * M_PI * n / 256),
						     s->a[1] + rr * sin(2 * M_PI * n / 256));
			} else {
				for (n = 0; n < s->npts && n < 512; n++)
					p[n] = fx_pt(s->pts[2 * n], s->pts[2 * n + 1]);
			}
			if (paths_add_pts(dst, p, (size_t)n)) {
				paths_fini(&add);
				paths_fini(&sub);
				return ERR_SET(e, ERR_NOMEM, "out of memory building a test region");
			}
		}
	}
	rc = clip_boolean(CLIP_DIFFERENCE, &add, &sub, CLIP_FILL_NONZERO, out, e);
	paths_fini(&add);
	paths_fini(&sub);
	return rc;
}

/* The checker's view of the stack. */
static inline int fx_write_json(const struct fx_stack *st, const char *path)
{
	FILE *f = fopen(path, "w");

	if (!f)
		return -1;
	fprintf(f, "{\"layers\": [");
	for (int i = 0; i < st->nr; i++) {
		const struct fx_range *r = &st->r[i];
		fprintf(f, "%s{\"from\": %d, \"to\": %d, \"shapes\": [", i ? ", " : "", r->from, r->to);
		for (int j = 0; j < r->n; j++) {
			const struct fx_shape *s = &r->shapes[j];
			const char *op = s->sub ? "sub" : "add";
			if (j)
				fprintf(f, ", ");
			if (s->kind == FX_RECT)
				fprintf(f,
					"{\"kind\": \"rect\", \"op\": \"%s\", \"x0\": %.9g, \"y0\": %.9g, "
					"\"x1\": %.9g, \"y1\": %.9g}",
					op, s->a[0], s->a[1], s->a[2], s->a[3]);
			else if (s->kind == FX_CIRCLE)
				fprintf(f,
					"{\"kind\": \"circle\", \"op\": \"%s\", \"cx\": %.9g, \"cy\": "
					"%.9g, \"r\": %.9g}",
					op, s->a[0], s->a[1], s->a[2]);
			else {
				fprintf(f, "{\"kind\": \"polygon\", \"op\": \"%s\", \"pts\": [", op);
				for (int k = 0; k < s->npts; k++)
					fprintf(f, "%s[%.9g, %.9g]", k ? ", " : "", s->pts[2 * k],
						s->pts[2 * k + 1]);
				fprintf(f, "]}");
			}
		}
		fprintf(f, "]}");
	}
	fprintf(f, "]}\n");
	return fclose(f) ? -1 : 0;
}

static inline struct printer fx_printer(void)
{
	return printer_fdm_profiles[0];
}

struct fx_run {
	int threads;
	int feed_layers;        /* < layers: stop early and free without close */
	struct sink *sink;      /* NULL: into out */
	const struct mesh *mesh; /* the part, for thumbnails (borrowed), or NULL */
	struct buf out;
	struct metrics m;
	struct err e;
	int rc;                 /* first failure */
	double peak_heap_bytes; /* when sampling */
	int sample_heap;
};

/* Bytes allocated on the heap now (main arena under glibc: run
 * single-threaded when sampling). */
static inline double fx_heap_bytes(void)
{
#if defined(__SANITIZE_ADDRESS__)
	return (double)__sanitizer_get_current_allocated_bytes();
#else
	struct mallinfo2 mi = mallinfo2();
	return (double)mi.uordblks + (double)mi.hblkhd;
#endif
}

static inline void fx_run_init(struct fx_run *r, int threads)
{
	memset(r, 0, sizeof *r);
	r->threads = threads;
	r->feed_layers = -1;
	buf_init(&r->out);
	metrics_init(&r->m);
	err_clear(&r->e);
}

static inline void fx_run_fini(struct fx_run *r)
{
	buf_fini(&r->out);
	metrics_fini(&r->m);
}

/* Drive the G-code writer over the stack. */
static inline int fx_write(const struct fx_stack *st, const struct printer *pr, struct fx_run *r)
{
	struct out_info info;
	struct sink bs, *s = r->sink;
	struct pt2 lo = {0, 0}, hi = {0, 0};
	void *state = NULL;
	int n = r->feed_layers >= 0 ? r->feed_layers : st->layers, rc;

	if (!s) {
		sink_init_buf(&bs, &r->out);
		s = &bs;
	}
	memset(&info, 0, sizeof info);
	/* part bounding box from the regions */
	for (int k = 0; k < st->layers; k++) {
		struct paths reg;
		enum layer_fill fill;
		struct pt2 a, b;
		paths_init(&reg);
		if (fx_region(st, k, &reg, &fill, &r->e) == 0 && paths_bbox(&reg, &a, &b)) {
			if (lo.x == 0 && hi.x == 0) {
				lo = a;
				hi = b;
			}
			if (a.x < lo.x) lo.x = a.x;
			if (a.y < lo.y) lo.y = a.y;
			if (b.x > hi.x) hi.x = b.x;
			if (b.y > hi.y) hi.y = b.y;
		}
		paths_fini(&reg);
	}
	info.format = OUT_GCODE;
	info.printer = pr;
	info.layer_count = st->layers;
	info.layer_mm = st->layer_mm;
	info.part_bbox.lo = v3(geom_nm_to_mm(lo.x), geom_nm_to_mm(lo.y), 0);
	info.part_bbox.hi = v3(geom_nm_to_mm(hi.x), geom_nm_to_mm(hi.y), st->layers * st->layer_mm);
	info.job_name = "fixture";
	info.engine_name = "solid";
	info.threads = r->threads;
	info.mesh = r->mesh;
	info.created = 1700000000; /* 2023-11-14 22:13:20 UTC */
	rc = gcode_writer_ops.open(&info, s, &state, &r->e);
	for (int k = 0; !rc && k < n; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.count = st->layers;
		ly.height_mm = st->layer_mm;
		ly.z_mm = (k + 0.5) * st->layer_mm;
		ly.z_top_mm = (k + 1) * st->layer_mm;
		paths_init(&ly.region);
		rc = fx_region(st, k, &ly.region, &ly.fill, &r->e);
		if (!rc)
			rc = gcode_writer_ops.layer(state, &ly, &r->e);
		paths_fini(&ly.region);
		if (r->sample_heap && fx_heap_bytes() > r->peak_heap_bytes)
			r->peak_heap_bytes = fx_heap_bytes();
	}
	if (!rc && n == st->layers)
		rc = gcode_writer_ops.close(state, &r->m, &r->e);
	if (r->sample_heap && fx_heap_bytes() > r->peak_heap_bytes)
		r->peak_heap_bytes = fx_heap_bytes();
	if (state)
		gcode_writer_ops.free_state(state);
	r->rc = rc;
	return rc;
}

/* A scratch directory for this test program (removed by fx_tmp_clean). */
static char fx_dir[256];

static inline const char *fx_tmp(const char *name)
{
	static char buf[4][512];
	static int k;
	char *b = buf[k++ & 3];

	if (!fx_dir[0]) {
		const char *t = getenv("TMPDIR");
		snprintf(fx_dir, sizeof fx_dir, "%s/gcode_test_XXXXXX", t && t[0] ? t : "/tmp");
		if (!mkdtemp(fx_dir))
			snprintf(fx_dir, sizeof fx_dir, "/tmp");
	}
	snprintf(b, sizeof buf[0], "%s/%s", fx_dir, name);
	return b;
}

static inline void fx_tmp_clean(void)
{
	char cmd[600];

	if (fx_dir[0] && strcmp(fx_dir, "/tmp") != 0) {
		snprintf(cmd, sizeof cmd, "rm -rf '%s'", fx_dir);
		if (system(cmd) != 0)
			fprintf(stderr, "could not remove %s\n", fx_dir);
	}
}

static inline int fx_save(const struct buf *b, const char *path)
{
	FILE *f = fopen(path, "wb");
	size_t n;

	if (!f)
		return -1;
	n = fwrite(b->data, 1, b->len, f);
	return fclose(f) || n != b->len ? -1 : 0;
}

/* Run gcodecheck.py on gcode (with regions JSON or NULL, extra args);
 * the summary goes to summary.  Returns its exit status. */
static inline int fx_check(const char *gcode, const char *regions, const char *summary,
			   const char *extra)
{
	char cmd[2048];
	int rc;

	snprintf(cmd, sizeof cmd, "python3 tests/support/gcodecheck.py '%s' %s%s%s --summary '%s' %s",
		 gcode, regions ? "--regions '" : "", regions ? regions : "", regions ? "'" : "",
		 summary, extra ? extra : "");
	rc = system(cmd);
	return rc == -1 ? -1 : WIFEXITED(rc) ? WEXITSTATUS(rc) : 128;
}

/* A value from a checker summary; NAN when absent. */
static inline double fx_get(const char *summary, const char *key)
{
	FILE *f = fopen(summary, "r");
	char k[256];
	double v, out = NAN;

	if (!f)
		return NAN;
	while (fscanf(f, "%255s %lf", k, &v) == 2)
		if (strcmp(k, key) == 0) {
			out = v;
			break;
		}
	fclose(f);
	return out;
}

static inline double fx_get0(const char *summary, const char *key)
{
	double v = fx_get(summary, key);
	return isnan(v) ? 0 : v;
}

static inline double fx_metric(const struct metrics *m, const char *key)
{
	const struct metric *x = metrics_get(m, key);

	if (!x)
		return NAN;
	return x->type == METRIC_NUM ? x->num : (double)x->ival;
}

#endif
