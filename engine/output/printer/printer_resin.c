/* printer_resin.c - resin printer profiles (sl1, sl1s, generic-resin),
 * their override table, checks, and the printer-mm -> image-pixel map.
 *
 * Values and sources: docs/printers.md (PrusaSlicer 2.5.2,
 * resources/profiles/PrusaResearch.ini and PrintConfig.cpp defaults).
 */
#include "engine/output/printer/printer.h"
#include "engine/output/printer/printer_kinds.h"
#include "engine/core/err.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

/* Exposure limits the SL1/SL1S firmware accepts (slafw defines.py:
 * exposure_time_min/max_ms, exposure_time_first_min/max_ms); PrusaSlicer's
 * own limits (1..120 s, 1..300 s) are wider. */
#define RESIN_EXPOSURE_MIN_S 1.0
#define RESIN_EXPOSURE_MAX_S 60.0
#define RESIN_EXPOSURE_FIRST_MIN_S 10.0
#define RESIN_EXPOSURE_FIRST_MAX_S 120.0

/* Display limits for generic-resin overrides: 16384 px covers 16K
 * panels; MSLA pixels are 0.019..0.05 mm, so 0.005..0.2 mm only catches
 * swapped or mistyped values (a pixel count given as mm, inches...). */
#define RESIN_DISPLAY_MAX_PX 16384
#define RESIN_PITCH_MIN_MM 0.005
#define RESIN_PITCH_MAX_MM 0.2

const struct printer printer_resin_profiles[] = {
	{
		.name = "sl1",
		.kind = PRINTER_RESIN,
		.resin =
			{
				.model = "SL1",
				.variant = "default",
				.profile = "Original Prusa SL1",
				.pixels_x = 2560,
				.pixels_y = 1440,
				.display_w_mm = 120.96,
				.display_h_mm = 68.04,
				.portrait = 1,
				.mirror_x = 1, /* PrintConfig.cpp default; SL1 profile sets none */
				.mirror_y = 0,
				.max_z_mm = 150,
				.layer_mm = 0.05,
				.exposure_s = 7.5, /* Prusa Orange Tough @0.05 */
				.exposure_first_s = 35,
				.fade_layers = 10,
				.antialias = 1,
				.print_speed = RESIN_SPEED_FAST,
				.tilt_fast_s = 5,
				.tilt_slow_s = 8,
				.tilt_hv_s = 10,
				.slow_area_pct = 50,
				.material = "Prusa Orange Tough @0.05",
			},
	},
	{
		.name = "sl1s",
		.kind = PRINTER_RESIN,
		.resin =
			{
				.model = "SL1S",
				.variant = "default",
				.profile = "Original Prusa SL1S SPEED",
				.pixels_x = 2560,
				.pixels_y = 1620,
				.display_w_mm = 128,
				.display_h_mm = 81,
				.portrait = 1,
				.mirror_x = 1,
				.mirror_y = 0,
				.max_z_mm = 150,
				.layer_mm = 0.05,
				.exposure_s = 2, /* Prusa Orange Tough @0.05 SL1S */
				.exposure_first_s = 25,
				.fade_layers = 10,
				.antialias = 1,
				.print_speed = RESIN_SPEED_FAST,
				.tilt_fast_s = 2.5,
				.tilt_slow_s = 5,
				.tilt_hv_s = 10,
				.slow_area_pct = 45,
				.material = "Prusa Orange Tough @0.05 SL1S",
			},
	},
	{
		/* Any other MSLA printer, for zip stacks: a round 4K panel of
		 * 40 um pixels, landscape, unmirrored; farms set the display_*
		 * and mirror_* keys to their own printer's. */
		.name = "generic-resin",
		.kind = PRINTER_RESIN,
		.resin =
			{
				.model = "GENERIC",
				.variant = "default",
				.profile = "Generic MSLA",
				.pixels_x = 3840,
				.pixels_y = 2400,
				.display_w_mm = 153.6,
				.display_h_mm = 96,
				.portrait = 0,
				.mirror_x = 0,
				.mirror_y = 0,
				.max_z_mm = 150,
				.layer_mm = 0.05,
				.exposure_s = 2.5,
				.exposure_first_s = 25,
				.fade_layers = 10,
				.antialias = 1,
				.print_speed = RESIN_SPEED_FAST,
				.tilt_fast_s = 5,
				.tilt_slow_s = 8,
				.tilt_hv_s = 10,
				.slow_area_pct = 50,
				.material = "Generic resin",
			},
	},
};
const size_t printer_resin_profile_count =
	sizeof printer_resin_profiles / sizeof printer_resin_profiles[0];

