/* test_core.c - errors, parameters, metrics, progress, pipeline. */
#include "harness.h"

#include <stddef.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/core/param.h"
#include "engine/core/pipeline.h"
#include "engine/core/progress.h"
#include "engine/core/sink.h"

struct demo {
	int flag;
	int count;
	double size_mm;
	int mode;
	char name[16];
	double at[3];
};

static const char *const modes[] = {"fast", "slow", NULL};
static const struct param_desc demo_desc[] = {
	{.name = "flag", .type = PARAM_BOOL, .offset = offsetof(struct demo, flag), .def = 1},
	{.name = "count", .type = PARAM_INT, .offset = offsetof(struct demo, count), .min = 1,
	 .max = 10, .def = 3},
	{.name = "size_mm", .type = PARAM_NUM, .offset = offsetof(struct demo, size_mm), .min = 0,
	 .max = 5, .def = 0.5, .flags = PARAM_F_MIN_EXCL, .unit = "mm"},
	{.name = "mode", .type = PARAM_ENUM, .offset = offsetof(struct demo, mode), .def = 1,
	 .choices = modes},
	{.name = "name", .type = PARAM_STR, .offset = offsetof(struct demo, name), .max = 15,
	 .str_cap = 16, .def_str = "abc"},
	{.name = "at", .type = PARAM_VEC3, .offset = offsetof(struct demo, at), .min = -100,
	 .max = 100, .def_str = "1,2,3"},
};
static const struct param_table demo_table = {"demo", demo_desc,
					      sizeof demo_desc / sizeof demo_desc[0]};

static void test_param_defaults_and_set(void)
{
	struct demo d;
	struct err e;
	char buf[64];

	err_clear(&e);
	param_defaults(&demo_table, &d);
	CHECK_EQ_INT(d.flag, 1);
	CHECK_EQ_INT(d.count, 3);
	CHECK_NUM(d.size_mm, ==, 0.5);
	CHECK_EQ_INT(d.mode, 1);
	CHECK_STR(d.name, "abc");
	CHECK_NUM(d.at[2], ==, 3);
	CHECK_EQ_INT(param_check(&demo_table, &d, &e), 0);

	CHECK_EQ_INT(param_set(&demo_table, &d, "count", "7", &e), 0);
	CHECK_EQ_INT(d.count, 7);
	CHECK_EQ_INT(param_set(&demo_table, &d, "flag", "off", &e), 0);
	CHECK_EQ_INT(d.flag, 0);
	CHECK_EQ_INT(param_set(&demo_table, &d, "mode", "fast", &e), 0);
	CHECK_EQ_INT(d.mode, 0);
	CHECK_EQ_INT(param_set(&demo_table, &d, "at", "-1, 0.5,2e1", &e), 0);
	CHECK_NUM(d.at[2], ==, 20);
	param_format(&demo_table.v[3], &d, buf, sizeof buf);
	CHECK_STR(buf, "fast");
}

static void test_param_errors(void)
{
	struct demo d;
	struct err e;

	param_defaults(&demo_table, &d);
	err_clear(&e);
	CHECK_EQ_INT(param_set(&demo_table, &d, "nope", "1", &e), ERR_NOTFOUND);
	CHECK_EQ_INT(param_set(&demo_table, &d, "count", "11", &e), ERR_PARAM);
	CHECK_STR(e.field, "count");
	CHECK_CONTAINS(e.msg, "[1, 10]");
	CHECK_EQ_INT(param_set(&demo_table, &d, "count", "2.5", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "size_mm", "0", &e), ERR_PARAM);
	CHECK_CONTAINS(e.msg, "(0, 5]");
	CHECK_EQ_INT(param_set(&demo_table, &d, "size_mm", "nan", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "size_mm", "1e999", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "size_mm", "1mm", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "mode", "medium", &e), ERR_PARAM);
	CHECK_CONTAINS(e.msg, "fast, slow");
	CHECK_EQ_INT(param_set(&demo_table, &d, "name", "0123456789abcdefg", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "at", "1,2", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "at", "1,2,3,4", &e), ERR_PARAM);
	CHECK_EQ_INT(param_set(&demo_table, &d, "flag", "maybe", &e), ERR_PARAM);
	/* values were left untouched by failures */
	CHECK_EQ_INT(d.count, 3);
	CHECK_NUM(d.size_mm, ==, 0.5);
	d.count = 99;
	CHECK_EQ_INT(param_check(&demo_table, &d, &e), ERR_PARAM);
	CHECK_STR(e.field, "count");
}

static void test_err_format(void)
{
	struct err e;
	char buf[600];

	err_clear(&e);
	CHECK_EQ_INT(ERR_PLACE(&e, ERR_PARSE, 84, 0, 1, "NaN coordinate"), ERR_PARSE);
	err_format(&e, buf, sizeof buf);
	CHECK_STR(buf, "parse error at byte 84 (record 1): NaN coordinate");
	err_prefix(&e, "reading %s", "x.stl");
	CHECK_STR(e.msg, "reading x.stl: NaN coordinate");
	CHECK(e.src_line > 0);
}

