/* json.c - engine records <-> JSON (see api_json.h). */
#include "api/api_json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/mem.h"

/* The object at the dotted prefix of key, created as needed; *leaf gets
 * the last component.  NULL if a non-object already sits on the path. */
static json_t *parent_for(json_t *root, const char *key, char *buf, size_t len,
			  const char **leaf)
{
	json_t *cur = root;
	char *p, *dot;

	snprintf(buf, len, "%s", key);
	p = buf;
	while ((dot = strchr(p, '.')) != NULL) {
		json_t *next;
		*dot = '\0';
		next = json_object_get(cur, p);
		if (!next) {
			next = json_object();
			if (!next || json_object_set_new(cur, p, next))
				return NULL;
		} else if (!json_is_object(next)) {
			return NULL;
		}
		cur = next;
		p = dot + 1;
	}
	*leaf = p;
	return cur;
}

/* A METRIC_STRS list ('\n'-joined, ival entries) as a JSON array. */
static json_t *strs_json(const struct metric *x)
{
	json_t *a = json_array();
	const char *p = x->str ? x->str : "";

	for (long long i = 0; a && i < x->ival; i++) {
		size_t n = strcspn(p, "\n");
		if (json_array_append_new(a, json_stringn(p, n))) {
			json_decref(a);
			return NULL;
		}
		p += n + (p[n] == '\n');
	}
	return a;
}

/* An object whose keys are exactly "0", "1", ... "n-1" (n >= 1, in
 * insertion order) as an array, recursively: dotted metric keys with a
 * decimal index segment ("hybrid.components.0.class") make JSON lists of
 * objects.  Returns v itself when it is not such an object (a new
 * reference either way; NULL on ERR_NOMEM). */
static json_t *index_arrays(json_t *v)
{
	const char *k;
	json_t *x, *a;
	void *tmp;
	size_t i = 0;
	int indexed = 1;
	char want[24];

	if (!json_is_object(v))
		return json_incref(v);
	json_object_foreach_safe(v, tmp, k, x) {
		json_t *y = index_arrays(x);
		if (!y || json_object_set_new(v, k, y))
			return NULL;
		snprintf(want, sizeof want, "%zu", i++);
		indexed &= strcmp(k, want) == 0;
	}
	if (!indexed || i == 0)
		return json_incref(v);
	if (!(a = json_array()))
		return NULL;
	for (size_t j = 0; j < i; j++) {
		snprintf(want, sizeof want, "%zu", j);
		if (json_array_append(a, json_object_get(v, want))) {
			json_decref(a);
			return NULL;
		}
	}
	return a;
}

json_t *api_metrics_json(const struct metrics *m)
{
	json_t *root = json_object();
	char buf[160];

	if (!root)
		return NULL;
	for (size_t i = 0; i < m->n; i++) {
		const struct metric *x = &m->v[i];
		const char *leaf;
		json_t *obj = parent_for(root, x->key, buf, sizeof buf, &leaf), *v = NULL;

		if (!obj)
			continue; /* key collides with a value: keep the first */
		switch (x->type) {
		case METRIC_NUM: v = isnan(x->num) ? json_null() : json_real(x->num); break;
		case METRIC_INT: v = json_integer(x->ival); break;
		case METRIC_BOOL: v = json_boolean(x->ival); break;
		case METRIC_STR: v = json_string(x->str ? x->str : ""); break;
		case METRIC_STRS: v = strs_json(x); break;
		}
		if (!v || json_object_set_new(obj, leaf, v)) {
			json_decref(root);
			return NULL;
		}
	}
	{
		json_t *r = index_arrays(root);
		json_decref(root);
		return r;
	}
}

static json_t *param_value_json(const struct param_desc *d, const void *base)
{
	const char *p = (const char *)base + d->offset;

	switch (d->type) {
	case PARAM_BOOL: return json_boolean(*(const int *)p);
	case PARAM_INT: return json_integer(*(const int *)p);
	case PARAM_NUM: return json_real(*(const double *)p);
	case PARAM_ENUM: {
		int k = *(const int *)p;
		return json_string(d->choices && k >= 0 ? d->choices[k] : "");
	}
	case PARAM_STR: return json_string(p);
	case PARAM_VEC3: {
		const double *v = (const double *)p;
		return json_pack("[fff]", v[0], v[1], v[2]);
	}
	}
	return json_null();
}