static const char *const print_speeds[] = {"fast", "slow", "high_viscosity", NULL};

#define RF(f) offsetof(struct resin_printer, f)
static const struct param_desc resin_desc[] = {
	{.name = "exposure_s", .type = PARAM_NUM, .offset = RF(exposure_s),
	 .min = RESIN_EXPOSURE_MIN_S, .max = RESIN_EXPOSURE_MAX_S, .def = 7.5, .unit = "s",
	 .help = "UV exposure of each layer after the first ones (config.ini expTime)"},
	{.name = "exposure_first_s", .type = PARAM_NUM, .offset = RF(exposure_first_s),
	 .min = RESIN_EXPOSURE_FIRST_MIN_S, .max = RESIN_EXPOSURE_FIRST_MAX_S, .def = 35, .unit = "s",
	 .help = "UV exposure of the first layers, which bond to the platform (expTimeFirst)"},
	{.name = "fade_layers", .type = PARAM_INT, .offset = RF(fade_layers), .min = 3, .max = 20,
	 .def = 10, .unit = "",
	 .help = "layers over which the exposure falls from the first-layer to the normal "
		 "time (numFade)"},
	{.name = "antialias", .type = PARAM_BOOL, .offset = RF(antialias), .def = 1, .unit = "",
	 .help = "8-bit edge coverage (true) or binary pixels (false)"},
	{.name = "print_speed", .type = PARAM_ENUM, .offset = RF(print_speed), .def = 0,
	 .choices = print_speeds, .unit = "",
	 .help = "tilt profile of the material: fast, slow or high_viscosity (expUserProfile)"},
	{.name = "tilt_fast_s", .type = PARAM_NUM, .offset = RF(tilt_fast_s), .min = 0, .max = 60,
	 .def = 5, .unit = "s", .help = "time of a fast tilt, for the print time estimate"},
	{.name = "tilt_slow_s", .type = PARAM_NUM, .offset = RF(tilt_slow_s), .min = 0, .max = 60,
	 .def = 8, .unit = "s", .help = "time of a slow tilt, for the print time estimate"},
	{.name = "tilt_hv_s", .type = PARAM_NUM, .offset = RF(tilt_hv_s), .min = 0, .max = 60,
	 .def = 10, .unit = "s",
	 .help = "time of a high-viscosity tilt, for the print time estimate"},
	{.name = "slow_area_pct", .type = PARAM_NUM, .offset = RF(slow_area_pct), .min = 0,
	 .max = 100, .def = 50, .unit = "%",
	 .help = "layers covering more than this share of the display use the slow tilt"},
	{.name = "display_px_x", .type = PARAM_INT, .offset = RF(pixels_x), .min = 1,
	 .max = RESIN_DISPLAY_MAX_PX, .def = 3840, .unit = "px",
	 .help = "display pixels along printer X, the image width (generic-resin only)"},
	{.name = "display_px_y", .type = PARAM_INT, .offset = RF(pixels_y), .min = 1,
	 .max = RESIN_DISPLAY_MAX_PX, .def = 2400, .unit = "px",
	 .help = "display pixels along printer Y, the image height (generic-resin only)"},
	{.name = "display_mm_x", .type = PARAM_NUM, .offset = RF(display_w_mm), .min = 0,
	 .max = 1000, .def = 153.6, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "width of the lit display area along printer X (generic-resin only)"},
	{.name = "display_mm_y", .type = PARAM_NUM, .offset = RF(display_h_mm), .min = 0,
	 .max = 1000, .def = 96, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "height of the lit display area along printer Y (generic-resin only)"},
	{.name = "mirror_x", .type = PARAM_BOOL, .offset = RF(mirror_x), .def = 0, .unit = "",
	 .help = "flip every image left-right, for displays seen from below (generic-resin "
		 "only)"},
	{.name = "mirror_y", .type = PARAM_BOOL, .offset = RF(mirror_y), .def = 0, .unit = "",
	 .help = "flip every image top-bottom (generic-resin only)"},
	{.name = "material", .type = PARAM_STR, .offset = RF(material), .min = 1, .max = 47,
	 .str_cap = sizeof(((struct resin_printer *)0)->material),
	 .def_str = "Prusa Orange Tough @0.05", .unit = "",
	 .help = "resin name written to config.ini (materialName)"},
};
#undef RF

