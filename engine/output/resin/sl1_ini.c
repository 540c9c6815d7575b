/* sl1_ini.c - config.ini, prusaslicer.ini, manifest.json, jobDir and the
 * print-time model of resin archives (see resin_int.h, docs/formats.md).
 *
 * Values are written `key = value` without quotes, as PrusaSlicer does;
 * the firmware reads them with a TOML reader that accepts that form.
 */
#include "engine/output/resin/resin_int.h"
#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/engine.h" /* INFILLD_VERSION */

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <time.h>

/* SL1 firmware (slafw defines.py): layers 0..2 always use expTimeFirst. */
#define SL1_FIRST_EXTRA_LAYERS 2
/* Delays before exposure the firmware adds (slafw defines.py, also in
 * PrusaSlicer 2.5's estimator): safe profile, high viscosity, and any
 * slow-tilt layer of the default profile. */
#define SL1_DELAY_SAFE_S 3.0
#define SL1_DELAY_HV_S 3.5
#define SL1_DELAY_SLOW_MOVE_S 1.0
/* Tower move per layer, seconds per mm of layer (PrusaSlicer 2.5). */
#define SL1_TOWER_S_PER_MM 5.0

double sl1_layer_exposure_s(const struct resin_printer *r, int k)
{
	int fade = r->fade_layers > 0 ? r->fade_layers : 0;
	double step;

	if (k <= SL1_FIRST_EXTRA_LAYERS)
		return r->exposure_first_s;
	if (k > fade + SL1_FIRST_EXTRA_LAYERS)
		return r->exposure_s;
	step = (r->exposure_first_s - r->exposure_s) / (fade + 1);
	return r->exposure_first_s - (k - SL1_FIRST_EXTRA_LAYERS) * step;
}

int sl1_layer_is_slow(const struct resin_printer *r, double area_mm2)
{
	return area_mm2 > r->display_w_mm * r->display_h_mm * r->slow_area_pct / 100.0;
}

double sl1_layer_time_s(const struct resin_printer *r, int k, double height_mm, int slow)
{
	double t = sl1_layer_exposure_s(r, k) + SL1_TOWER_S_PER_MM * height_mm;

	switch (r->print_speed) {
	case RESIN_SPEED_SLOW:
		return t + r->tilt_slow_s + SL1_DELAY_SAFE_S;
	case RESIN_SPEED_HIGH_VISCOSITY:
		return t + r->tilt_hv_s + SL1_DELAY_HV_S;
	default:
		return t + (slow ? r->tilt_slow_s + SL1_DELAY_SLOW_MOVE_S : r->tilt_fast_s);
	}
}

void sl1_timestamp(time_t t, char *out, size_t len)
{
	struct tm tm;

	if (!gmtime_r(&t, &tm)) {
		snprintf(out, len, "1970-01-01 at 00:00:00 UTC");
		return;
	}
	strftime(out, len, "%Y-%m-%d at %H:%M:%S UTC", &tm);
}

static const char *print_speed_name(int s)
{
	return s == RESIN_SPEED_SLOW ? "slow" : s == RESIN_SPEED_HIGH_VISCOSITY ? "high_viscosity"
										  : "fast";
}

/* config.ini expUserProfile: 0 default (fast), 1 safe (slow), 2 superslow. */
static int exp_user_profile(int s)
{
	return s == RESIN_SPEED_SLOW ? 1 : s == RESIN_SPEED_HIGH_VISCOSITY ? 2 : 0;
}

static int is_hollow(const struct out_info *info)
{
	/* every engine but plain slicing leaves cavities in the part */
	return info->engine_name && strcmp(info->engine_name, "solid") != 0;
}

static void print_profile_name(const struct out_info *info, char *out, size_t len)
{
	snprintf(out, len, "%g mm infilld %s", info->layer_mm,
		 info->engine_name ? info->engine_name : "solid");
}

static int nomem(struct err *e, const char *what)
{
	return ERR_SET(e, ERR_NOMEM, "out of memory writing %s", what);
}

int sl1_config_ini(const struct out_info *info, const struct resin_printer *r,
		   const char *job_dir, const struct sl1_summary *sum, struct buf *out,
		   struct err *e)
{
	struct sink s;
	char stamp[40], prof[96];
	int rc;

	sink_init_buf(&s, out);
	sl1_timestamp(info->created, stamp, sizeof stamp);
	print_profile_name(info, prof, sizeof prof);
	rc = sink_printf(&s, NULL,
			 "action = print\n"
			 "jobDir = %s\n"
			 "expTime = %g\n"
			 "expTimeFirst = %g\n"
			 "expUserProfile = %d\n"
			 "layerHeight = %g\n"
			 "layerHeightFirst = %g\n"
			 "numFade = %d\n"
			 "numSlow = %d\n"
			 "numFast = %d\n"
			 "usedMaterial = %.6f\n"
			 "printTime = %.3f\n",
			 job_dir, r->exposure_s, r->exposure_first_s,
			 exp_user_profile(r->print_speed), info->layer_mm, info->layer_mm,
			 r->fade_layers, sum->slow_layers, sum->fast_layers,
			 sum->volume_mm3 / 1000.0, sum->print_time_s);
	if (!rc)
		rc = sink_printf(&s, NULL,
				 "printerModel = %s\n"
				 "printerVariant = %s\n"
				 "printerProfile = %s\n"
				 "printProfile = %s\n"
				 "materialName = %s\n"
				 "fileCreationTimestamp = %s\n"
				 "prusaSlicerVersion = infilld %s\n"
				 "hollow = %d\n",
				 r->model, r->variant, r->profile, prof, r->material, stamp,
				 INFILLD_VERSION, is_hollow(info));
	return rc ? nomem(e, "config.ini") : 0;
}

