/* run.h - the hollow engine's pipeline (run.c): the paper's optimiser
 * (opt/opt.h) over repeated rounds, then the top-down pixel fill
 * (fill/fill.h) of what it left, and for the stability objective the
 * centre-of-mass bookkeeping around both.  Design: docs/hollow.md.
 */
#ifndef INFILLD_HOLLOW_RUN_H
#define INFILLD_HOLLOW_RUN_H

#include <stddef.h>

#include "engine/geom/raster.h"
#include "engine/hollow/fill/fill.h"
#include "engine/hollow/opt/opt.h"

struct mesh;
struct progress;
struct err;

/* What the job asks for (engine/hollow/hollow.c fills it from the job's
 * parameters); run.c derives the fill's own parameters from it. */
struct hl_config {
	struct hl_opt_params opt;  /* the optimiser's rounds (opt.target: left NULL, run.c
				    * sets the stability target); the fill takes its
				    * walls, pixel, alpha, margin and min_void_mm3 */
	double print_layer_mm;     /* the job's layer (the fill's layers; contact
				    * layer for stability) */
	int fill;                  /* top-down fill of what the optimiser left */
	int fill_lean;             /* fill: walls between voids lean (else they stand) */
	int fill_corners;          /* fill: convex void corners grow square (with fill_lean) */
	struct raster_map fill_map; /* printer mm -> pixels of the images the verifier reads */
	int fill_map_set;          /* fill_map is set (else no fill) */
};

struct hl_outcome {
	struct mesh *mesh;        /* outer surface + the kept optimised voids' surfaces (owned) */
	int rounds;               /* rounds whose voids are in the output (0: fill alone kept) */
	size_t voids;             /* voids in the output: optimised + fill components */
	size_t voids_optimised;   /* of them: made by the optimiser (or its start) */
	size_t voids_fallback;    /* of those: kept at their support-free start */
	struct hl_opt_stats opt;  /* the optimiser's own record (its voids may have
				   * been dropped below for the fill alone) */
	double part_volume_mm3;
	double void_volume_mm3;   /* of the voids in the output */
	/* lightweight with the fill: the fill alone's volume (0 when not
	 * built: no optimised void), the optimised voids and the fill around
	 * them together, and the optimised voids dropped because the fill
	 * alone hollows more */
	double fill_alone_mm3;
	double opt_fill_mm3;
	size_t voids_dropped_for_fill;
	struct hl_fill fill;      /* top-down fill; empty when off */
	double s_fill;            /* seconds in the fill */
	char note[384];           /* "" or why nothing was hollowed */
	/* stability */
	int has_com;
	double com_before_mm;     /* signed distance to the contact hull, > 0 inside */
	double com_after_mm;
	int com_inside;           /* after: inside the offset hull H_r */
	double hull_offset_mm;    /* r, half the inscribed radius */
	int stands_before;
};

void hl_outcome_fini(struct hl_outcome *o);

/* Hollow the placed, closed mesh part (printer frame, mm).  On success
 * *o holds the result (o->mesh never NULL: the part itself, copied, when
 * nothing could be hollowed, with o->note saying why).  prog may be NULL.
 * Returns 0, ERR_NOMEM, ERR_CANCELLED, ERR_LIMIT (grid too large) or an
 * error of the slicer. */
int hl_run(const struct mesh *part, const struct hl_config *c, struct progress *prog,
	   struct hl_outcome *o, struct err *e);

#endif
