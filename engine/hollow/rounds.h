/* rounds.h - the hollowing pipeline of paper 004 over repeated rounds
 * (rounds.c): uniform offset -> slices -> loops -> groups -> strips ->
 * optimisation -> voids, the solid of one round being the input of the
 * next (section 7.2).  Design: docs/hollow.md.
 */
#ifndef INFILLD_HOLLOW_ROUNDS_H
#define INFILLD_HOLLOW_ROUNDS_H

#include <stddef.h>

#include "engine/geom/hull.h"
#include "engine/hollow/nlp.h"
#include "engine/hollow/topdown.h"

struct mesh;
struct progress;
struct err;

struct hl_config {
	double wall_mm;        /* first offset t (shell to the outside) */
	double wall_next_mm;   /* offset of later rounds (walls between voids) */
	double opt_layer_mm;   /* h of the optimisation (snapped to the stack) */
	double stack_layer_mm; /* layer height of the eroded stack */
	double pixel_mm;       /* erosion grid pitch */
	double sample_mm;      /* loop sampling step s */
	double alpha_rad;      /* overhang limit, from the vertical */
	double margin_rad;     /* safety subtracted from alpha in the constraints */
	double min_void_mm3;
	int rounds;            /* at most this many rounds */
	double optimise_s;     /* time budget of the rounds (s, from hl_run's start);
				* voids not solved in it keep their support-free
				* start, later rounds do not start; 0 = none */
	int threads;
	enum hl_objective objective;
	double light_weight;   /* stability: weight of the lightweight term */
	double print_layer_mm; /* the job's layer (contact layer for stability) */
	int fill;              /* lightweight: top-down fill of what the optimiser left */
	int fill_lean;         /* fill: walls between voids lean (else they stand) */
	struct raster_map fill_map; /* printer mm -> pixels of the images the verifier reads */
	int fill_map_set;      /* fill_map is set (else no fill) */
	int fill_keep_set;     /* the fill keeps to the half-plane below (hl_run sets it
				* for stability; callers leave it 0) */
	double fill_keep[3];   /* pixel centre (x, y) in printer mm may be void only
				* where keep[0] x + keep[1] y < keep[2] */
};

struct hl_outcome {
	struct mesh *mesh;        /* outer surface + void surfaces (owned) */
	int rounds;               /* rounds whose voids are in the output (0: fill alone kept) */
	int budget_spent;         /* the optimise_s budget cut the rounds short */
	size_t voids;             /* optimised (mesh) voids + fill components */
	size_t voids_optimised;   /* of them: made by the optimiser (or its start) */
	size_t voids_fallback;    /* voids kept at their support-free start */
	size_t groups_failed;     /* optimised groups dropped (check failed) */
	size_t groups_small;      /* dropped: below min_void_mm3 */
	size_t voids_too_close;   /* dropped: within wall_next_mm of a larger void */
	size_t voids_against_com; /* stability: optimised voids dropped because they
				   * moved the centre of mass away from the target */
	double part_volume_mm3;
	double void_volume_mm3;
	double opt_volume_mm3;    /* of the optimised voids (before the choice below) */
	/* lightweight with the fill: the fill alone's volume (0 when not
	 * built: no optimised void), the optimised voids and the fill around
	 * them together, and the optimised voids dropped because the fill
	 * alone hollows more */
	double fill_alone_mm3;
	double opt_fill_mm3;
	size_t voids_dropped_for_fill;
	struct hl_fill fill;      /* top-down fill (topdown.h); empty when off */
	double opt_layer_mm;      /* h actually used */
	double sample_mm;
	int iterations;           /* Ipopt iterations, all voids and rounds */
	double s_offset, s_contours, s_groups, s_solve, s_mesh, s_fill; /* seconds */
	char note[256];           /* "" or why nothing was hollowed */
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

/* Volume (mm^3) and centre of mass (mm) of a closed, outward mesh
 * (mesh_mass, divided out; 0 for a mesh of no volume). */
void hl_mesh_mass(const struct mesh *m, double *vol, double com[3]);


#endif