int sl1_prusaslicer_ini(const struct out_info *info, const struct resin_printer *r,
			struct buf *out, struct err *e)
{
	struct sink s;
	char prof[96];
	double ex = printer_resin_extent_x_mm(r), ey = printer_resin_extent_y_mm(r);
	int rc;

	sink_init_buf(&s, out);
	print_profile_name(info, prof, sizeof prof);
	/* sorted by key, as PrusaSlicer writes its configuration */
	rc = sink_printf(&s, NULL,
			 "area_fill = %g\n"
			 "bed_shape = 0x0,%gx0,%gx%g,0x%g\n"
			 "display_height = %g\n"
			 "display_mirror_x = %d\n"
			 "display_mirror_y = %d\n"
			 "display_orientation = %s\n"
			 "display_pixels_x = %d\n"
			 "display_pixels_y = %d\n"
			 "display_width = %g\n"
			 "exposure_time = %g\n"
			 "faded_layers = %d\n"
			 "fast_tilt_time = %g\n"
			 "gamma_correction = %d\n"
			 "high_viscosity_tilt_time = %g\n"
			 "hollowing_enable = %d\n"
			 "initial_exposure_time = %g\n"
			 "initial_layer_height = %g\n"
			 "layer_height = %g\n",
			 r->slow_area_pct, ex, ex, ey, ey, r->display_h_mm, r->mirror_x ? 1 : 0,
			 r->mirror_y ? 1 : 0, r->portrait ? "portrait" : "landscape", r->pixels_x,
			 r->pixels_y, r->display_w_mm, r->exposure_s, r->fade_layers,
			 r->tilt_fast_s, r->antialias ? 1 : 0, r->tilt_hv_s, is_hollow(info),
			 r->exposure_first_s, info->layer_mm, info->layer_mm);
	if (!rc)
		rc = sink_printf(&s, NULL,
				 "material_print_speed = %s\n"
				 "max_print_height = %g\n"
				 "pad_enable = 0\n"
				 "printer_model = %s\n"
				 "printer_settings_id = %s\n"
				 "printer_technology = SLA\n"
				 "printer_variant = %s\n"
				 "sla_material_settings_id = %s\n"
				 "sla_print_settings_id = %s\n"
				 "slow_tilt_time = %g\n"
				 "supports_enable = 0\n"
				 "thumbnails = 400x400,800x480\n",
				 print_speed_name(r->print_speed), r->max_z_mm, r->model, r->profile,
				 r->variant, r->material, prof, r->tilt_slow_s);
	return rc ? nomem(e, "prusaslicer.ini") : 0;
}

/* A JSON string literal of s (control characters escaped). */
static int json_string(struct sink *s, const char *v)
{
	int rc = sink_write(s, "\"", 1, NULL);

	for (const unsigned char *p = (const unsigned char *)(v ? v : ""); !rc && *p; p++) {
		if (*p == '"' || *p == '\\')
			rc = sink_printf(s, NULL, "\\%c", *p);
		else if (*p < 0x20)
			rc = sink_printf(s, NULL, "\\u%04x", *p);
		else
			rc = sink_write(s, p, 1, NULL);
	}
	return rc ? rc : sink_write(s, "\"", 1, NULL);
}

int sl1_manifest_json(const struct out_info *info, const struct resin_printer *r,
		      const struct raster_map *map, int w_px, int h_px,
		      const struct sl1_summary *sum, struct buf *out, struct err *e)
{
	struct sink s;
	char stamp[40];
	int rc;

	sink_init_buf(&s, out);
	sl1_timestamp(info->created, stamp, sizeof stamp);
	rc = sink_printf(&s, NULL, "{\n  \"format\": \"infilld-png-stack\",\n  \"version\": 1,\n"
				   "  \"producer\": \"infilld %s\",\n  \"created\": \"%s\",\n"
				   "  \"job\": ",
			 INFILLD_VERSION, stamp);
	if (!rc)
		rc = json_string(&s, info->job_name);
	if (!rc)
		rc = sink_printf(&s, NULL, ",\n  \"printer\": ");
	if (!rc)
		rc = json_string(&s, r->model);
	if (!rc)
		rc = sink_printf(
			&s, NULL,
			",\n  \"layers\": %d,\n  \"first_layer_file\": \"1.png\",\n"
			"  \"layer_height_mm\": %.10g,\n"
			"  \"image_width_px\": %d,\n  \"image_height_px\": %d,\n"
			"  \"pixel_um\": [%.10g, %.10g],\n"
			"  \"map_mm_to_px\": {\"u\": [%.10g, %.10g, %.10g], \"v\": [%.10g, %.10g, "
			"%.10g]},\n"
			"  \"antialias\": %s,\n"
			"  \"exposure_s\": %g,\n  \"exposure_first_s\": %g,\n"
			"  \"fade_layers\": %d,\n"
			"  \"material_volume_mm3\": %.3f,\n  \"print_time_s\": %.3f\n}\n",
			sum->layers, info->layer_mm, w_px, h_px,
			1000.0 / hypot(map->a[0][0], map->a[0][1]),
			1000.0 / hypot(map->a[1][0], map->a[1][1]), map->a[0][0], map->a[0][1], map->b[0],
			map->a[1][0], map->a[1][1], map->b[1], r->antialias ? "true" : "false",
			r->exposure_s, r->exposure_first_s, r->fade_layers, sum->volume_mm3,
			sum->print_time_s);
	return rc ? nomem(e, "manifest.json") : 0;
}
