/* gcode_int.h - internal to gcode_*.c: the G-code writer's pieces.
 *
 * gcode_write.c is the writer (gcode_writer_ops: layer window, parallel
 * planning, header, start/end code, footer, metrics); gcode_format.c
 * turns a planned layer into G-code text (number formatting, flow);
 * gcode_spool.c holds the body until the header's totals are known.
 * Design: docs/gcode.md.
 */
#ifndef INFILLD_GCODE_INT_H
#define INFILLD_GCODE_INT_H

#include <stdint.h>
#include <stdio.h>

#include "engine/core/sink.h"
#include "engine/output/printer/printer.h"
#include "engine/output/toolpath/toolpath.h"

/* E is counted in integer units of 1e-5 mm of filament (the printed
 * resolution) so every total is the exact sum of the printed values. */
#define GC_E_PER_MM 100000

/* Constants of a job the formatter needs. */
struct gc_params {
	const struct fdm_printer *f;
	double filament_area_mm2; /* pi d^2 / 4 */
	int hop;                  /* z_hop_mm > 0 */
};

/* One formatted layer body and its figures. */
struct gc_layer_out {
	struct buf text;
	int64_t e_units[TP_ROLE_COUNT]; /* extruded filament per role */
	double extrude_mm;              /* extrusion path length */
	double travel_mm;
	long retractions;
	int64_t lo_x_um, lo_y_um, hi_x_um, hi_y_um; /* extrusion bounds */
	int has_extrusion;
	struct pt2 first, last; /* nozzle at the body's start and end, nm */
	int has_moves;
};

void gc_layer_out_init(struct gc_layer_out *o);
void gc_layer_out_fini(struct gc_layer_out *o);

/* Format plan p (printed at z_mm, layer height h_mm) as a G-code body that
 * starts with the nozzle at the plan's first point, primed, and ends
 * after its last extrusion.  Relative E (M83).  0 or ERR_NOMEM. */
int gc_format_layer(const struct gc_params *g, const struct tp_plan *p, double z_mm, double h_mm,
		    struct gc_layer_out *o, struct err *e);

/* Number text: v / 10^dec with trailing zeros (and a bare '.') removed,
 * "-" for negatives, a leading "0" kept.  Returns the length written
 * (at most 24 bytes, no NUL). */
size_t gc_fmt_fixed(char *dst, int64_t v, int dec);
/* mm given in double, at 1 um resolution. */
size_t gc_fmt_mm(char *dst, double mm);

/* ---- spool (gcode_spool.c) --------------------------------------------- */

/* An append-only store for the G-code body: memory up to a threshold,
 * then an unlinked temporary file in dir.  Besides text it records
 * progress marks that become "M73 P<pct> R<min>" lines on replay, once
 * the total time is known. */
struct gc_spool {
	struct buf mem;
	FILE *file;
	const char *dir;
	size_t mem_max;
	uint64_t bytes; /* text bytes held */
};

void gc_spool_init(struct gc_spool *s, const char *dir, size_t mem_max);
void gc_spool_fini(struct gc_spool *s);
int gc_spool_text(struct gc_spool *s, const void *p, size_t n, struct err *e);
/* A progress mark: elapsed_s of printing done when the printer gets here. */
int gc_spool_mark(struct gc_spool *s, double elapsed_s, struct err *e);
/* Write everything to out, marks as M73 lines for a print of total_s
 * seconds of which offset_s come before the spooled part. */
int gc_spool_replay(struct gc_spool *s, struct sink *out, double offset_s, double total_s,
		    struct err *e);
/* "M73 P<pct> R<min>\n" into dst (>= 32 bytes); returns its length. */
size_t gc_m73(char *dst, double elapsed_s, double total_s);

#endif
