/* printer.c - the printer profile registry (see printer.h).
 *
 * Profiles and override tables of each kind live in printer_resin.c and
 * printer_fdm.c; this file only looks them up and dispatches by kind.
 */
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <string.h>

size_t printer_profile_count(void)
{
	return printer_resin_profile_count + printer_fdm_profile_count;
}

static const struct printer *profile_at(size_t i)
{
	if (i < printer_resin_profile_count)
		return &printer_resin_profiles[i];
	i -= printer_resin_profile_count;
	return i < printer_fdm_profile_count ? &printer_fdm_profiles[i] : NULL;
}

const char *printer_profile_name(size_t i)
{
	const struct printer *p = profile_at(i);
	return p ? p->name : NULL;
}

int printer_lookup(const char *name, struct printer *out, struct err *e)
{
	char known[256] = "";
	size_t n = 0;

	for (size_t i = 0; i < printer_profile_count(); i++) {
		const struct printer *p = profile_at(i);
		if (name && strcmp(p->name, name) == 0) {
			*out = *p;
			return 0;
		}
		if (n < sizeof known)
			n += (size_t)snprintf(known + n, sizeof known - n, "%s%s", i ? ", " : "",
					      p->name);
	}
	ERR_SET(e, ERR_NOTFOUND, "unknown printer '%s' (known: %s)", name ? name : "", known);
	if (e)
		snprintf(e->field, sizeof e->field, "printer");
	return ERR_NOTFOUND;
}

const struct param_table *printer_param_table(enum printer_kind kind)
{
	return kind == PRINTER_RESIN ? &printer_resin_table : &printer_fdm_table;
}

void *printer_params_base(struct printer *p)
{
	return p->kind == PRINTER_RESIN ? (void *)&p->resin : (void *)&p->fdm;
}

int printer_check(const struct printer *p, struct err *e)
{
	int rc = param_check(printer_param_table(p->kind),
			     p->kind == PRINTER_RESIN ? (const void *)&p->resin
						      : (const void *)&p->fdm,
			     e);
	if (rc)
		return rc;
	if (p->kind == PRINTER_FDM)
		return printer_fdm_check(&p->fdm, e);
	rc = printer_resin_check_display(p, e);
	return rc ? rc : printer_resin_check(&p->resin, e);
}

void printer_center(const struct printer *p, double *x_mm, double *y_mm)
{
	struct box3 b = printer_build_volume(p);

	*x_mm = 0.5 * (b.lo.x + b.hi.x);
	*y_mm = 0.5 * (b.lo.y + b.hi.y);
}

struct box3 printer_build_volume(const struct printer *p)
{
	struct box3 b;

	b.lo = v3(0, 0, 0);
	if (p->kind == PRINTER_RESIN)
		b.hi = v3(printer_resin_extent_x_mm(&p->resin), printer_resin_extent_y_mm(&p->resin),
			  p->resin.max_z_mm);
	else
		b.hi = v3(p->fdm.bed_x_mm, p->fdm.bed_y_mm, p->fdm.max_z_mm);
	return b;
}

double printer_layer_mm(const struct printer *p)
{
	return p->kind == PRINTER_RESIN ? p->resin.layer_mm : p->fdm.layer_mm;
}
