/* param.h - typed parameter descriptions.
 *
 * Each engine, the common job keys and each output format describe their
 * parameters with a table of struct param_desc pointing into their own
 * parameter struct (offsetof).  One parser turns `--set KEY=VALUE`, a
 * params JSON object (converted to text by api/ or service/) and defaults
 * into struct fields, and the same tables are published by
 * `infilld engines` and GET /v1/engines.  Design: docs/parameters.md.
 */
#ifndef INFILLD_PARAM_H
#define INFILLD_PARAM_H

#include <stddef.h>

struct err;

enum param_type {
	PARAM_BOOL, /* int field: 0/1; text "true/false/1/0/yes/no/on/off" */
	PARAM_INT,  /* int field, range [min, max] */
	PARAM_NUM,  /* double field, range [min, max], finite only */
	PARAM_ENUM, /* int field holding the index into choices[] */
	PARAM_STR,  /* char[str_cap] field, NUL-terminated; min/max = length bounds */
	PARAM_VEC3  /* double[3] field, text "x,y,z"; each in [min, max] */
};

/* flags */
#define PARAM_F_MIN_EXCL 0x1u /* min is exclusive (value > min) */
#define PARAM_F_MAX_EXCL 0x2u /* max is exclusive */
#define PARAM_F_PATH 0x4u     /* a local file path: CLI only, refused by the API */
#define PARAM_F_AUTO 0x8u     /* 0 means "automatic" (the help text says how) */

struct param_desc {
	const char *name;           /* key, lower_snake_case with unit suffix */
	enum param_type type;
	size_t offset;              /* offsetof(struct owner, field) */
	double min, max;            /* see type */
	double def;                 /* default for BOOL/INT/NUM, index for ENUM */
	const char *def_str;        /* default text for STR/VEC3 (NULL = "") */
	const char *const *choices; /* ENUM: NULL-terminated names */
	size_t str_cap;             /* STR: sizeof the char array */
	unsigned flags;
	const char *unit;           /* "mm", "deg", "", ... for documentation */
	const char *help;           /* one sentence */
};

struct param_table {
	const char *name; /* "common", "lattice", "gcode", ... */
	const struct param_desc *v;
	size_t n;
};

/* Write every default of the table into base. */
void param_defaults(const struct param_table *t, void *base);

/* The description for key, or NULL. */
const struct param_desc *param_find(const struct param_table *t, const char *key);

/* Parse value (text) for key into base.  Returns 0; ERR_NOTFOUND if the
 * table has no such key (e left untouched, so a caller can try the next
 * table); ERR_PARAM (e->field = key) if the value is malformed or out of
 * range, with a message that states the accepted range or choices. */
int param_set(const struct param_table *t, void *base, const char *key,
	      const char *value, struct err *e);

/* Check every field of base against its range (for structs filled by
 * code rather than param_set).  0 or ERR_PARAM naming the field. */
int param_check(const struct param_table *t, const void *base, struct err *e);

/* Current value of d in base as text ("0.05", "true", "y", "1,2,3"). */
void param_format(const struct param_desc *d, const void *base, char *buf, size_t len);

/* Type name for descriptions: "bool", "int", "number", "enum", "string", "vec3". */
const char *param_type_name(enum param_type t);

#endif
