/* param.c - parameter parsing and range checking (see param.h). */
#include "engine/core/param.h"
#include "engine/core/err.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define FIELD(base, d, type) ((type *)((char *)(base) + (d)->offset))
#define CFIELD(base, d, type) ((const type *)((const char *)(base) + (d)->offset))

const char *param_type_name(enum param_type t)
{
	switch (t) {
	case PARAM_BOOL: return "bool";
	case PARAM_INT: return "int";
	case PARAM_NUM: return "number";
	case PARAM_ENUM: return "enum";
	case PARAM_STR: return "string";
	case PARAM_VEC3: return "vec3";
	}
	return "?";
}

const struct param_desc *param_find(const struct param_table *t, const char *key)
{
	for (size_t i = 0; i < t->n; i++)
		if (strcmp(t->v[i].name, key) == 0)
			return &t->v[i];
	return NULL;
}

/* Describe the accepted range, e.g. "(0, 10]", for error messages. */
static void range_text(const struct param_desc *d, char *buf, size_t len)
{
	snprintf(buf, len, "%c%g, %g%c", (d->flags & PARAM_F_MIN_EXCL) ? '(' : '[', d->min,
		 d->max, (d->flags & PARAM_F_MAX_EXCL) ? ')' : ']');
}

static int in_range(const struct param_desc *d, double v)
{
	if (!isfinite(v))
		return 0;
	if ((d->flags & PARAM_F_MIN_EXCL) ? !(v > d->min) : !(v >= d->min))
		return 0;
	if ((d->flags & PARAM_F_MAX_EXCL) ? !(v < d->max) : !(v <= d->max))
		return 0;
	return 1;
}

static int range_error(const struct param_desc *d, const char *value, struct err *e)
{
	char r[96];

	range_text(d, r, sizeof r);
	return ERR_FIELD(e, d->name, "%s = '%s' is outside the accepted range %s%s%s", d->name,
			 value, r, d->unit && d->unit[0] ? " " : "", d->unit ? d->unit : "");
}

/* Parse a whole-string finite double; 0 on success. */
static int parse_num(const char *s, double *out)
{
	char *end;
	double v;

	while (*s == ' ' || *s == '\t')
		s++;
	if (!*s)
		return -1;
	errno = 0;
	v = strtod(s, &end);
	while (*end == ' ' || *end == '\t')
		end++;
	if (*end || errno == ERANGE || !isfinite(v))
		return -1;
	*out = v;
	return 0;
}

