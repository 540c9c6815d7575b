/* cli_run.c - `infilld run`, `infilld analyze`, `infilld engines`: one job
 * from the shell.  The contract is in README.md ("Command line"): exit 0
 * on success, 1 with one line "infilld: <what and where>" on failure, 2
 * on usage errors.  Outputs are written to OUT.part and renamed into
 * place only on success, so a failed or interrupted run leaves no
 * partial file behind. */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "api/api_json.h"
#include "engine/core/mem.h"
#include "engine/engine.h"
#include "service/commands.h"

#define CLI_MAX_SETS 256

struct cli_opts {
	const char *input, *output, *engine, *format, *printer, *params_file, *metrics_file;
	const char *loads_file; /* --loads: JSON load case -> the engine key "loads" */
	const char *sets[CLI_MAX_SETS];
	int nsets, quiet, threads;
};

/* SIGINT/SIGTERM request cooperative cancellation of the running job. */
static volatile sig_atomic_t interrupted;

static void on_signal(int sig)
{
	(void)sig;
	interrupted = 1;
}

static int is_cancelled(void *ctx)
{
	(void)ctx;
	return interrupted;
}

static int fail(const struct err *e)
{
	char line[ERR_MSG_MAX + 256];

	fprintf(stderr, "infilld: %s\n", err_format(e, line, sizeof line));
	return 1;
}

static int usage_error(const char *cmd, const char *fmt, ...)
	__attribute__((format(printf, 2, 3)));
static int usage_error(const char *cmd, const char *fmt, ...)
{
	va_list ap;

	fprintf(stderr, "infilld %s: ", cmd);
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fprintf(stderr, " (see `infilld --help`)\n");
	return 2;
}

/* Parse the options shared by run and analyze.  Returns 0 or 2. */
static int parse_opts(const char *cmd, int argc, char **argv, struct cli_opts *o)
{
	memset(o, 0, sizeof *o);
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		const char **slot = NULL;

		if (!strcmp(a, "-o") || !strcmp(a, "--output")) slot = &o->output;
		else if (!strcmp(a, "--engine")) slot = &o->engine;
		else if (!strcmp(a, "--format")) slot = &o->format;
		else if (!strcmp(a, "--printer")) slot = &o->printer;
		else if (!strcmp(a, "--params")) slot = &o->params_file;
		else if (!strcmp(a, "--metrics")) slot = &o->metrics_file;
		else if (!strcmp(a, "--loads")) slot = &o->loads_file;
		else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
			o->quiet = 1;
			continue;
		} else if (!strcmp(a, "--threads")) {
			if (++i >= argc)
				return usage_error(cmd, "%s needs a value", a);
			if (!(o->threads = cmd_threads_arg(argv[i], 256)))
				return usage_error(cmd, "--threads wants 1..256, not '%s'", argv[i]);
			continue;
		} else if (!strcmp(a, "--set") || !strcmp(a, "-s")) {
			if (++i >= argc)
				return usage_error(cmd, "%s needs KEY=VALUE", a);
			if (!strchr(argv[i], '='))
				return usage_error(cmd, "--set wants KEY=VALUE, not '%s'", argv[i]);
			if (o->nsets == CLI_MAX_SETS)
				return usage_error(cmd, "more than %d --set options", CLI_MAX_SETS);
			o->sets[o->nsets++] = argv[i];
			continue;
		} else if (a[0] == '-' && a[1] != '\0') {
			return usage_error(cmd, "unknown option '%s'", a);
		} else if (!o->input) {
			o->input = a;
			continue;
		} else {
			return usage_error(cmd, "unexpected argument '%s'", a);
		}
		if (++i >= argc)
			return usage_error(cmd, "%s needs a value", a);
		*slot = argv[i];
	}
	if (!o->input)
		return usage_error(cmd, "%s", "missing the input MESH");
	return 0;
}

/* --params FILE.json, --loads FILE.json, then every --set in order (later
 * wins). */
