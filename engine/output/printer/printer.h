/* printer.h - printer profiles: build volume, pixel grid, FDM settings.
 *
 * Profiles are compiled in (sl1, sl1s, generic-resin, generic-fdm; docs/printers.md has
 * their values and sources).  A job copies one and applies `--set`
 * overrides through printer_param_table(); the result is validated with
 * printer_check().  Two kinds with separate parameter structs, so resin
 * settings never leak into FDM ones.
 */
#ifndef INFILLD_PRINTER_H
#define INFILLD_PRINTER_H

#include <stddef.h>

#include "engine/core/param.h"
#include "engine/geom/raster.h"
#include "engine/geom/vec.h"

struct err;

enum printer_kind { PRINTER_RESIN, PRINTER_FDM };

/* Resin (masked SLA) printer.  Display geometry follows PrusaSlicer's
 * printer settings; the image orientation it implies is derived in
 * docs/printers.md and realised by printer_raster_geometry(). */
enum resin_print_speed { RESIN_SPEED_FAST, RESIN_SPEED_SLOW, RESIN_SPEED_HIGH_VISCOSITY };

struct resin_printer {
	char model[8];          /* config.ini printerModel: "SL1" / "SL1S"; "GENERIC" */
	char variant[16];       /* printerVariant */
	char profile[48];       /* printerProfile: PrusaSlicer's preset name */
	int pixels_x, pixels_y; /* display_pixels_x/_y as PrusaSlicer stores them */
	double display_w_mm;    /* display_width (along display_pixels_x) */
	double display_h_mm;    /* display_height (along display_pixels_y) */
	int portrait;           /* display_orientation = portrait */
	int mirror_x, mirror_y; /* display_mirror_x/_y */
	double max_z_mm;        /* printable height */
	double layer_mm;        /* default layer height */
	double exposure_s;      /* expTime */
	double exposure_first_s;/* expTimeFirst */
	int fade_layers;        /* numFade */
	int antialias;          /* 1 = 8-bit coverage, 0 = binary */
	int print_speed;        /* enum resin_print_speed: expUserProfile, tilt choice */
	double tilt_fast_s;     /* per-layer overhead, fast tilt (printTime model) */
	double tilt_slow_s;     /* per-layer overhead, slow tilt */
	double tilt_hv_s;       /* per-layer overhead, high-viscosity tilt */
	double slow_area_pct;   /* layers whose area exceeds this % of the display use the slow tilt */
	char material[48];      /* materialName */
};

struct fdm_printer {
	double bed_x_mm, bed_y_mm, max_z_mm;
	double nozzle_mm, filament_mm; /* filament diameter */
	double layer_mm, first_layer_mm;
	double line_width_mm;           /* extrusion width */
	int perimeters;                 /* perimeter loops */
	int top_layers, bottom_layers;  /* solid skins over/under sparse infill */
	double infill_pct;              /* sparse infill density for LAYER_FILL_PART */
	double infill_angle_deg;        /* first infill direction; alternates by 90 */
	double nozzle_c, bed_c;         /* temperatures, Celsius */
	double print_speed_mm_s, perimeter_speed_mm_s, infill_speed_mm_s;
	double first_layer_speed_mm_s, travel_speed_mm_s;
	double retract_mm, retract_speed_mm_s, z_hop_mm;
	double min_travel_retract_mm;   /* shorter travels do not retract */
	char filament_type[16];         /* "PLA" */
	double filament_density_g_cm3;
	/* Per-feature speeds (print_speed_mm_s covers gap fill and skirt). */
	double external_perimeter_speed_mm_s, solid_infill_speed_mm_s;
	double top_solid_speed_mm_s, bridge_speed_mm_s, z_speed_mm_s;
	/* Motion model for the time estimate (docs/gcode.md). */
	double accel_mm_s2, jerk_mm_s;
	/* Cooling: fan from layer 1 on; slow down layers faster than this. */
	double fan_pct, min_layer_time_s, min_print_speed_mm_s;
	int skirt_loops;
	double skirt_distance_mm;
	int external_perimeter_first;   /* 0: inner loops first (default) */
	int seam;                       /* enum fdm_seam */
	int klipper;                    /* emit SET_PRINT_STATS_INFO */
};

enum fdm_seam { FDM_SEAM_NEAREST, FDM_SEAM_REAR };

struct printer {
	char name[32]; /* profile name */
	enum printer_kind kind;
	struct resin_printer resin; /* valid when kind == PRINTER_RESIN */
	struct fdm_printer fdm;     /* valid when kind == PRINTER_FDM */
};

/* Copy profile `name` into *out.  ERR_NOTFOUND lists the known names. */
int printer_lookup(const char *name, struct printer *out, struct err *e);
size_t printer_profile_count(void);
const char *printer_profile_name(size_t i);

/* Override table for a kind; base pointer = &p->resin or &p->fdm. */
const struct param_table *printer_param_table(enum printer_kind kind);
/* Base pointer for printer_param_table(p->kind). */
void *printer_params_base(struct printer *p);
/* Range and cross-field checks after overrides. */
int printer_check(const struct printer *p, struct err *e);

/* Where parts go: the centre of the plate/display, printer frame mm. */
void printer_center(const struct printer *p, double *x_mm, double *y_mm);
/* Printable box (printer frame, mm), z from 0. */
struct box3 printer_build_volume(const struct printer *p);
/* Default layer height of the profile, mm. */
double printer_layer_mm(const struct printer *p);

/* Resin only: stored image size and the printer-mm -> pixel map that
 * realises orientation and mirroring (raster.h).  See docs/printers.md
 * for the derivation from PrusaSlicer 2.5's SL1 output. */
void printer_raster_geometry(const struct printer *p, struct raster_map *map, int *w_px,
			     int *h_px);

/* Resin display geometry, for the resin writers: checks a display (pixels,
 * pitch, exposure; ERR_FIELD names the key) and its printable area along
 * printer X and Y (mm). */
int printer_resin_check(const struct resin_printer *r, struct err *e);
double printer_resin_extent_x_mm(const struct resin_printer *r);
double printer_resin_extent_y_mm(const struct resin_printer *r);

#endif
