/* printer_kinds.h - internal: what each printer kind provides to printer.c.
 * printer_resin.c defines the resin half, printer_fdm.c the FDM half. */
#ifndef INFILLD_PRINTER_KINDS_H
#define INFILLD_PRINTER_KINDS_H

#include <stddef.h>

#include "engine/output/printer/printer.h"

extern const struct printer printer_resin_profiles[];
extern const size_t printer_resin_profile_count;
extern const struct param_table printer_resin_table; /* base: struct resin_printer */
int printer_resin_check(const struct resin_printer *r, struct err *e);
/* Refuses display overrides on SL1/SL1S profiles (naming the key); run by
 * printer_check() only, so writers still take any geometry. */
int printer_resin_check_display(const struct printer *p, struct err *e);
/* Printable area along printer X and Y (mm) for the display geometry. */
double printer_resin_extent_x_mm(const struct resin_printer *r);
double printer_resin_extent_y_mm(const struct resin_printer *r);

extern const struct printer printer_fdm_profiles[];
extern const size_t printer_fdm_profile_count;
extern const struct param_table printer_fdm_table; /* base: struct fdm_printer */
int printer_fdm_check(const struct fdm_printer *f, struct err *e);

#endif
