/* toolpath.h - internal: FDM toolpath planning for the G-code writer.
 *
 * Turns one layer's material region (integer nm, layer.h) and the
 * regions of its neighbours into an ordered list of extrusion paths:
 * skirt, perimeters, thin walls and gap fill, solid skins and sparse
 * infill, with the travel decisions between them.  Planning only: no
 * G-code text here (gcode_write.c formats).  Design: docs/gcode.md.
 * Not included outside engine/output/.
 */
#ifndef INFILLD_TOOLPATH_H
#define INFILLD_TOOLPATH_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/slice/layer.h"

struct err;
struct fdm_printer;

/* Extrusion roles, named as PrusaSlicer's ;TYPE: comments. */
enum tp_role {
	TP_ROLE_SKIRT,
	TP_ROLE_EXT_PERIMETER, /* outermost loops and thin walls */
	TP_ROLE_PERIMETER,
	TP_ROLE_GAP_FILL,
	TP_ROLE_SPARSE,        /* "Internal infill" */
	TP_ROLE_SOLID,
	TP_ROLE_TOP,           /* solid infill on an exposed top surface */
	TP_ROLE_BRIDGE,        /* solid infill over air */
	TP_ROLE_COUNT
};

/* ";TYPE:" text of a role ("External perimeter"...). */
const char *tp_role_name(enum tp_role r);
/* Metric key fragment of a role ("external_perimeter"...). */
const char *tp_role_key(enum tp_role r);

/* Planner settings derived from a printer profile and the job's layer
 * height.  Lengths in nm, speeds in mm/s. */
struct tp_config {
	int64_t width_nm;              /* bead width w (line_width_mm) */
	int64_t nozzle_nm;
	double layer_mm, first_layer_mm;
	int perimeters, top_layers, bottom_layers;
	double infill_frac;            /* sparse density, 0..1 */
	double infill_angle_rad;
	int external_first, seam_rear;
	int64_t min_travel_retract_nm;
	int skirt_loops;
	int64_t skirt_distance_nm;
	int64_t clean_nm;              /* region simplification tolerance */
	double speed_mm_s[TP_ROLE_COUNT];
	double first_layer_speed_mm_s;
	struct pt2 bed_lo, bed_hi;     /* printable bed, nm */
};

/* Can printer f print layers of layer_mm (mm; the first layer is f's own
 * first_layer_mm)?  At most 80 % of the nozzle, under the line width.
 * 0, or ERR_PARAM (field "layer_mm") saying which limit it passes. */
int tp_config_check(const struct fdm_printer *f, double layer_mm, struct err *e);

/* Derive c from printer f and the layer height the job prints with.
 * ERR_PARAM (field "layer_mm") when that height cannot be printed with
 * f's nozzle and line width (tp_config_check). */
int tp_config_init(struct tp_config *c, const struct fdm_printer *f, double layer_mm,
		   struct err *e);

/* Bead spacing of the Slic3r flow model: beads of width w and height h
 * (a rectangle with semicircular sides) laid side by side so their
 * cross-sections tile the plane: s = w - h (1 - pi/4).  nm. */
int64_t tp_spacing_nm(int64_t width_nm, double height_mm);
/* Cross-section area of that bead, mm^2: (w - h) h + pi (h/2)^2. */
double tp_bead_area_mm2(double width_mm, double height_mm);

struct tp_path {
	uint8_t role;      /* enum tp_role */
	uint8_t closed;    /* a loop: extrude back to the first point */
	uint8_t retract;   /* the travel to this path's start retracts (and hops) */
	int16_t depth;     /* loop depth (0 = outermost), -1 for open paths */
	int64_t width_nm;  /* bead width, when seg_w is SIZE_MAX */
	double speed_mm_s; /* feed while extruding */
	size_t first, n;   /* points pts[first .. first + n - 1] */
	size_t seg_w;      /* SIZE_MAX, or index into tp_plan.seg_w of the n - 1
			      (n when closed) per-segment widths */
};

/* One layer's toolpaths in print order. */
struct tp_plan {
	struct tp_path *paths;
	size_t npaths, cap_paths;
	struct pt2 *pts;
	size_t npts, cap_pts;
	int64_t *seg_w;
	size_t nseg_w, cap_seg_w;
	double speed_factor;   /* <= 1: layer-time slowdown applied to extrusions */
	double min_speed_mm_s; /* ... never below this (nor above a path's own speed) */
	/* Thin material (narrower than a line width) found on this layer. */
	int thin_regions;          /* pieces printed as thin walls / gap fill */
	int thin_dropped;          /* pieces too thin to print (< layer height wide) */
	double thin_dropped_mm2;
};

void tp_plan_init(struct tp_plan *p);
void tp_plan_fini(struct tp_plan *p);
void tp_plan_reset(struct tp_plan *p); /* empty, memory kept */

/* Width of segment k of path pa (from point k to k + 1), nm. */
static inline int64_t tp_seg_width(const struct tp_plan *p, const struct tp_path *pa, size_t k)
{
	return pa->seg_w == SIZE_MAX ? pa->width_nm : p->seg_w[pa->seg_w + k];
}

/* Most skin layers a profile may ask for (printer_fdm.c's table limit). */
#define TP_WINDOW_MAX 100

/* What the planner sees of one layer.  Skins come from the exposed parts
 * of the layers around it (docs/gcode.md, "skins"): top[j] is the part of
 * layer index + j that the layer above it does not cover (all of it for
 * the last layer), bottom[j] the part of layer index - j that the layer
 * below does not cover (all of it on the bed).  A point of this layer
 * needs a solid skin exactly when it lies in one of top[0..top_layers) or
 * bottom[0..bottom_layers).  All borrowed and read-only (planned
 * concurrently); ntop/nbottom stop at the part's last and first layers
 * (past them no exposure is missed: see toolpath_regions.c). */