json_t *api_params_json(const struct param_table *t, const void *base)
{
	json_t *arr = json_array();

	for (size_t i = 0; arr && i < t->n; i++) {
		const struct param_desc *d = &t->v[i];
		json_t *o = json_object();
		if (!o)
			break;
		json_object_set_new(o, "name", json_string(d->name));
		json_object_set_new(o, "type", json_string(param_type_name(d->type)));
		json_object_set_new(o, "unit", json_string(d->unit ? d->unit : ""));
		json_object_set_new(o, "default", param_value_json(d, base));
		if (d->type == PARAM_INT || d->type == PARAM_NUM || d->type == PARAM_VEC3) {
			json_object_set_new(o, "min", json_real(d->min));
			json_object_set_new(o, "max", json_real(d->max));
			json_object_set_new(o, "min_exclusive",
					    json_boolean(d->flags & PARAM_F_MIN_EXCL));
			json_object_set_new(o, "max_exclusive",
					    json_boolean(d->flags & PARAM_F_MAX_EXCL));
		}
		if (d->type == PARAM_STR)
			json_object_set_new(o, "max_length", json_integer((json_int_t)d->str_cap - 1));
		if (d->type == PARAM_ENUM) {
			json_t *c = json_array();
			for (int k = 0; d->choices && d->choices[k]; k++)
				json_array_append_new(c, json_string(d->choices[k]));
			json_object_set_new(o, "choices", c);
		}
		if (d->flags & PARAM_F_AUTO)
			json_object_set_new(o, "zero_means_auto", json_true());
		if (d->flags & PARAM_F_PATH)
			json_object_set_new(o, "cli_only", json_true());
		json_object_set_new(o, "help", json_string(d->help ? d->help : ""));
		json_array_append_new(arr, o);
	}
	return arr;
}

json_t *api_engines_json(void)
{
	const struct engine_ops *const *l = engine_list();
	json_t *root = json_object(), *engines = json_array(), *printers = json_array();
	json_t *formats = json_array();
	struct common_params common;

	if (!root || !engines || !printers || !formats)
		goto fail;
	for (size_t i = 0; l[i]; i++) {
		const struct engine_ops *ops = l[i];
		void *defaults = mem_calloc(1, ops->params_size ? ops->params_size : 1);
		json_t *o = json_object();
		if (!defaults || !o) {
			mem_free(defaults);
			json_decref(o);
			goto fail;
		}
		param_defaults(&ops->params, defaults);
		json_object_set_new(o, "name", json_string(ops->name));
		json_object_set_new(o, "summary", json_string(ops->summary));
		json_object_set_new(o, "paper", ops->paper ? json_string(ops->paper) : json_null());
		json_object_set_new(o, "lattice_input",
				    json_boolean(ops->flags & ENGINE_F_LATTICE_INPUT));
		json_object_set_new(o, "mesh_output", json_boolean(ops->flags & ENGINE_F_MESH_OUTPUT));
		json_object_set_new(o, "params", api_params_json(&ops->params, defaults));
		json_array_append_new(engines, o);
		mem_free(defaults);
	}
	for (size_t i = 0; i < printer_profile_count(); i++) {
		struct printer p;
		json_t *o = json_object();
		if (!o || printer_lookup(printer_profile_name(i), &p, NULL)) {
			json_decref(o);
			goto fail;
		}
		json_object_set_new(o, "name", json_string(p.name));
		json_object_set_new(o, "kind", json_string(p.kind == PRINTER_RESIN ? "resin" : "fdm"));
		json_object_set_new(o, "settings",
				    api_params_json(printer_param_table(p.kind),
						    printer_params_base(&p)));
		json_array_append_new(printers, o);
	}
	for (int f = 0; f < OUT_FORMAT_COUNT; f++) {
		const char *dp = out_format_default_printer((enum out_format)f);
		json_array_append_new(
			formats, json_pack("{s:s, s:s, s:s, s:s, s:o}", "name",
					   out_format_name((enum out_format)f), "extension",
					   out_format_extension((enum out_format)f), "media_type",
					   out_format_mime((enum out_format)f), "kind",
					   out_format_is_raster((enum out_format)f) ? "layers-png"
					   : out_format_is_mesh((enum out_format)f) ? "mesh"
										    : "gcode",
					   "default_printer", dp ? json_string(dp) : json_null()));
	}
	param_defaults(common_param_table(), &common);
	json_object_set_new(root, "version", json_string(INFILLD_VERSION));
	json_object_set_new(root, "engines", engines);
	json_object_set_new(root, "common_params", api_params_json(common_param_table(), &common));
	json_object_set_new(root, "printers", printers);
	json_object_set_new(root, "formats", formats);
	return root;
fail:
	json_decref(root);
	json_decref(engines);
	json_decref(printers);
	json_decref(formats);
	return NULL;
}

