/* loads.c - the text form of a load case (fea_loads_parse/format) and the
 * default case.  Grammar (docs/fea.md, "Load cases"):
 *
 *   text      := statement (';' statement)*     empty statements skipped
 *   statement := 'material' ('E_mpa=' num | 'nu=' num)*
 *              | 'fixed' place ['axes=' [xyz]+]  (axes default xyz)
 *              | 'force' place 'n=' num ',' num ',' num
 *   place     := 'plate' | 'top' | 'box=' num ',' num ',' num ',' num ',' num ',' num
 *
 * Words may come in any order inside a statement; blanks are allowed
 * around '=', ',' and ';'.  A text with no fixed and no force statement
 * (empty, or material only) is the default case with its material.
 */
#include "engine/fea/fea_int.h"

#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define LOADS_MAX_STATEMENTS 256
#define WORD_MAX 128

int fea_loads_default(struct fea_loads *l, struct fea_material mat, struct err *e)
{
	struct fea_loads t = {mat, NULL, 0, NULL, 0};

	t.fixed = mem_calloc(1, sizeof *t.fixed);
	t.forces = mem_calloc(1, sizeof *t.forces);
	if (!t.fixed || !t.forces) {
		fea_loads_fini(&t);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the load case");
	}
	t.fixed[0].at = FEA_AT_PLATE;
	t.fixed[0].axes = FEA_AXIS_X | FEA_AXIS_Y | FEA_AXIS_Z;
	t.nfixed = 1;
	t.forces[0].at = FEA_AT_TOP;
	t.forces[0].force_n[2] = -1000;
	t.nforces = 1;
	*l = t;
	return 0;
}

void fea_loads_fini(struct fea_loads *l)
{
	if (!l)
		return;
	mem_free(l->fixed);
	mem_free(l->forces);
	l->fixed = NULL;
	l->forces = NULL;
	l->nfixed = l->nforces = 0;
}

/* A parser position and the statement being read (for messages). */
struct lp {
	const char *s;
	int stmt;         /* 1-based statement number */
	const char *kind; /* "material", "fixed", "force" */
	struct err *e;
};

static int lerr(struct lp *p, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 2, 3)))
#endif
	;
static int lerr(struct lp *p, const char *fmt, ...)
{
	char what[256];
	va_list ap;

	va_start(ap, fmt);
	vsnprintf(what, sizeof what, fmt, ap);
	va_end(ap);
	if (p->kind)
		return ERR_FIELD(p->e, "loads", "loads: statement %d (%s): %s", p->stmt, p->kind,
				 what);
	return ERR_FIELD(p->e, "loads", "loads: statement %d: %s", p->stmt, what);
}

