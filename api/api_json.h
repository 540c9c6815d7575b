/* api_json.h - engine records <-> JSON (jansson), shared by the CLI
 * (service/cli_run.c) and the HTTP API.  The only place that turns
 * struct metrics, parameter tables and job parameters into JSON. */
#ifndef INFILLD_API_JSON_H
#define INFILLD_API_JSON_H

#include <jansson.h>

#include "engine/engine.h"

/* Nested object from dotted keys ("lattice.gamma_raw" -> {"lattice":
 * {"gamma_raw": ...}}); NaN numbers become null.  New reference; NULL on
 * allocation failure. */
json_t *api_metrics_json(const struct metrics *m);

/* Describe one parameter table; defaults read from base (a struct filled
 * with the defaults or a printer profile).  New reference. */
json_t *api_params_json(const struct param_table *t, const void *base);

/* Everything `infilld engines` and GET /v1/engines publish: engines with
 * their parameters, the common keys, printer profiles with their
 * settings, output formats.  New reference. */
json_t *api_engines_json(void);

/* Apply a JSON object of parameters to js with strict types: numbers
 * for number/int keys, booleans for bool, strings for enum/string,
 * [x, y, z] for vec3; "loads" a load-case object (api_loads_text,
 * checked before the key is looked up, errors naming its JSON path).
 * allow_paths = 0 refuses file-path parameters (the HTTP API).  0 or
 * ERR_PARAM with e->field naming the key. */
int api_params_apply(struct job_spec *js, const json_t *params, int allow_paths,
		     struct err *e);

/* The JSON load case (docs/fea_cli.md: {"material", "fixed", "forces"})
 * as the FEA engine's text form (engine/fea/fea.h, fea_loads_parse), for
 * `infilld fea --loads`, `infilld run --loads` and params.loads of a job
 * (api_params_apply converts an object under "loads" with it).  An empty
 * object gives "" (the engine's default case); a missing "fixed" is the
 * plate fixed in xyz, a missing "forces" 1000 N down on the top.  *out:
 * NUL-terminated, caller frees with mem_free().  0, or ERR_PARAM with
 * e->field the JSON path of the offending value ("loads.forces[1].force_n")
 * and a one-line message, or ERR_NOMEM. */
int api_loads_text(const json_t *loads, char **out, struct err *e);

#endif