static int apply_params(struct job_spec *js, const struct cli_opts *o, struct err *e)
{
	int rc;

	if (o->params_file) {
		json_error_t je;
		json_t *p = json_load_file(o->params_file, JSON_REJECT_DUPLICATES, &je);
		if (!p)
			return ERR_PLACE(e, ERR_PARSE, -1, je.line > 0 ? je.line : 0, -1,
					 "%s: %s", o->params_file, je.text);
		rc = api_params_apply(js, p, 1, e);
		json_decref(p);
		if (rc) {
			err_prefix(e, "%s", o->params_file);
			return rc;
		}
	}
	if (o->loads_file) {
		char *text = NULL;
		rc = cmd_loads_read(o->loads_file, &text, e);
		if (!rc)
			rc = job_spec_set(js, "loads", text, e);
		mem_free(text);
		if (rc)
			return rc;
	}
	for (int i = 0; i < o->nsets; i++) {
		char key[128];
		const char *eq = strchr(o->sets[i], '=');
		size_t klen = (size_t)(eq - o->sets[i]);
		if (klen == 0 || klen >= sizeof key)
			return ERR_FIELD(e, "", "--set '%s' has no usable key", o->sets[i]);
		memcpy(key, o->sets[i], klen);
		key[klen] = '\0';
		rc = job_spec_set(js, key, eq + 1, e);
		if (rc)
			return rc;
	}
	return 0;
}

struct bar {
	int tty;
	double last_s;
};

/* A one-line progress bar on stderr, redrawn at most 10 times a second. */
static void bar_report(void *ctx, const struct progress_info *p)
{
	struct bar *b = ctx;
	double now = progress_now_s();
	char fill[41];
	int n = (int)(p->fraction * 40 + 0.5);

	if (!b->tty || (now - b->last_s < 0.1 && p->fraction < 1.0))
		return;
	b->last_s = now;
	for (int i = 0; i < 40; i++)
		fill[i] = i < n ? '#' : '.';
	fill[40] = '\0';
	if (p->layers_total > 0)
		fprintf(stderr, "\r[%s] %5.1f%% %-8s layer %d/%d ", fill, p->fraction * 100,
			p->stage, p->layers_done, p->layers_total);
	else
		fprintf(stderr, "\r[%s] %5.1f%% %-8s               ", fill, p->fraction * 100,
			p->stage);
}

static int write_json_file(const char *path, json_t *j, struct err *e)
{
	char tmp[4096];

	if (!strcmp(path, "-")) {
		json_dumpf(j, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(10));
		fputc('\n', stdout);
		return 0;
	}
	snprintf(tmp, sizeof tmp, "%s.part", path);
	if (json_dump_file(j, tmp, JSON_INDENT(2) | JSON_REAL_PRECISION(10)) != 0 ||
	    rename(tmp, path) != 0) {
		unlink(tmp);
		return ERR_SET(e, ERR_IO, "cannot write %s: %s", path, strerror(errno));
	}
	return 0;
}

int cmd_threads_arg(const char *s, int max)
{
	char *end;
	long n;

	errno = 0;
	n = strtol(s, &end, 10);
	return *end || errno || n < 1 || n > max ? 0 : (int)n;
}

void cmd_print_warnings(const struct metrics *m)
{
	const struct metric *w = metrics_get(m, "warnings");
	const char *p = w && w->type == METRIC_STRS && w->str ? w->str : NULL;

	for (long long i = 0; p && i < w->ival; i++) {
		size_t n = strcspn(p, "\n");
		fprintf(stderr, "infilld: warning: %.*s\n", (int)n, p);
		p += n + (p[n] == '\n');
	}
}

