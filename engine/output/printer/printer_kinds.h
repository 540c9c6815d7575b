/* printer_kinds.h - internal to printer/ (and its unit tests): the profile
 * and override tables each printer kind provides to printer.c.
 * printer_resin.c defines the resin half, printer_fdm.c the FDM half.
 * What writers outside printer/ need is in printer.h. */
#ifndef INFILLD_PRINTER_KINDS_H
#define INFILLD_PRINTER_KINDS_H

#include <stddef.h>

#include "engine/output/printer/printer.h"

extern const struct printer printer_resin_profiles[];
extern const size_t printer_resin_profile_count;
extern const struct param_table printer_resin_table; /* base: struct resin_printer */
/* Refuses display overrides on SL1/SL1S profiles (naming the key); run by
 * printer_check() only, so writers still take any geometry. */
int printer_resin_check_display(const struct printer *p, struct err *e);

extern const struct printer printer_fdm_profiles[];
extern const size_t printer_fdm_profile_count;
extern const struct param_table printer_fdm_table; /* base: struct fdm_printer */
int printer_fdm_check(const struct fdm_printer *f, struct err *e);

#endif
