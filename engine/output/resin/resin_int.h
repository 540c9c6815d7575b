/* resin_int.h - internal to engine/output/resin/ (sl1_ini.c): the text records of resin archives and the
 * print-time model.
 *
 * config.ini (what the SL1/SL1S firmware reads), prusaslicer.ini (what
 * PrusaSlicer and UVtools need to re-open the archive), manifest.json
 * of generic PNG-stack zips, the jobDir name, and the per-layer exposure
 * and time model behind printTime.  Key by key: docs/formats.md.  Not
 * included outside engine/output/.
 */
#ifndef INFILLD_OUTPUT_RESIN_INT_H
#define INFILLD_OUTPUT_RESIN_INT_H

#include <stddef.h>

#include "engine/output/output.h"
#include "engine/output/printer/printer.h"

struct buf;
struct err;

/* Figures gathered while the layers were written. */
struct sl1_summary {
	int layers;
	int slow_layers, fast_layers; /* by area, see sl1_layer_time_s() */
	double volume_mm3;            /* sum of coverage * pixel area * layer height */
	double print_time_s;          /* sum of sl1_layer_time_s() */
	double max_area_mm2;          /* largest layer */
};

/* Longest jobDir we write (without the NUL): out_job_dir(). */
#define SL1_JOB_DIR_MAX OUT_JOB_DIR_MAX

/* The firmware's exposure schedule: layers 0-2 expose exposure_first_s,
 * the next fade_layers fall linearly towards exposure_s, then exposure_s. */
double sl1_layer_exposure_s(const struct resin_printer *r, int k);

/* Seconds to print layer k (0-based) of height_mm: exposure, tilt (slow
 * when the layer is slow or the profile asks for it) and its delay, and
 * the tower move.  docs/formats.md gives the constants' sources. */
double sl1_layer_time_s(const struct resin_printer *r, int k, double height_mm, int slow);

/* Whether a layer of area_mm2 needs the slow tilt. */
int sl1_layer_is_slow(const struct resin_printer *r, double area_mm2);

/* Append config.ini / prusaslicer.ini / manifest.json.  0 or ERR_NOMEM. */
int sl1_config_ini(const struct out_info *info, const struct resin_printer *r,
		   const char *job_dir, const struct sl1_summary *sum, struct buf *out,
		   struct err *e);
int sl1_prusaslicer_ini(const struct out_info *info, const struct resin_printer *r,
			struct buf *out, struct err *e);
int sl1_manifest_json(const struct out_info *info, const struct resin_printer *r,
		      const struct raster_map *map, int w_px, int h_px,
		      const struct sl1_summary *sum, struct buf *out, struct err *e);

/* "YYYY-MM-DD at HH:MM:SS UTC" (out: at least 32 bytes). */
void sl1_timestamp(time_t t, char *out, size_t len);

#endif
