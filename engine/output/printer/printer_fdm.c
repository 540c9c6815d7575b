/* printer_fdm.c - FDM printer profiles, their override table and the
 * cross-field checks (see printer.h; values and sources in
 * docs/printers.md).  The G-code writer (gcode_write.c) and the toolpath
 * planner (toolpath*.c) read only struct fdm_printer.
 */
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/core/err.h"

#include <stddef.h>

/* generic-fdm: a 220 x 220 x 250 mm bed-slinger with a 0.4 mm nozzle and
 * 1.75 mm PLA, tuned like PrusaSlicer 2.5's "Generic PLA" with its
 * "0.20mm QUALITY" print profile (docs/printers.md lists the sources). */
#define GENERIC_FDM                                                                       \
	{                                                                                 \
		.bed_x_mm = 220, .bed_y_mm = 220, .max_z_mm = 250, .nozzle_mm = 0.4,      \
		.filament_mm = 1.75, .layer_mm = 0.2, .first_layer_mm = 0.2,              \
		.line_width_mm = 0.45, .perimeters = 2, .top_layers = 5,                  \
		.bottom_layers = 4, .infill_pct = 15, .infill_angle_deg = 45,             \
		.nozzle_c = 215, .bed_c = 60, .print_speed_mm_s = 40,                     \
		.perimeter_speed_mm_s = 45, .infill_speed_mm_s = 80,                      \
		.first_layer_speed_mm_s = 20, .travel_speed_mm_s = 150,                   \
		.retract_mm = 0.8, .retract_speed_mm_s = 35, .z_hop_mm = 0.2,             \
		.min_travel_retract_mm = 1, .filament_type = "PLA",                       \
		.filament_density_g_cm3 = 1.24, .external_perimeter_speed_mm_s = 25,      \
		.solid_infill_speed_mm_s = 80, .top_solid_speed_mm_s = 40,                \
		.bridge_speed_mm_s = 25, .z_speed_mm_s = 12, .accel_mm_s2 = 1000,         \
		.jerk_mm_s = 8, .fan_pct = 100, .min_layer_time_s = 15,                   \
		.min_print_speed_mm_s = 15, .skirt_loops = 1, .skirt_distance_mm = 2,     \
		.external_perimeter_first = 0, .seam = FDM_SEAM_NEAREST, .klipper = 0,    \
	}

const struct printer printer_fdm_profiles[] = {
	{.name = "generic-fdm", .kind = PRINTER_FDM, .fdm = GENERIC_FDM},
};
const size_t printer_fdm_profile_count = sizeof printer_fdm_profiles / sizeof printer_fdm_profiles[0];

static const char *const seam_choices[] = {"nearest", "rear", NULL};

#define OFF(f) offsetof(struct fdm_printer, f)
#define NUM(key, f, lo, hi, def, unit, help) \
	{key, PARAM_NUM, OFF(f), lo, hi, def, NULL, NULL, 0, 0, unit, help}
#define NUMX(key, f, lo, hi, def, unit, help) \
	{key, PARAM_NUM, OFF(f), lo, hi, def, NULL, NULL, 0, PARAM_F_MIN_EXCL, unit, help}
#define INT(key, f, lo, hi, def, help) \
	{key, PARAM_INT, OFF(f), lo, hi, def, NULL, NULL, 0, 0, "", help}
#define BOOL(key, f, def, help) {key, PARAM_BOOL, OFF(f), 0, 1, def, NULL, NULL, 0, 0, "", help}

/* Defaults repeat GENERIC_FDM so the table documents the default profile
 * (tests/unit/output/test_gcode_printer.c checks they agree). */
