/* loads.c - the JSON load case (docs/fea_cli.md) -> the FEA engine's text
 * form (engine/fea/fea.h, fea_loads_parse), one converter for `infilld
 * fea --loads`, `infilld run --loads` and the jobs API's params.loads.
 * Every rule is checked here, so an error names its JSON path
 * ("loads.forces[1].force_n"); the engine parser then sees only text it
 * accepts.  Whether boxes hold material is known only once the part is
 * voxelised (fea_solver_new).
 */
#include "api/api_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/sink.h"

/* At most this many fixed and force entries each: a load case is a few
 * statements, and the text must fit a string parameter. */
#define LOADS_MAX_ENTRIES 64

/* The path of a value: "loads.fixed[2].axes". */
struct jpath {
	char s[ERR_FIELD_MAX];
};

static const char *jp(struct jpath *p, const char *base, const char *key, long idx)
{
	if (idx >= 0 && key)
		snprintf(p->s, sizeof p->s, "%s.%s[%ld]", base, key, idx);
	else if (idx >= 0)
		snprintf(p->s, sizeof p->s, "%s[%ld]", base, idx);
	else
		snprintf(p->s, sizeof p->s, "%s.%s", base, key);
	return p->s;
}

/* The shortest of %.15g, %.16g, %.17g that reads back as v, so the text
 * says 0.36 and not 0.35999999999999999 yet loses nothing. */
static const char *num(double v, char buf[32])
{
	for (int prec = 15; prec <= 17; prec++) {
		snprintf(buf, 32, "%.*g", prec, v);
		if (strtod(buf, NULL) == v)
			break;
	}
	return buf;
}

/* Every key of object o is one of allowed (NULL-terminated). */
static int only_keys(const json_t *o, const char *path, const char *const *allowed,
		     const char *list, struct err *e)
{
	const char *key;
	json_t *v;
	struct jpath p;

	json_object_foreach((json_t *)o, key, v) {
		int ok = 0;
		for (int i = 0; allowed[i]; i++)
			ok |= !strcmp(key, allowed[i]);
		if (!ok)
			return ERR_FIELD(e, jp(&p, path, key, -1), "unknown key '%s' (allowed: %s)",
					 key, list);
	}
	return 0;
}

/* n finite numbers from array v into out. */
static int numbers(const json_t *v, size_t n, const char *path, double *out, struct err *e)
{
	if (!json_is_array(v) || json_array_size(v) != n)
		return ERR_FIELD(e, path, "expected %zu numbers", n);
	for (size_t i = 0; i < n; i++) {
		const json_t *x = json_array_get(v, i);
		if (!json_is_number(x))
			return ERR_FIELD(e, path, "expected %zu numbers (item %zu is not a number)", n,
					 i);
		out[i] = json_number_value(x);
		if (!isfinite(out[i]) || fabs(out[i]) > 1e12)
			return ERR_FIELD(e, path, "item %zu is not a finite number below 1e12", i);
	}
	return 0;
}

/* "box=x0,y0,z0,x1,y1,z1" or a preset name for entry o into s. */
static int where(const json_t *o, const char *path, struct buf *s, struct err *e)
{
	const json_t *box = json_object_get(o, "box_mm"), *pre = json_object_get(o, "preset");
	struct jpath p;
	double b[6];
	int rc;

	if (box && pre)
		return ERR_FIELD(e, path, "give box_mm or preset, not both");
	if (!box && !pre)
		return ERR_FIELD(e, path, "needs box_mm [x0, y0, z0, x1, y1, z1] or a preset");
	if (pre) {
		const char *name = json_string_value(pre);
		if (!name || (strcmp(name, "plate") && strcmp(name, "top")))
			return ERR_FIELD(e, jp(&p, path, "preset", -1),
					 "expected \"plate\" or \"top\"");
		return buf_append(s, name, strlen(name)) ? ERR_SET(e, ERR_NOMEM, "out of memory")
							  : 0;
	}
	jp(&p, path, "box_mm", -1);
	if ((rc = numbers(box, 6, p.s, b, e)) != 0)
		return rc;
	for (int a = 0; a < 3; a++)
		if (b[a] > b[a + 3])
			return ERR_FIELD(e, p.s, "min %c %g is above max %c %g", "xyz"[a], b[a],
					 "xyz"[a], b[a + 3]);
	{
		char t[220], n[6][32];
		int len = snprintf(t, sizeof t, "box=%s,%s,%s,%s,%s,%s", num(b[0], n[0]),
				   num(b[1], n[1]), num(b[2], n[2]), num(b[3], n[3]),
				   num(b[4], n[4]), num(b[5], n[5]));
		if (buf_append(s, t, (size_t)len))
			return ERR_SET(e, ERR_NOMEM, "out of memory");
	}
	return 0;
}