int cmd_run(int argc, char **argv)
{
	struct cli_opts o;
	struct job_spec js;
	struct metrics m;
	struct err e;
	struct sink sink;
	struct bar bar = {0, 0};
	struct progress_hooks hooks = {bar_report, is_cancelled, &bar};
	char tmp[4096], dir[4096];
	const char *format, *slash;
	enum out_format fmt;
	int fd = -1, rc, to_stdout;
	struct sigaction sa;

	if (parse_opts("run", argc, argv, &o))
		return 2;
	if (!o.output)
		return usage_error("run", "%s", "missing -o OUT (use -o - for standard output)");
	to_stdout = !strcmp(o.output, "-");
	err_clear(&e);
	metrics_init(&m);
	format = o.format;
	if (!format && !to_stdout) {
		if (out_format_from_path(o.output, &fmt, &e))
			return fail(&e);
		format = out_format_name(fmt);
	}
	rc = job_spec_init(&js, o.engine, format, o.printer, &e);
	if (!rc)
		rc = apply_params(&js, &o, &e);
	if (!rc)
		rc = job_spec_validate(&js, &e);
	if (rc) {
		job_spec_fini(&js);
		return fail(&e);
	}
	js.input_path = o.input;
	js.threads = o.threads;
	/* Writers' temporary files go beside the output, on the same disk. */
	slash = strrchr(o.output, '/');
	if (!slash)
		snprintf(dir, sizeof dir, ".");
	else if (slash == o.output)
		snprintf(dir, sizeof dir, "/");
	else
		snprintf(dir, sizeof dir, "%.*s", (int)(slash - o.output), o.output);
	js.scratch_dir = to_stdout ? NULL : dir;

	if (to_stdout) {
		fd = STDOUT_FILENO;
	} else {
		snprintf(tmp, sizeof tmp, "%s.part", o.output);
		fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
		if (fd < 0) {
			ERR_SET(&e, ERR_IO, "cannot create %s: %s", tmp, strerror(errno));
			job_spec_fini(&js);
			return fail(&e);
		}
	}
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	bar.tty = !o.quiet && isatty(STDERR_FILENO);
	sink_init_fd(&sink, fd);
	rc = engine_run(&js, &sink, &hooks, &m, &e);
	if (bar.tty)
		fputc('\n', stderr);
	if (!to_stdout) {
		if (!rc && fsync(fd) != 0)
			rc = ERR_SET(&e, ERR_IO, "cannot flush %s: %s", tmp, strerror(errno));
		if (close(fd) != 0 && !rc)
			rc = ERR_SET(&e, ERR_IO, "cannot close %s: %s", tmp, strerror(errno));
		if (!rc && rename(tmp, o.output) != 0)
			rc = ERR_SET(&e, ERR_IO, "cannot rename %s to %s: %s", tmp, o.output,
				     strerror(errno));
		if (rc)
			unlink(tmp);
	}
	if (!rc && o.metrics_file) {
		json_t *j = api_metrics_json(&m);
		rc = j ? write_json_file(o.metrics_file, j, &e)
		       : ERR_SET(&e, ERR_NOMEM, "out of memory writing metrics");
		json_decref(j);
	}
	if (!rc && !o.quiet)
		cmd_print_warnings(&m); /* --quiet: in the metrics only */
	if (!rc && !o.quiet && !to_stdout) {
		const struct metric *mv = metrics_get(&m, "material_volume_mm3");
		const struct metric *el = metrics_get(&m, "elapsed_s");
		const struct metric *ly = metrics_get(&m, "layers");
		fprintf(stderr, "infilld: wrote %s (%lld layers, %.1f mm3 material) in %.2f s\n",
			o.output, ly ? ly->ival : 0LL, mv ? mv->num : 0.0, el ? el->num : 0.0);
	}
	metrics_fini(&m);
	job_spec_fini(&js);
	return rc ? fail(&e) : 0;
}

int cmd_analyze(int argc, char **argv)
{
	struct cli_opts o;
	struct job_spec js;
	struct metrics m;
	struct err e;
	json_t *j;
	int rc;

	if (parse_opts("analyze", argc, argv, &o))
		return 2;
	if (o.output || o.metrics_file || o.engine || o.format || o.loads_file)
		return usage_error("analyze", "%s", "takes only MESH, --printer, --set and --params");
	err_clear(&e);
	metrics_init(&m);
	rc = job_spec_init(&js, NULL, NULL, o.printer, &e);
	if (!rc)
		rc = apply_params(&js, &o, &e);
	if (!rc) {
		js.input_path = o.input;
		rc = engine_analyze(&js, &m, &e);
	}
	if (!rc)
		cmd_print_warnings(&m);
	if (!rc) {
		j = api_metrics_json(&m);
		if (!j)
			rc = ERR_SET(&e, ERR_NOMEM, "out of memory");
		else
			rc = write_json_file("-", j, &e);
		json_decref(j);
	}
	metrics_fini(&m);
	job_spec_fini(&js);
	return rc ? fail(&e) : 0;
}

int cmd_engines(int argc, char **argv)
{
	json_t *j;
	struct err e;
	int rc;

	(void)argv;
	if (argc > 1)
		return usage_error("engines", "%s", "takes no arguments");
	err_clear(&e);
	j = api_engines_json();
	if (!j) {
		ERR_SET(&e, ERR_NOMEM, "out of memory");
		return fail(&e);
	}
	rc = write_json_file("-", j, &e);
	json_decref(j);
	return rc ? fail(&e) : 0;
}