static const struct param_desc fdm_params[] = {
	NUMX("bed_x_mm", bed_x_mm, 0, 2000, 220, "mm", "Printable bed size along X."),
	NUMX("bed_y_mm", bed_y_mm, 0, 2000, 220, "mm", "Printable bed size along Y."),
	NUMX("max_z_mm", max_z_mm, 0, 2000, 250, "mm", "Printable height."),
	NUM("nozzle_mm", nozzle_mm, 0.1, 2.0, 0.4, "mm", "Nozzle diameter."),
	NUM("filament_diameter_mm", filament_mm, 1.0, 3.5, 1.75, "mm", "Filament diameter."),
	NUM("default_layer_mm", layer_mm, 0.01, 1.5, 0.2, "mm",
	    "Layer height used when the job's layer_mm is 0."),
	NUM("first_layer_mm", first_layer_mm, 0.01, 1.5, 0.2, "mm",
	    "Height of the first printed layer; the part is raised by its excess over the "
	    "layer height."),
	NUM("line_width_mm", line_width_mm, 0.1, 3.0, 0.45, "mm",
	    "Extrusion width of perimeters and infill (Slic3r convention: bead width)."),
	INT("perimeters", perimeters, 1, 50, 2, "Perimeter loops around every island and hole."),
	INT("top_layers", top_layers, 0, 100, 5, "Solid layers under every top surface."),
	INT("bottom_layers", bottom_layers, 0, 100, 4, "Solid layers over every bottom surface."),
	NUM("infill_pct", infill_pct, 0, 100, 15, "%",
	    "Sparse infill density of the part's bulk (rectilinear, alternating 90 degrees)."),
	NUM("infill_angle_deg", infill_angle_deg, -360, 360, 45, "deg",
	    "Direction of infill lines on even layers; odd layers turn by 90."),
	NUM("nozzle_temp_c", nozzle_c, 0, 450, 215, "C", "Nozzle temperature."),
	NUM("bed_temp_c", bed_c, 0, 150, 60, "C", "Bed temperature (0: no heated bed)."),
	NUMX("print_speed_mm_s", print_speed_mm_s, 0, 1000, 40, "mm/s",
	     "Gap fill and skirt speed."),
	NUMX("perimeter_speed_mm_s", perimeter_speed_mm_s, 0, 1000, 45, "mm/s",
	     "Inner perimeter speed."),
	NUMX("infill_speed_mm_s", infill_speed_mm_s, 0, 1000, 80, "mm/s", "Sparse infill speed."),
	NUMX("first_layer_speed_mm_s", first_layer_speed_mm_s, 0, 1000, 20, "mm/s",
	     "Speed of every extrusion on the first layer."),
	NUMX("travel_speed_mm_s", travel_speed_mm_s, 0, 2000, 150, "mm/s", "Travel speed."),
	NUM("retract_mm", retract_mm, 0, 20, 0.8, "mm", "Filament retracted before a travel."),
	NUMX("retract_speed_mm_s", retract_speed_mm_s, 0, 200, 35, "mm/s", "Retraction speed."),
	NUM("z_hop_mm", z_hop_mm, 0, 10, 0.2, "mm", "Lift on retracting travels (0: none)."),
	NUM("min_travel_retract_mm", min_travel_retract_mm, 0, 1000, 1, "mm",
	    "Travels at most this long that stay over the layer's material do not retract."),
	{"filament_type", PARAM_STR, OFF(filament_type), 1, 15, 0, "PLA", NULL,
	 sizeof(((struct fdm_printer *)0)->filament_type), 0, "", "Filament material name."},
	NUMX("filament_density_g_cm3", filament_density_g_cm3, 0, 25, 1.24, "g/cm3",
	     "Filament density for the weight estimate."),
	NUMX("external_perimeter_speed_mm_s", external_perimeter_speed_mm_s, 0, 1000, 25, "mm/s",
	     "Outermost perimeter and thin wall speed."),
	NUMX("solid_infill_speed_mm_s", solid_infill_speed_mm_s, 0, 1000, 80, "mm/s",
	     "Solid infill speed."),
	NUMX("top_solid_speed_mm_s", top_solid_speed_mm_s, 0, 1000, 40, "mm/s",
	     "Speed of solid infill on exposed top surfaces."),
	NUMX("bridge_speed_mm_s", bridge_speed_mm_s, 0, 1000, 25, "mm/s",
	     "Speed of solid infill over air."),
	NUMX("z_speed_mm_s", z_speed_mm_s, 0, 200, 12, "mm/s", "Z moves (layer change, hop)."),
	NUMX("accel_mm_s2", accel_mm_s2, 0, 100000, 1000, "mm/s2",
	     "Acceleration of the time estimate (trapezoidal profile)."),
	NUM("jerk_mm_s", jerk_mm_s, 0, 100, 8, "mm/s",
	    "Instant speed change allowed at corners (Marlin classic jerk)."),
	NUM("fan_pct", fan_pct, 0, 100, 100, "%", "Part cooling fan from the second layer on."),
	NUM("min_layer_time_s", min_layer_time_s, 0, 600, 15, "s",
	    "Layers estimated faster than this are slowed down (0: never)."),
	NUMX("min_print_speed_mm_s", min_print_speed_mm_s, 0, 1000, 15, "mm/s",
	     "Slowest speed the layer-time slowdown may use."),
	INT("skirt_loops", skirt_loops, 0, 20, 1, "Skirt loops around the first layer."),
	NUM("skirt_distance_mm", skirt_distance_mm, 0, 100, 2, "mm",
	    "Gap between the skirt and the first layer's outline."),
	BOOL("external_perimeter_first", external_perimeter_first, 0,
	     "Print the outermost loop first (default: inner loops first)."),
	{"seam", PARAM_ENUM, OFF(seam), 0, 0, FDM_SEAM_NEAREST, NULL, seam_choices, 0, 0, "",
	 "Loop start: nearest to the nozzle, or the rear-most vertex."},
	BOOL("klipper", klipper, 0, "Emit Klipper SET_PRINT_STATS_INFO layer progress."),
};