static int put(struct buf *s, struct err *e, const char *t)
{
	return buf_append(s, t, strlen(t)) ? ERR_SET(e, ERR_NOMEM, "out of memory") : 0;
}

static int material(const json_t *m, const char *path, struct buf *s, struct err *e)
{
	static const char *const keys[] = {"E_mpa", "nu", NULL};
	struct jpath p;
	const json_t *E = json_object_get(m, "E_mpa"), *nu = json_object_get(m, "nu");
	char t[96], a[32], b[32];
	int rc;

	if (!json_is_object(m))
		return ERR_FIELD(e, path, "expected an object {\"E_mpa\": ..., \"nu\": ...}");
	if ((rc = only_keys(m, path, keys, "E_mpa, nu", e)) != 0)
		return rc;
	if (!E || !json_is_number(E) || !(json_number_value(E) > 0) ||
	    !(json_number_value(E) <= 1e7))
		return ERR_FIELD(e, jp(&p, path, "E_mpa", -1),
				 "expected Young's modulus in MPa, 0 < E_mpa <= 1e7");
	if (!nu || !json_is_number(nu) || !(json_number_value(nu) > -1) ||
	    !(json_number_value(nu) < 0.5))
		return ERR_FIELD(e, jp(&p, path, "nu", -1),
				 "expected Poisson's ratio, -1 < nu < 0.5");
	snprintf(t, sizeof t, "material E_mpa=%s nu=%s; ", num(json_number_value(E), a),
		 num(json_number_value(nu), b));
	return put(s, e, t);
}

/* "axes" of a fixed entry: letters from x, y, z, each at most once. */
static int axes(const json_t *o, const char *path, char out[4], struct err *e)
{
	const json_t *a = json_object_get(o, "axes");
	const char *t;
	struct jpath p;
	size_t n = 0;

	if (!a) {
		memcpy(out, "xyz", 4);
		return 0;
	}
	t = json_string_value(a);
	jp(&p, path, "axes", -1);
	if (!t || !t[0] || strlen(t) > 3)
		return ERR_FIELD(e, p.s, "expected a string of x, y, z (e.g. \"xyz\", \"z\")");
	for (const char *c = t; *c; c++) {
		if (!strchr("xyz", *c) || memchr(out, *c, n))
			return ERR_FIELD(e, p.s, "expected each of x, y, z at most once, not \"%s\"",
					 t);
		out[n++] = *c;
	}
	out[n] = '\0';
	return 0;
}

static int fixed_entry(const json_t *f, const char *path, struct buf *s, struct err *e)
{
	static const char *const keys[] = {"box_mm", "preset", "axes", NULL};
	char ax[4];
	int rc;

	if (json_is_string(f)) {
		const char *name = json_string_value(f);
		if (strcmp(name, "plate") && strcmp(name, "top"))
			return ERR_FIELD(e, path, "expected the preset \"plate\" or \"top\", or an "
					 "object with box_mm");
		rc = put(s, e, "fixed ");
		if (!rc)
			rc = put(s, e, name);
		return rc ? rc : put(s, e, " axes=xyz; ");
	}
	if (!json_is_object(f))
		return ERR_FIELD(e, path, "expected \"plate\", \"top\" or an object with box_mm");
	if ((rc = only_keys(f, path, keys, "box_mm, preset, axes", e)) != 0)
		return rc;
	if ((rc = axes(f, path, ax, e)) != 0)
		return rc;
	if ((rc = put(s, e, "fixed ")) != 0 || (rc = where(f, path, s, e)) != 0 ||
	    (rc = put(s, e, " axes=")) != 0 || (rc = put(s, e, ax)) != 0)
		return rc;
	return put(s, e, "; ");
}

