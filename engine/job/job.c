/* job.c - job specifications: defaults, KEY=VALUE routing, validation.
 *
 * A key is looked up in the common table, then the engine's, then the
 * printer kind's override table (docs/parameters.md lists them all).
 */
#include "engine/engine.h"
#include "engine/core/mem.h"

#include <stddef.h>
#include <stdio.h>
#include <string.h>

static const char *const units_names[] = {"mm", "cm", "m", "in", NULL};
static const char *const up_names[] = {"z", "-z", "y", "-y", "x", "-x", NULL};

static const struct param_desc common_desc[] = {
	{.name = "units", .type = PARAM_ENUM, .offset = offsetof(struct common_params, units),
	 .def = MESH_UNITS_MM, .choices = units_names, .unit = "",
	 .help = "Length unit of the input file's coordinates."},
	{.name = "scale", .type = PARAM_NUM, .offset = offsetof(struct common_params, scale),
	 .min = 0, .max = 1e6, .def = 1, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Uniform scale factor applied after the unit conversion."},
	{.name = "height_mm", .type = PARAM_NUM, .offset = offsetof(struct common_params, height_mm),
	 .min = 0, .max = 10000, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Scale uniformly so the printed height is this; 0 keeps the size."},
	{.name = "up", .type = PARAM_ENUM, .offset = offsetof(struct common_params, up),
	 .def = MESH_UP_Z, .choices = up_names, .unit = "",
	 .help = "Axis of the input file that points up in the printer."},
	{.name = "layer_mm", .type = PARAM_NUM, .offset = offsetof(struct common_params, layer_mm),
	 .min = 0, .max = 2, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Layer height; 0 uses the printer profile's (0.05 resin, 0.2 FDM)."},
	{.name = "shell_mm", .type = PARAM_NUM, .offset = offsetof(struct common_params, shell_mm),
	 .min = 0, .max = 100, .def = 0, .unit = "mm",
	 .help = "Solid skin thickness kept by engines that hollow or fill the part; 0 = none."},
	{.name = "alpha_deg", .type = PARAM_NUM, .offset = offsetof(struct common_params, alpha_deg),
	 .min = 0, .max = 90, .def = 45, .flags = PARAM_F_MIN_EXCL | PARAM_F_MAX_EXCL,
	 .unit = "deg",
	 .help = "Largest overhang that prints without support, measured from the vertical."},
};

static const struct param_table common_table = {
	"common", common_desc, sizeof common_desc / sizeof common_desc[0]};

const struct param_table *common_param_table(void)
{
	return &common_table;
}

/* Smallest layer height we accept when one is given (mm). */
#define JOB_MIN_LAYER_MM 0.005

int job_spec_init(struct job_spec *js, const char *engine, const char *format,
		  const char *printer, struct err *e)
{
	const char *pname;
	int rc;

	memset(js, 0, sizeof *js);
	js->input_format = MESH_FMT_AUTO;
	param_defaults(&common_table, &js->common);
	js->engine = engine_find(engine ? engine : "solid");
	if (!js->engine) {
		char known[256] = "";
		size_t n = 0;
		const struct engine_ops *const *l = engine_list();
		for (size_t i = 0; l[i] && n < sizeof known; i++)
			n += (size_t)snprintf(known + n, sizeof known - n, "%s%s", i ? ", " : "",
					      l[i]->name);
		return ERR_FIELD(e, "engine", "unknown engine '%s' (known: %s)", engine, known);
	}
	js->engine_params = mem_calloc(1, js->engine->params_size ? js->engine->params_size : 1);
	if (!js->engine_params)
		return ERR_SET(e, ERR_NOMEM, "out of memory for engine parameters");
	param_defaults(&js->engine->params, js->engine_params);
	js->format = OUT_SL1;
	if (format) {
		rc = out_format_parse(format, &js->format, e);
		if (rc)
			return rc;
	}
	pname = printer ? printer : out_format_default_printer(js->format);
	if (!pname)
		pname = "sl1";
	rc = printer_lookup(pname, &js->printer, e);
	if (rc) {
		if (e)
			snprintf(e->field, sizeof e->field, "printer");
		return rc == ERR_NOTFOUND ? ERR_PARAM : rc;
	}
	return 0;
}

void job_spec_fini(struct job_spec *js)
{
	mem_free(js->engine_params);
	js->engine_params = NULL;
}

int job_spec_set(struct job_spec *js, const char *key, const char *value, struct err *e)
{
	int rc;

	rc = param_set(&common_table, &js->common, key, value, e);
	if (rc != ERR_NOTFOUND)
		return rc;
	rc = param_set(&js->engine->params, js->engine_params, key, value, e);
	if (rc != ERR_NOTFOUND)
		return rc;
	rc = param_set(printer_param_table(js->printer.kind), printer_params_base(&js->printer),
		       key, value, e);
	if (rc != ERR_NOTFOUND)
		return rc;
	return ERR_FIELD(e, key,
			 "unknown parameter '%s' (not a common key, not a parameter of engine "
			 "'%s', not a setting of %s printer '%s'; see `infilld engines`)",
			 key, js->engine->name,
			 js->printer.kind == PRINTER_RESIN ? "resin" : "FDM", js->printer.name);
}

const struct param_desc *job_spec_param(const struct job_spec *js, const char *key)
{
	const struct param_desc *d = param_find(&common_table, key);

	if (!d)
		d = param_find(&js->engine->params, key);
	if (!d)
		d = param_find(printer_param_table(js->printer.kind), key);
	return d;
}

double job_spec_layer_mm(const struct job_spec *js)
{
	return js->common.layer_mm > 0 ? js->common.layer_mm : printer_layer_mm(&js->printer);
}

int job_spec_validate(const struct job_spec *js, struct err *e)
{
	const struct common_params *c = &js->common;
	int raster = out_format_is_raster(js->format);
	int rc;

	rc = param_check(&common_table, c, e);
	if (rc)
		return rc;
	rc = param_check(&js->engine->params, js->engine_params, e);
	if (rc)
		return rc;
	rc = printer_check(&js->printer, e);
	if (rc)
		return rc;
	if (c->layer_mm != 0 && c->layer_mm < JOB_MIN_LAYER_MM)
		return ERR_FIELD(e, "layer_mm", "layer_mm = %g is below the minimum of %g mm",
				 c->layer_mm, JOB_MIN_LAYER_MM);
	if (out_format_is_mesh(js->format)) {
		if (!(js->engine->flags & ENGINE_F_MESH_OUTPUT))
			return ERR_FIELD(e, "format",
					 "engine '%s' cannot write a mesh (format %s); use a "
					 "layer format (sl1, sl1s, zip, gcode)",
					 js->engine->name, out_format_name(js->format));
	} else if (raster != (js->printer.kind == PRINTER_RESIN)) {
		return ERR_FIELD(e, "printer",
				 "format %s needs a %s printer, but '%s' is a %s printer",
				 out_format_name(js->format), raster ? "resin" : "FDM",
				 js->printer.name,
				 js->printer.kind == PRINTER_RESIN ? "resin" : "FDM");
	}
	/* a G-code job's layer height is checked against the nozzle here,
	 * before the engine's work (minutes for some), not when the writer opens */
	rc = out_check_layers(js->format, &js->printer, job_spec_layer_mm(js), e);
	if (rc)
		return rc;
	if ((js->format == OUT_SL1 || js->format == OUT_SL1S) &&
	    strcmp(js->printer.resin.model, js->format == OUT_SL1 ? "SL1" : "SL1S") != 0)
		return ERR_FIELD(e, "printer", "format %s needs printer model %s, '%s' is a %s",
				 out_format_name(js->format),
				 js->format == OUT_SL1 ? "SL1" : "SL1S", js->printer.name,
				 js->printer.resin.model);
	if (js->engine->validate) {
		rc = js->engine->validate(js->engine_params, c, &js->printer, e);
		if (rc)
			return rc;
	}
	return 0;
}