static int is_blank(char c)
{
	return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

static void skip_blank(struct lp *p)
{
	while (is_blank(*p->s))
		p->s++;
}

/* Copy the identifier at p->s into w; 0, or an error for an over-long word. */
static int read_ident(struct lp *p, char w[WORD_MAX])
{
	size_t n = 0;

	while (isalnum((unsigned char)*p->s) || *p->s == '_') {
		if (n + 1 >= WORD_MAX)
			return lerr(p, "word too long ('%.20s...')", p->s - n);
		w[n++] = *p->s++;
	}
	w[n] = 0;
	return 0;
}

/* The value after '=': everything up to a blank or ';', blanks around
 * commas removed ("0, 0 ,1" -> "0,0,1").  Empty when nothing follows. */
static int read_value(struct lp *p, char v[WORD_MAX])
{
	size_t n = 0;

	skip_blank(p);
	for (;;) {
		const char *q;

		while (*p->s && *p->s != ';' && !is_blank(*p->s)) {
			if (n + 1 >= WORD_MAX)
				return lerr(p, "value too long ('%.20s...')", v);
			v[n++] = *p->s++;
			v[n] = 0;
		}
		q = p->s;
		while (is_blank(*q))
			q++;
		if (*q == ',' || (n > 0 && v[n - 1] == ',' && *q && *q != ';')) {
			p->s = q;
			continue;
		}
		break;
	}
	v[n] = 0;
	return 0;
}

/* Parse a comma-separated list of exactly `want` finite numbers. */
static int parse_nums(struct lp *p, const char *key, const char *v, double *out, int want)
{
	const char *s = v;
	int n = 0;

	for (;;) {
		char *end;
		char tok[WORD_MAX];
		size_t len = strcspn(s, ",");

		memcpy(tok, s, len);
		tok[len] = 0;
		errno = 0;
		double x = strtod(tok, &end);
		if (len == 0 || *end || !isfinite(x) || errno == ERANGE)
			return lerr(p, "bad number '%s' in %s", tok, key);
		if (n < want)
			out[n] = x;
		n++;
		s += len;
		if (!*s)
			break;
		s++; /* the comma */
	}
	if (n != want) {
		char msg[64];
		snprintf(msg, sizeof msg, "%d numbers, got %d", want, n);
		return lerr(p, "%s needs %s", key, msg);
	}
	return 0;
}

static int parse_axes(struct lp *p, const char *v, unsigned *axes)
{
	*axes = 0;
	if (!*v)
		return lerr(p, "axes '%s' not in xyz", v);
	for (const char *c = v; *c; c++) {
		unsigned bit = *c == 'x' ? FEA_AXIS_X : *c == 'y' ? FEA_AXIS_Y : *c == 'z' ? FEA_AXIS_Z : 0;
		if (!bit)
			return lerr(p, "axes '%s' not in xyz", v);
		if (*axes & bit)
			return lerr(p, "axes '%s' repeats an axis", v);
		*axes |= bit;
	}
	return 0;
}

static int check_box(struct lp *p, const double b[6])
{
	static const char ax[3] = {'x', 'y', 'z'};

	for (int a = 0; a < 3; a++)
		if (b[3 + a] < b[a]) {
			char lo[64], hi[64];
			snprintf(hi, sizeof hi, "%c1 = %g", ax[a], b[3 + a]);
			snprintf(lo, sizeof lo, "%c0 = %g", ax[a], b[a]);
			return lerr(p, "box has %s < %s", hi, lo);
		}
	return 0;
}

/* One statement (between separators).  fix/force: where a fixed or force
 * statement goes (the caller has grown the arrays). */
static int parse_statement(struct lp *p, struct fea_material *mat, int *have_mat,
			   struct fea_fix *fix, struct fea_force *force, int *kind_out)
{
	char w[WORD_MAX], v[WORD_MAX];
	int have_place = 0, have_axes = 0, have_n = 0, have_E = 0, have_nu = 0, rc;
	enum fea_at at = FEA_AT_BOX;
	double box[6] = {0}, n3[3] = {0};
	unsigned axes = FEA_AXIS_X | FEA_AXIS_Y | FEA_AXIS_Z;
	struct fea_material m = *mat;

	*kind_out = 0;
	skip_blank(p);
	if (!*p->s || *p->s == ';')
		return 0; /* empty statement */
	if ((rc = read_ident(p, w)))
		return rc;
	if (!w[0]) {
		char c[2] = {*p->s, 0};
		return lerr(p, "unexpected '%s'", c);
	}
	if (!strcmp(w, "material"))
		p->kind = "material", *kind_out = 1;
	else if (!strcmp(w, "fixed"))
		p->kind = "fixed", *kind_out = 2;
	else if (!strcmp(w, "force"))
		p->kind = "force", *kind_out = 3;
	else
		return lerr(p, "unknown word '%s' (expected material, fixed or force)", w);
	if (*kind_out == 1 && *have_mat)
		return lerr(p, "material given twice");
	for (;;) {
		int has_eq;

		skip_blank(p);
		if (!*p->s || *p->s == ';')
			break;
		if ((rc = read_ident(p, w)))
			return rc;
		if (!w[0]) {
			char c[2] = {*p->s, 0};
			return lerr(p, "unexpected '%s'", c);
		}
		skip_blank(p);
		has_eq = *p->s == '=';
		v[0] = 0;
		if (has_eq) {
			p->s++;
			if ((rc = read_value(p, v)))
				return rc;
		}
		if (*kind_out == 1 && (!strcmp(w, "E_mpa") || !strcmp(w, "nu"))) {
			int isE = w[0] == 'E';
			if ((isE && have_E) || (!isE && have_nu))
				return lerr(p, "'%s' given twice", w);
			if (!has_eq)
				return lerr(p, "'%s' needs '=number'", w);
			if ((rc = parse_nums(p, w, v, isE ? &m.E_mpa : &m.nu, 1)))
				return rc;
			if (isE) {
				have_E = 1;
				if (!(m.E_mpa > 0))
					return lerr(p, "E_mpa must be > 0 (got %s)", v);
			} else {
				have_nu = 1;
				if (!(m.nu > -1 && m.nu < 0.5))
					return lerr(p, "nu must be in (-1, 0.5) (got %s)", v);
			}
		} else if (*kind_out != 1 &&
			   (!strcmp(w, "plate") || !strcmp(w, "top") || !strcmp(w, "box"))) {
			if (have_place)
				return lerr(p, "more than one place ('%s' after another)", w);
			have_place = 1;
			if (w[0] == 'b') {
				at = FEA_AT_BOX;
				if (!has_eq)
					return lerr(p, "box needs '=x0,y0,z0,x1,y1,z1'");
				if ((rc = parse_nums(p, "box", v, box, 6)) || (rc = check_box(p, box)))
					return rc;
			} else {
				if (has_eq)
					return lerr(p, "'%s' takes no value", w);
				at = w[0] == 'p' ? FEA_AT_PLATE : FEA_AT_TOP;
			}
		} else if (*kind_out == 2 && !strcmp(w, "axes")) {
			if (have_axes)
				return lerr(p, "'%s' given twice", w);
			have_axes = 1;
			if ((rc = parse_axes(p, v, &axes)))
				return rc;
		} else if (*kind_out == 3 && !strcmp(w, "n")) {
			if (have_n)
				return lerr(p, "'%s' given twice", w);
			have_n = 1;
			if (!has_eq)
				return lerr(p, "n needs '=fx,fy,fz'");
			if ((rc = parse_nums(p, "n", v, n3, 3)))
				return rc;
		} else {
			return lerr(p, "unknown word '%s'", w);
		}
	}
	if (*kind_out == 1) {
		*mat = m;
		*have_mat = 1;
		return 0;
	}
	if (!have_place)
		return lerr(p, "missing place (plate, top or box=x0,y0,z0,x1,y1,z1)");
	if (*kind_out == 2) {
		fix->at = at;
		memcpy(fix->box_mm, box, sizeof box);
		fix->axes = axes;
	} else {
		if (!have_n)
			return lerr(p, "missing n=fx,fy,fz (N)");
		force->at = at;
		memcpy(force->box_mm, box, sizeof box);
		memcpy(force->force_n, n3, sizeof n3);
	}
	return 0;
}

int fea_loads_parse(const char *text, struct fea_material mat, struct fea_loads *l,
		    struct err *e)
{
	struct fea_loads t = {mat, NULL, 0, NULL, 0};
	struct lp p = {text ? text : "", 0, NULL, e};
	size_t cap_fix = 0, cap_force = 0;
	int have_mat = 0, rc = 0;

	for (;;) {
		struct fea_fix fix;
		struct fea_force force;
		int kind;

		p.stmt++;
		p.kind = NULL;
		if (p.stmt > LOADS_MAX_STATEMENTS) {
			skip_blank(&p);
			if (*p.s) {
				rc = ERR_FIELD(e, "loads", "loads: more than %d statements",
					       LOADS_MAX_STATEMENTS);
				goto out;
			}
		}
		if ((rc = parse_statement(&p, &t.material, &have_mat, &fix, &force, &kind)))
			goto out;
		skip_blank(&p);
		if (*p.s && *p.s != ';') {
			rc = lerr(&p, "unexpected text '%.20s'", p.s);
			goto out;
		}
		if (kind == 2) {
			if ((rc = mem_grow((void **)&t.fixed, &cap_fix, t.nfixed + 1, sizeof fix))) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for the load case");
				goto out;
			}
			t.fixed[t.nfixed++] = fix;
		} else if (kind == 3) {
			if ((rc = mem_grow((void **)&t.forces, &cap_force, t.nforces + 1,
					   sizeof force))) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for the load case");
				goto out;
			}
			t.forces[t.nforces++] = force;
		}
		if (!*p.s)
			break;
		p.s++; /* ';' */
	}
	if (t.nfixed == 0 && t.nforces == 0) {
		struct fea_material m = t.material;
		fea_loads_fini(&t);
		return fea_loads_default(l, m, e);
	}
	*l = t;
	return 0;