static int set_one(const struct param_desc *d, void *base, const char *value, struct err *e)
{
	double v, xyz[3];

	switch (d->type) {
	case PARAM_BOOL:
		if (!strcasecmp(value, "true") || !strcmp(value, "1") || !strcasecmp(value, "yes") ||
		    !strcasecmp(value, "on")) {
			*FIELD(base, d, int) = 1;
			return 0;
		}
		if (!strcasecmp(value, "false") || !strcmp(value, "0") || !strcasecmp(value, "no") ||
		    !strcasecmp(value, "off")) {
			*FIELD(base, d, int) = 0;
			return 0;
		}
		return ERR_FIELD(e, d->name, "%s = '%s' is not a boolean (true or false)", d->name,
				 value);
	case PARAM_INT:
		if (parse_num(value, &v) || v != floor(v))
			return ERR_FIELD(e, d->name, "%s = '%s' is not an integer", d->name, value);
		if (!in_range(d, v))
			return range_error(d, value, e);
		*FIELD(base, d, int) = (int)v;
		return 0;
	case PARAM_NUM:
		if (parse_num(value, &v))
			return ERR_FIELD(e, d->name, "%s = '%s' is not a finite number", d->name,
					 value);
		if (!in_range(d, v))
			return range_error(d, value, e);
		*FIELD(base, d, double) = v;
		return 0;
	case PARAM_ENUM:
		for (int i = 0; d->choices && d->choices[i]; i++) {
			if (strcmp(d->choices[i], value) == 0) {
				*FIELD(base, d, int) = i;
				return 0;
			}
		}
		{
			char list[256] = "";
			size_t n = 0;
			for (int i = 0; d->choices && d->choices[i] && n < sizeof list; i++)
				n += (size_t)snprintf(list + n, sizeof list - n, "%s%s",
						      i ? ", " : "", d->choices[i]);
			return ERR_FIELD(e, d->name, "%s = '%s' is not one of: %s", d->name, value,
					 list);
		}
	case PARAM_STR: {
		size_t len = strlen(value);
		if (len + 1 > d->str_cap)
			return ERR_FIELD(e, d->name, "%s is longer than %zu characters", d->name,
					 d->str_cap - 1);
		if ((double)len < d->min || (double)len > d->max)
			return ERR_FIELD(e, d->name, "%s must have %g to %g characters", d->name,
					 d->min, d->max);
		for (size_t i = 0; i < len; i++)
			if ((unsigned char)value[i] < 0x20)
				return ERR_FIELD(e, d->name, "%s contains a control character",
						 d->name);
		memcpy(FIELD(base, d, char), value, len + 1);
		return 0;
	}
	case PARAM_VEC3: {
		char tmp[256], *save = NULL, *tok;
		int k = 0;
		if (strlen(value) >= sizeof tmp)
			return ERR_FIELD(e, d->name, "%s is too long", d->name);
		strcpy(tmp, value);
		for (tok = strtok_r(tmp, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
			if (k == 3 || parse_num(tok, &xyz[k]))
				return ERR_FIELD(e, d->name,
						 "%s = '%s' is not three numbers 'x,y,z'", d->name,
						 value);
			if (!in_range(d, xyz[k]))
				return range_error(d, value, e);
			k++;
		}
		if (k != 3)
			return ERR_FIELD(e, d->name, "%s = '%s' is not three numbers 'x,y,z'",
					 d->name, value);
		memcpy(FIELD(base, d, double), xyz, sizeof xyz);
		return 0;
	}
	}
	return ERR_SET(e, ERR_INTERNAL, "parameter %s has an unknown type", d->name);
}

void param_defaults(const struct param_table *t, void *base)
{
	for (size_t i = 0; i < t->n; i++) {
		const struct param_desc *d = &t->v[i];
		int rc;

		switch (d->type) {
		case PARAM_BOOL:
		case PARAM_INT:
		case PARAM_ENUM:
			*FIELD(base, d, int) = (int)d->def;
			break;
		case PARAM_NUM:
			*FIELD(base, d, double) = d->def;
			break;
		case PARAM_STR:
			FIELD(base, d, char)[0] = '\0';
			if (d->def_str)
				snprintf(FIELD(base, d, char), d->str_cap, "%s", d->def_str);
			break;
		case PARAM_VEC3:
			memset(FIELD(base, d, double), 0, 3 * sizeof(double));
			if (d->def_str) {
				rc = set_one(d, base, d->def_str, NULL);
				(void)rc; /* defaults are checked by tests/unit/core */
			}
			break;
		}
	}
}

int param_set(const struct param_table *t, void *base, const char *key, const char *value,
	      struct err *e)
{
	const struct param_desc *d = param_find(t, key);

	if (!d)
		return ERR_NOTFOUND;
	return set_one(d, base, value, e);
}

int param_check(const struct param_table *t, const void *base, struct err *e)
{
	char text[128];

	for (size_t i = 0; i < t->n; i++) {
		const struct param_desc *d = &t->v[i];
		double v;

		switch (d->type) {
		case PARAM_INT:
			v = *CFIELD(base, d, int);
			break;
		case PARAM_NUM:
			v = *CFIELD(base, d, double);
			break;
		case PARAM_ENUM: {
			int k = *CFIELD(base, d, int), n = 0;
			while (d->choices && d->choices[n])
				n++;
			if (k < 0 || k >= n)
				return ERR_FIELD(e, d->name, "%s holds an invalid choice index %d",
						 d->name, k);
			continue;
		}
		case PARAM_VEC3:
			for (int k = 0; k < 3; k++) {
				v = CFIELD(base, d, double)[k];
				if (!in_range(d, v)) {
					param_format(d, base, text, sizeof text);
					return range_error(d, text, e);
				}
			}
			continue;
		default:
			continue;
		}
		if (!in_range(d, v)) {
			param_format(d, base, text, sizeof text);
			return range_error(d, text, e);
		}
	}
	return 0;
}

void param_format(const struct param_desc *d, const void *base, char *buf, size_t len)
{
	const double *v3;

	switch (d->type) {
	case PARAM_BOOL:
		snprintf(buf, len, "%s", *CFIELD(base, d, int) ? "true" : "false");
		return;
	case PARAM_INT:
		snprintf(buf, len, "%d", *CFIELD(base, d, int));
		return;
	case PARAM_NUM:
		snprintf(buf, len, "%.17g", *CFIELD(base, d, double));
		return;
	case PARAM_ENUM: {
		int k = *CFIELD(base, d, int);
		snprintf(buf, len, "%s", (d->choices && k >= 0) ? d->choices[k] : "?");
		return;
	}
	case PARAM_STR:
		snprintf(buf, len, "%s", CFIELD(base, d, char));
		return;
	case PARAM_VEC3:
		v3 = CFIELD(base, d, double);
		snprintf(buf, len, "%.17g,%.17g,%.17g", v3[0], v3[1], v3[2]);
		return;
	}
	snprintf(buf, len, "?");
}