static int force_entry(const json_t *f, const char *path, struct buf *s, struct err *e)
{
	static const char *const keys[] = {"box_mm", "preset", "force_n", NULL};
	struct jpath p;
	double n[3];
	char t[120], a[32], b[32], c[32];
	int rc;

	if (!json_is_object(f))
		return ERR_FIELD(e, path, "expected an object {\"box_mm\" or \"preset\", "
				 "\"force_n\": [fx, fy, fz]}");
	if ((rc = only_keys(f, path, keys, "box_mm, preset, force_n", e)) != 0)
		return rc;
	jp(&p, path, "force_n", -1);
	if (!json_object_get(f, "force_n"))
		return ERR_FIELD(e, p.s, "required: the total force [fx, fy, fz] in N");
	if ((rc = numbers(json_object_get(f, "force_n"), 3, p.s, n, e)) != 0)
		return rc;
	if (n[0] == 0 && n[1] == 0 && n[2] == 0)
		return ERR_FIELD(e, p.s, "is zero: a force entry must push");
	if ((rc = put(s, e, "force ")) != 0 || (rc = where(f, path, s, e)) != 0)
		return rc;
	snprintf(t, sizeof t, " n=%s,%s,%s; ", num(n[0], a), num(n[1], b), num(n[2], c));
	return put(s, e, t);
}

/* The array under key of loads, each entry through fn; a missing key adds
 * the default statement dflt. */
static int entries(const json_t *loads, const char *key, const char *dflt,
		   int (*fn)(const json_t *, const char *, struct buf *, struct err *),
		   struct buf *s, struct err *e)
{
	const json_t *a = json_object_get(loads, key);
	struct jpath p;
	int rc;

	if (!a)
		return put(s, e, dflt);
	if (!json_is_array(a))
		return ERR_FIELD(e, jp(&p, "loads", key, -1), "expected an array");
	if (json_array_size(a) > LOADS_MAX_ENTRIES)
		return ERR_FIELD(e, jp(&p, "loads", key, -1), "has %zu entries (at most %d)",
				 json_array_size(a), LOADS_MAX_ENTRIES);
	for (size_t i = 0; i < json_array_size(a); i++)
		if ((rc = fn(json_array_get(a, i), jp(&p, "loads", key, (long)i), s, e)) != 0)
			return rc;
	return 0;
}

int api_loads_text(const json_t *loads, char **out, struct err *e)
{
	static const char *const keys[] = {"material", "fixed", "forces", NULL};
	struct buf s;
	int rc;

	if (!json_is_object(loads))
		return ERR_FIELD(e, "loads", "expected a load-case object {\"material\", \"fixed\", "
				 "\"forces\"} (docs/fea_cli.md)");
	if ((rc = only_keys(loads, "loads", keys, "material, fixed, forces", e)) != 0)
		return rc;
	buf_init(&s);
	if (json_object_size(loads) == 0) {
		rc = put(&s, e, ""); /* the engine's default case */
		goto out;
	}
	if (json_object_get(loads, "material") &&
	    (rc = material(json_object_get(loads, "material"), "loads.material", &s, e)) != 0)
		goto out;
	if ((rc = entries(loads, "fixed", "fixed plate axes=xyz; ", fixed_entry, &s, e)) != 0)
		goto out;
	if ((rc = entries(loads, "forces", "force top n=0,0,-1000; ", force_entry, &s, e)) != 0)
		goto out;
out:
	if (!rc) {
		/* drop the last "; " separator; NUL-terminate */
		while (s.len && (s.data[s.len - 1] == ' ' || s.data[s.len - 1] == ';'))
			s.len--;
		if (buf_append(&s, "", 1))
			rc = ERR_SET(e, ERR_NOMEM, "out of memory");
	}
	if (rc) {
		buf_fini(&s);
		return rc;
	}
	*out = (char *)s.data; /* the buffer's storage, handed to the caller */
	return 0;
}