static void test_metrics(void)
{
	struct metrics m;

	metrics_init(&m);
	CHECK_EQ_INT(metrics_num(&m, "a.b", 1.5), 0);
	CHECK_EQ_INT(metrics_int(&m, "layers", 10), 0);
	CHECK_EQ_INT(metrics_str(&m, "a.s", "x"), 0);
	CHECK_EQ_INT(metrics_num(&m, "a.b", 2.5), 0); /* replace keeps order */
	CHECK_EQ_INT(m.n, 3);
	CHECK_STR(m.v[0].key, "a.b");
	CHECK_NUM(metrics_get(&m, "a.b")->num, ==, 2.5);
	CHECK_EQ_INT(metrics_num(&m, "inf", 1.0 / 0.0), 0);
	CHECK(isnan(metrics_get(&m, "inf")->num));
	metrics_fini(&m);
}

static void test_alloc_injection(void)
{
	void *p;
	struct buf b;

	mem_fail_after(2);
	p = mem_alloc(10);
	CHECK(p != NULL);
	CHECK(mem_alloc(10) == NULL);
	CHECK(mem_alloc(10) == NULL);
	CHECK_EQ_INT(mem_injected_failures(), 2);
	mem_fail_after(-1);
	mem_free(p);
	buf_init(&b);
	mem_fail_after(1);
	CHECK_EQ_INT(buf_append(&b, "x", 1), ERR_NOMEM);
	mem_fail_after(-1);
	CHECK_EQ_INT(buf_append(&b, "xy", 2), 0);
	CHECK_EQ_INT(b.len, 2);
	buf_fini(&b);
}

struct pctx {
	long next_emit;
	long sum;
	int fail_at;
};

static int p_work(void *ctx, void *item, struct err *e)
{
	struct pctx *c = ctx;
	long *v = item;

	if (*v == c->fail_at)
		return ERR_SET(e, ERR_IO, "item %ld failed", *v);
	*v *= 2;
	return 0;
}

static int p_emit(void *ctx, void *item, struct err *e)
{
	struct pctx *c = ctx;
	long *v = item;

	(void)e;
	if (*v != 2 * c->next_emit) {
		fprintf(stderr, "out of order: %ld after %ld\n", *v, c->next_emit);
		c->sum = -1000000;
	}
	c->next_emit++;
	c->sum += *v;
	mem_free(v);
	return 0;
}

static void p_drop(void *ctx, void *item)
{
	(void)ctx;
	mem_free(item);
}

static void run_pipeline(int threads, int fail_at, int *rc_out, long *sum)
{
	static const struct pipeline_ops ops = {p_work, p_emit, p_drop};
	struct pctx c = {0, 0, fail_at};
	struct pipeline *p;
	struct err e;
	int rc = 0;

	err_clear(&e);
	if (pipeline_new(&ops, &c, threads, 4, &p, &e)) {
		*rc_out = -99;
		return;
	}
	for (long i = 0; i < 1000 && rc == 0; i++) {
		long *v = mem_alloc(sizeof *v);
		*v = i;
		rc = pipeline_submit(p, v, &e);
	}
	if (!rc)
		rc = pipeline_finish(p, &e);
	pipeline_free(p);
	*rc_out = rc;
	*sum = c.sum;
}

static void test_pipeline(void)
{
	int rc;
	long sum;

	for (int threads = 0; threads <= 3; threads++) {
		run_pipeline(threads, -1, &rc, &sum);
		CHECK_EQ_INT(rc, 0);
		CHECK_EQ_INT(sum, 999 * 1000);
		run_pipeline(threads, 500, &rc, &sum);
		CHECK_EQ_INT(rc, ERR_IO);
		CHECK(sum < 999 * 1000 && sum >= 0);
	}
}

static int cancel_after;
static int cancelled_cb(void *ctx)
{
	(void)ctx;
	return --cancel_after < 0;
}

static void test_progress(void)
{
	struct progress p;
	struct progress_hooks h = {NULL, cancelled_cb, NULL};
	struct err e;

	cancel_after = 3;
	err_clear(&e);
	progress_init(&p, &h);
	progress_stage(&p, "a", 0.0, 0.5);
	CHECK_EQ_INT(progress_update(&p, 0.5, &e), 0);
	CHECK_NEAR(p.info.fraction, 0.25, 1e-12);
	progress_stage(&p, "b", 0.1, 1.0); /* lo below current: clamped */
	CHECK_NEAR(p.info.fraction, 0.25, 1e-12);
	CHECK_EQ_INT(progress_update(&p, 0.0, &e), 0);
	CHECK_EQ_INT(progress_update(&p, 1.0, &e), 0);
	CHECK_NEAR(p.info.fraction, 1.0, 1e-12);
	CHECK_EQ_INT(progress_update(&p, 1.0, &e), ERR_CANCELLED);
}

int main(void)
{
	RUN(test_param_defaults_and_set);
	RUN(test_param_errors);
	RUN(test_err_format);
	RUN(test_metrics);
	RUN(test_alloc_injection);
	RUN(test_pipeline);
	RUN(test_progress);
	return harness_report();
}