/* Text form of a JSON value for param_set(), with the type the key
 * expects.  0 or ERR_PARAM. */
static int value_text(const struct param_desc *d, const json_t *v, char *buf, size_t len,
		      struct err *e)
{
	switch (d->type) {
	case PARAM_BOOL:
		if (!json_is_boolean(v))
			return ERR_FIELD(e, d->name, "%s must be a boolean", d->name);
		snprintf(buf, len, "%s", json_is_true(v) ? "true" : "false");
		return 0;
	case PARAM_INT:
		if (!json_is_integer(v) && !(json_is_real(v) &&
					     json_real_value(v) == floor(json_real_value(v))))
			return ERR_FIELD(e, d->name, "%s must be an integer", d->name);
		snprintf(buf, len, "%.17g", json_number_value(v));
		return 0;
	case PARAM_NUM:
		if (!json_is_number(v))
			return ERR_FIELD(e, d->name, "%s must be a number", d->name);
		snprintf(buf, len, "%.17g", json_number_value(v));
		return 0;
	case PARAM_ENUM:
	case PARAM_STR:
		if (!json_is_string(v))
			return ERR_FIELD(e, d->name, "%s must be a string", d->name);
		if (json_string_length(v) >= len || strlen(json_string_value(v)) !=
							   json_string_length(v))
			return ERR_FIELD(e, d->name, "%s is too long or contains NUL", d->name);
		snprintf(buf, len, "%s", json_string_value(v));
		return 0;
	case PARAM_VEC3:
		if (!json_is_array(v) || json_array_size(v) != 3 ||
		    !json_is_number(json_array_get(v, 0)) || !json_is_number(json_array_get(v, 1)) ||
		    !json_is_number(json_array_get(v, 2)))
			return ERR_FIELD(e, d->name, "%s must be an array of three numbers", d->name);
		snprintf(buf, len, "%.17g,%.17g,%.17g", json_number_value(json_array_get(v, 0)),
			 json_number_value(json_array_get(v, 1)),
			 json_number_value(json_array_get(v, 2)));
		return 0;
	}
	return ERR_FIELD(e, d->name, "%s has an unknown type", d->name);
}

int api_params_apply(struct job_spec *js, const json_t *params, int allow_paths,
		     struct err *e)
{
	const char *key;
	json_t *v;
	char text[512];
	int rc;

	if (!params || json_is_null(params))
		return 0;
	if (!json_is_object(params))
		return ERR_FIELD(e, "params", "params must be a JSON object");
	json_object_foreach((json_t *)params, key, v) {
		const struct param_desc *d = job_spec_param(js, key);
		if (!strcmp(key, "loads") && json_is_object(v)) {
			/* the load case: checked (errors name its JSON path) before
			 * the key is looked up, so a malformed one is reported as
			 * such for every engine */
			char *loads = NULL;
			rc = api_loads_text(v, &loads, e);
			if (!rc)
				rc = d ? job_spec_set(js, key, loads, e) : job_spec_set(js, key, "", e);
			mem_free(loads);
			if (rc)
				return rc;
			continue;
		}
		if (!d)
			return job_spec_set(js, key, "", e); /* the unknown-key message */
		if (!strcmp(key, "loads")) /* one format: the object (docs/fea_cli.md) */
			return ERR_FIELD(e, "loads", "expected a load-case object {\"material\", "
					 "\"fixed\", \"forces\"} (docs/fea_cli.md)");
		if ((d->flags & PARAM_F_PATH) && !allow_paths)
			return ERR_FIELD(e, key, "%s names a local file and is only accepted by "
					 "the command line", key);
		rc = value_text(d, v, text, sizeof text, e);
		if (rc)
			return rc;
		rc = job_spec_set(js, key, text, e);
		if (rc)
			return rc;
	}
	return 0;
}