const struct param_table printer_resin_table = {"resin", resin_desc,
						sizeof resin_desc / sizeof resin_desc[0]};

int printer_resin_check(const struct resin_printer *r, struct err *e)
{
	const struct {
		const char *px_key, *mm_key;
		int px;
		double mm;
	} ax[2] = {{"display_px_x", "display_mm_x", r->pixels_x, r->display_w_mm},
		   {"display_px_y", "display_mm_y", r->pixels_y, r->display_h_mm}};

	for (int i = 0; i < 2; i++) {
		double pitch_mm;

		if (ax[i].px < 1 || ax[i].px > RESIN_DISPLAY_MAX_PX)
			return ERR_FIELD(e, ax[i].px_key, "%s = %d px is outside 1..%d",
					 ax[i].px_key, ax[i].px, RESIN_DISPLAY_MAX_PX);
		if (!(ax[i].mm > 0) || !isfinite(ax[i].mm))
			return ERR_FIELD(e, ax[i].mm_key, "%s = %g mm is not a positive size",
					 ax[i].mm_key, ax[i].mm);
		pitch_mm = ax[i].mm / ax[i].px;
		if (!(pitch_mm >= RESIN_PITCH_MIN_MM && pitch_mm <= RESIN_PITCH_MAX_MM))
			return ERR_FIELD(e, ax[i].mm_key,
					 "%s = %g mm over %s = %d px gives %g mm pixels, outside "
					 "%g..%g mm: check both values",
					 ax[i].mm_key, ax[i].mm, ax[i].px_key, ax[i].px, pitch_mm,
					 RESIN_PITCH_MIN_MM, RESIN_PITCH_MAX_MM);
	}
	if (!(r->max_z_mm > 0) || !isfinite(r->max_z_mm))
		return ERR_FIELD(e, "printer", "printable height %g mm is not positive",
				 r->max_z_mm);
	if (!(r->layer_mm >= 0.01 && r->layer_mm <= 0.2))
		return ERR_FIELD(e, "layer_mm", "default layer height %g mm is outside [0.01, 0.2]",
				 r->layer_mm);
	if (r->exposure_first_s < r->exposure_s)
		return ERR_FIELD(e, "exposure_first_s",
				 "exposure_first_s = %g s is shorter than exposure_s = %g s: the "
				 "first layers must cure at least as long to hold on the platform",
				 r->exposure_first_s, r->exposure_s);
	if (strpbrk(r->material, "#\"\\=[]"))
		return ERR_FIELD(e, "material",
				 "material '%s' contains one of # \" \\ = [ ], which config.ini "
				 "cannot hold unquoted",
				 r->material);
	if (r->model[0] == '\0')
		return ERR_FIELD(e, "printer", "resin profile without a printerModel");
	return 0;
}

/* The display of a profile whose model is SL1 or SL1S is the firmware's:
 * refuse any change, naming the first key that differs from the compiled
 * profile of the same name (a profile not found here is a caller's own,
 * e.g. a test's, and is left alone). */