struct tp_layer_in {
	int index, count;
	double height_mm;                  /* printed height of this layer */
	enum layer_fill fill;
	const struct paths *region;        /* material, normalised, nm */
	const struct paths *const *top;    /* top[0] = this layer's own top */
	const struct paths *const *bottom; /* bottom[0] = this layer's own bottom */
	int ntop, nbottom;
	struct pt2 start;                  /* nozzle position the ordering starts at */
};

/* The exposure of region r towards a neighbour layer: r minus other
 * (all of r when other is NULL: no layer there).  Into out (replaced).
 * 0, ERR_NOMEM or ERR_INTERNAL. */
int tp_exposure(const struct paths *r, const struct paths *other, struct paths *out,
		struct err *e);

/* Plan layer `in` into out (reset first).  Output order: skirt (layer 0),
 * then island by island (nearest first): perimeters (inner loops first
 * unless c->external_first), thin walls, gap fill, then sparse, bridge,
 * solid and top infill.  0, ERR_NOMEM or ERR_INTERNAL (Clipper). */
int tp_plan_layer(const struct tp_config *c, const struct tp_layer_in *in, struct tp_plan *out,
		  struct err *e);

/* Simplify a region in place before planning (Douglas-Peucker per loop):
 * every dropped vertex lies within c->clean_nm of the new outline
 * (docs/gcode.md counts it in the containment tolerance); loops that
 * collapse are dropped.  Simplifying a normalised region can, in rare
 * near-touching cases, make loops touch; the planner's offsets
 * re-normalise.  0 or ERR_NOMEM. */
int tp_region_clean(const struct tp_config *c, struct paths *region, struct err *e);

/* ---- Walking a plan: the primitive moves the printer makes ----------- */

enum tp_ev_kind {
	TP_EV_RETRACT,   /* pull filament back (retract_mm) */
	TP_EV_HOP_UP,    /* lift by z_hop_mm (only when hops are on) */
	TP_EV_TRAVEL,    /* move to `to` without extruding */
	TP_EV_HOP_DOWN,
	TP_EV_UNRETRACT,
	TP_EV_FEATURE,   /* a path starts: role, speed_mm_s */
	TP_EV_EXTRUDE    /* extrude a straight bead to `to`, width_nm wide */
};

struct tp_ev {
	enum tp_ev_kind kind;
	struct pt2 to;
	int64_t width_nm;
	enum tp_role role;
	double speed_mm_s;
};

/* Pull iterator over a plan.  Starts at the first path's first point with
 * the filament primed (the layer change positions the nozzle there); the
 * caller supplies `hop` (z_hop_mm > 0).  Speeds already include the
 * plan's speed_factor. */
struct tp_cursor {
	const struct tp_plan *plan;
	int hop;
	size_t path, pt;  /* next path / point within it */
	int stage;
};

void tp_cursor_init(struct tp_cursor *cu, const struct tp_plan *p, int hop);
/* Next event into *ev; 0 at the end. */
int tp_cursor_next(struct tp_cursor *cu, struct tp_ev *ev);

/* First point of the plan (where the layer starts), 0 if the plan is
 * empty. */
int tp_plan_start(const struct tp_plan *p, struct pt2 *at);
/* Last point the nozzle reaches, 0 if the plan is empty. */
int tp_plan_end(const struct tp_plan *p, struct pt2 *at);

/* ---- Motion: time estimate (toolpath_motion.c) ------------------------- */

/* Trapezoidal-profile time estimate of a move sequence (docs/gcode.md).
 * Moves between two stops are planned together: junction speeds from the
 * jerk limit, then a backward and a forward pass so each move can reach
 * its exit speed within accel_mm_s2, then each move's trapezoid (or
 * triangle) time.  Buffers the moves since the last stop. */
struct tp_motion {
	double accel_mm_s2, jerk_mm_s;
	double time_s;          /* everything flushed so far */
	double extrude_s;       /* ... of which extruding moves */
	struct tp_move *moves;  /* pending moves since the last stop */
	size_t n, cap;
};

void tp_motion_init(struct tp_motion *m, double accel_mm_s2, double jerk_mm_s);
void tp_motion_fini(struct tp_motion *m);
/* Queue a straight move of (dx, dy, dz) mm at feed v mm/s (extrude: it
 * deposits material).  0 or ERR_NOMEM. */
int tp_motion_move(struct tp_motion *m, double dx, double dy, double dz, double v_mm_s,
		   int extrude, struct err *e);
/* Come to rest (retraction, dwell, end of layer): plans the pending moves
 * and adds extra_s (a stationary move such as a retraction). */
void tp_motion_stop(struct tp_motion *m, double extra_s);

/* Seconds to print plan p (starting at rest at its first point) with the
 * machine of c/f: travels, hops and retractions included.  Extrusion
 * seconds (the part a layer-time slowdown can stretch) in *extrude_s. */
int tp_plan_time(const struct tp_plan *p, const struct fdm_printer *f, double *total_s,
		 double *extrude_s, struct err *e);

/* Scale the plan's extrusion speeds so it takes at least min_layer_time_s,
 * never below min_print_speed_mm_s (PrusaSlicer's slowdown_below_layer_time).
 * Sets p->speed_factor; *time_s gets the new estimate. */
int tp_plan_slowdown(struct tp_plan *p, const struct fdm_printer *f, double *time_s,
		     struct err *e);

#endif
