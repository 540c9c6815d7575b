/* cli_fea.c - `infilld fea`: the stiffness of a part or of a written layer
 * archive under a load case, as one JSON object on stdout (docs/fea_cli.md),
 * and the JSON load-case file shared with `infilld run --loads`.  Thin:
 * arguments and printing; the work is engine_fea() (engine/job/fea_run.c)
 * and api_loads_text() (api/loads.c).  Exit 0, 1 with one line
 * "infilld: ..." on stderr, 2 on usage errors.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_json.h"
#include "engine/core/mem.h"
#include "engine/engine.h"
#include "service/commands.h"

#define FEA_MAX_SETS 64

int cmd_loads_read(const char *path, char **text, struct err *e)
{
	json_error_t je;
	json_t *j = json_load_file(path, JSON_REJECT_DUPLICATES, &je);
	int rc;

	if (!j)
		return ERR_PLACE(e, ERR_PARSE, -1, je.line > 0 ? je.line : 0, -1, "%s: %s", path,
				 je.text);
	rc = api_loads_text(j, text, e);
	json_decref(j);
	if (rc)
		err_prefix(e, "%s", path);
	return rc;
}

static int fail(const struct err *e)
{
	char line[ERR_MSG_MAX + 256];

	fprintf(stderr, "infilld: %s\n", err_format(e, line, sizeof line));
	return 1;
}

static int usage_error(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int usage_error(const char *fmt, ...)
{
	va_list ap;

	fprintf(stderr, "infilld fea: ");
	va_start(ap, fmt);
	vfprintf(stderr, fmt, ap);
	va_end(ap);
	fprintf(stderr, " (see `infilld --help`)\n");
	return 2;
}

struct fea_cli {
	const char *input, *loads, *vtk, *printer;
	const char *sets[FEA_MAX_SETS];
	int nsets, threads, quiet;
};

static int parse(int argc, char **argv, struct fea_cli *o)
{
	memset(o, 0, sizeof *o);
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		const char **slot = NULL;
		if (!strcmp(a, "--loads"))
			slot = &o->loads;
		else if (!strcmp(a, "--out-vtk"))
			slot = &o->vtk;
		else if (!strcmp(a, "--printer"))
			slot = &o->printer;
		else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) {
			o->quiet = 1;
			continue;
		} else if (!strcmp(a, "--threads")) {
			if (++i >= argc)
				return usage_error("%s needs a value", a);
			if (!(o->threads = cmd_threads_arg(argv[i], 256)))
				return usage_error("--threads wants 1..256, not '%s'", argv[i]);
			continue;
		} else if (!strcmp(a, "--set") || !strcmp(a, "-s")) {
			if (++i >= argc)
				return usage_error("%s needs KEY=VALUE", a);
			if (!strchr(argv[i], '=') || argv[i][0] == '=')
				return usage_error("--set wants KEY=VALUE, not '%s'", argv[i]);
			if (o->nsets == FEA_MAX_SETS)
				return usage_error("more than %d --set options", FEA_MAX_SETS);
			o->sets[o->nsets++] = argv[i];
			continue;
		} else if (a[0] == '-' && a[1] != '\0') {
			return usage_error("unknown option '%s'", a);
		} else if (!o->input) {
			o->input = a;
			continue;
		} else {
			return usage_error("unexpected argument '%s'", a);
		}
		if (++i >= argc)
			return usage_error("%s needs a value", a);
		*slot = argv[i];
	}
	if (!o->input)
		return usage_error("%s", "missing the INPUT (a mesh or a layer archive)");
	return 0;
}

int cmd_fea(int argc, char **argv)
{
	struct fea_cli o;
	struct job_spec js;
	struct engine_fea_params fp;
	struct metrics m;
	struct err e;
	char *loads = NULL;
	json_t *j;
	int rc;

	if (parse(argc, argv, &o))
		return 2;
	err_clear(&e);
	metrics_init(&m);
	engine_fea_defaults(&fp);
	rc = job_spec_init(&js, NULL, NULL, o.printer, &e);
	for (int i = 0; !rc && i < o.nsets; i++) {
		char key[128];
		const char *eq = strchr(o.sets[i], '=');
		size_t klen = (size_t)(eq - o.sets[i]);
		if (klen >= sizeof key) {
			rc = ERR_FIELD(&e, "", "--set '%s' has no usable key", o.sets[i]);
			break;
		}
		memcpy(key, o.sets[i], klen);
		key[klen] = '\0';
		rc = engine_fea_set(&js, &fp, key, eq + 1, &e);
	}
	if (!rc && o.loads)
		rc = cmd_loads_read(o.loads, &loads, &e);
	if (!rc) {
		js.input_path = o.input;
		js.threads = o.threads;
		rc = engine_fea(&js, &fp, loads, o.vtk, &m, &e);
	}
	if (!rc && !o.quiet)
		cmd_print_warnings(&m);
	if (!rc) {
		j = api_metrics_json(&m);
		if (!j) {
			rc = ERR_SET(&e, ERR_NOMEM, "out of memory");
		} else {
			json_dumpf(j, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(10));
			fputc('\n', stdout);
			json_decref(j);
		}
	}
	mem_free(loads);
	metrics_fini(&m);
	job_spec_fini(&js);
	return rc ? fail(&e) : 0;
}