out:
	fea_loads_fini(&t);
	return rc;
}

/* Shortest %g form of x that reads back exactly. */
static void fmt_num(char *b, size_t len, double x)
{
	for (int prec = 6; prec <= 17; prec++) {
		snprintf(b, len, "%.*g", prec, x);
		if (strtod(b, NULL) == x)
			return;
	}
}

struct out {
	char *buf;
	size_t len, n;
};

static void put(struct out *o, const char *s)
{
	size_t k = strlen(s);

	if (o->n + k < o->len)
		memcpy(o->buf + o->n, s, k + 1);
	o->n += k;
}

static void put_nums(struct out *o, const double *x, int n)
{
	char b[40];

	for (int i = 0; i < n; i++) {
		fmt_num(b, sizeof b, x[i]);
		if (i)
			put(o, ",");
		put(o, b);
	}
}

static void put_place(struct out *o, enum fea_at at, const double box[6])
{
	if (at == FEA_AT_PLATE) {
		put(o, " plate");
	} else if (at == FEA_AT_TOP) {
		put(o, " top");
	} else {
		put(o, " box=");
		put_nums(o, box, 6);
	}
}

int fea_loads_format(const struct fea_loads *l, char *buf, size_t len, struct err *e)
{
	struct out o = {buf, len, 0};

	if (len)
		buf[0] = 0;
	put(&o, "material E_mpa=");
	put_nums(&o, &l->material.E_mpa, 1);
	put(&o, " nu=");
	put_nums(&o, &l->material.nu, 1);
	for (size_t i = 0; i < l->nfixed; i++) {
		const struct fea_fix *f = &l->fixed[i];
		put(&o, "; fixed");
		put_place(&o, f->at, f->box_mm);
		put(&o, " axes=");
		if (f->axes & FEA_AXIS_X)
			put(&o, "x");
		if (f->axes & FEA_AXIS_Y)
			put(&o, "y");
		if (f->axes & FEA_AXIS_Z)
			put(&o, "z");
	}
	for (size_t i = 0; i < l->nforces; i++) {
		const struct fea_force *f = &l->forces[i];
		put(&o, "; force");
		put_place(&o, f->at, f->box_mm);
		put(&o, " n=");
		put_nums(&o, f->force_n, 3);
	}
	if (o.n >= len) {
		if (len)
			buf[0] = 0;
		return ERR_SET(e, ERR_LIMIT, "load case text needs %zu bytes, buffer has %zu",
			       o.n + 1, len);
	}
	return 0;
}