int printer_resin_check_display(const struct printer *p, struct err *e)
{
	const struct resin_printer *r = &p->resin, *f = NULL;
	const char *key = NULL;

	if (strcmp(r->model, "SL1") != 0 && strcmp(r->model, "SL1S") != 0)
		return 0;
	for (size_t i = 0; i < printer_resin_profile_count; i++)
		if (strcmp(printer_resin_profiles[i].name, p->name) == 0)
			f = &printer_resin_profiles[i].resin;
	if (!f)
		return 0;
	if (r->pixels_x != f->pixels_x)
		key = "display_px_x";
	else if (r->pixels_y != f->pixels_y)
		key = "display_px_y";
	else if (r->display_w_mm != f->display_w_mm)
		key = "display_mm_x";
	else if (r->display_h_mm != f->display_h_mm)
		key = "display_mm_y";
	else if (r->mirror_x != f->mirror_x)
		key = "mirror_x";
	else if (r->mirror_y != f->mirror_y)
		key = "mirror_y";
	else if (r->portrait != f->portrait)
		key = "printer";
	if (!key)
		return 0;
	return ERR_FIELD(e, key,
			 "%s cannot be overridden on printer '%s': the %s firmware fixes its "
			 "display (%d x %d px, %g x %g mm); use --printer generic-resin",
			 key, p->name, r->model, f->pixels_x, f->pixels_y, f->display_w_mm,
			 f->display_h_mm);
}

/* PrusaSlicer's display_width always spans the printer X axis (its
 * bed_shape: 1.48..119.48 x 1.02..67.02 for the SL1), in either
 * orientation; portrait only changes how the image is stored. */
double printer_resin_extent_x_mm(const struct resin_printer *r)
{
	return r->display_w_mm;
}

double printer_resin_extent_y_mm(const struct resin_printer *r)
{
	return r->display_h_mm;
}

/* The map, following PrusaSlicer 2.5's SLA raster transform
 * (docs/printers.md derives it):
 *   landscape: u = X / pitch_x, v = Y / pitch_y; image pixels_x wide;
 *   portrait:  u = Y / pitch_y, v = X / pitch_x; image pixels_y wide
 *              (the X<->Y swap itself mirrors, so PrusaSlicer inverts
 *              its mirror_x flag there);
 * then u is mirrored (u -> W - u) when mirror_x XOR portrait, and v is
 * mirrored (v -> H - v) unless mirror_y, because the raster origin is the
 * top-left corner while the printer's Y/X grows upwards.
 * SL1 (portrait, mirror_x = 1, mirror_y = 0): u = Y / 0.04725,
 * v = (120.96 - X) / 0.04725 on a 1440 x 2560 image. */
void printer_raster_geometry(const struct printer *p, struct raster_map *map, int *w_px,
			     int *h_px)
{
	const struct resin_printer *r = &p->resin;
	double ppx = r->pixels_x / r->display_w_mm; /* pixels per mm along printer X */
	double ppy = r->pixels_y / r->display_h_mm; /* pixels per mm along printer Y */
	int w, h, flip_u, flip_v;

	map->a[0][0] = map->a[0][1] = map->a[1][0] = map->a[1][1] = 0;
	map->b[0] = map->b[1] = 0;
	if (r->portrait) {
		w = r->pixels_y;
		h = r->pixels_x;
		map->a[0][1] = ppy; /* u from Y */
		map->a[1][0] = ppx; /* v from X */
		flip_u = !r->mirror_x;
	} else {
		w = r->pixels_x;
		h = r->pixels_y;
		map->a[0][0] = ppx;
		map->a[1][1] = ppy;
		flip_u = r->mirror_x;
	}
	flip_v = !r->mirror_y;
	if (flip_u) {
		map->a[0][0] = -map->a[0][0];
		map->a[0][1] = -map->a[0][1];
		map->b[0] = w;
	}
	if (flip_v) {
		map->a[1][0] = -map->a[1][0];
		map->a[1][1] = -map->a[1][1];
		map->b[1] = h;
	}
	*w_px = w;
	*h_px = h;
}