const struct param_table printer_fdm_table = {"printer.fdm", fdm_params,
					      sizeof fdm_params / sizeof fdm_params[0]};

int printer_fdm_check(const struct fdm_printer *f, struct err *e)
{
	if (f->line_width_mm < 0.8 * f->nozzle_mm || f->line_width_mm > 2.5 * f->nozzle_mm)
		return ERR_FIELD(e, "line_width_mm",
				 "line_width_mm = %g must lie within 0.8 to 2.5 times the nozzle "
				 "diameter (%g mm)",
				 f->line_width_mm, f->nozzle_mm);
	if (f->layer_mm > 0.8 * f->nozzle_mm)
		return ERR_FIELD(e, "default_layer_mm",
				 "default_layer_mm = %g exceeds 80%% of the nozzle diameter (%g mm)",
				 f->layer_mm, f->nozzle_mm);
	if (f->first_layer_mm > f->nozzle_mm)
		return ERR_FIELD(e, "first_layer_mm",
				 "first_layer_mm = %g exceeds the nozzle diameter (%g mm)",
				 f->first_layer_mm, f->nozzle_mm);
	/* The Slic3r bead model (docs/gcode.md) needs a bead at least as wide as
	 * it is high. */
	if (f->line_width_mm <= f->layer_mm || f->line_width_mm <= f->first_layer_mm)
		return ERR_FIELD(e, "line_width_mm",
				 "line_width_mm = %g must exceed the layer heights (%g, first %g mm)",
				 f->line_width_mm, f->layer_mm, f->first_layer_mm);
	if (f->z_hop_mm >= f->max_z_mm)
		return ERR_FIELD(e, "z_hop_mm", "z_hop_mm = %g exceeds the printable height",
				 f->z_hop_mm);
	if (f->min_print_speed_mm_s > f->external_perimeter_speed_mm_s ||
	    f->min_print_speed_mm_s > f->first_layer_speed_mm_s)
		return ERR_FIELD(e, "min_print_speed_mm_s",
				 "min_print_speed_mm_s = %g exceeds a feature speed (external "
				 "perimeter %g, first layer %g mm/s)",
				 f->min_print_speed_mm_s, f->external_perimeter_speed_mm_s,
				 f->first_layer_speed_mm_s);
	if (f->skirt_loops > 0 &&
	    2 * (f->skirt_distance_mm + f->skirt_loops * f->line_width_mm) >=
		    (f->bed_x_mm < f->bed_y_mm ? f->bed_x_mm : f->bed_y_mm))
		return ERR_FIELD(e, "skirt_distance_mm",
				 "the skirt (%d loops at %g mm) does not fit the %g x %g mm bed",
				 f->skirt_loops, f->skirt_distance_mm, f->bed_x_mm, f->bed_y_mm);
	return 0;
}
