/* opt.h - the optimiser of paper 004 (engine/hollow/opt/): repeated rounds
 * of uniform offset -> optimisation slices -> loops -> groups -> strips ->
 * support-free offset optimisation -> voids, the solid of one round the
 * input of the next (sections 3-8 and 7.2).  The hollow engine's
 * orchestration (engine/hollow/run.c) runs it before the pixel fill
 * (engine/hollow/fill/fill.h).  Design: docs/hollow.md "Pipeline".
 * Frame: printer frame, mm, z up.
 */
#ifndef INFILLD_HOLLOW_OPT_H
#define INFILLD_HOLLOW_OPT_H

#include <stddef.h>

struct mesh;
struct progress;
struct err;
struct hull_pt;

enum hl_objective { HL_OBJ_LIGHTWEIGHT = 0, HL_OBJ_STABILITY = 1 };

struct hl_opt_params {
	double wall_mm;        /* offset t of round 1 (shell to the outside) */
	double wall_next_mm;   /* offset of later rounds (walls between voids) */
	double opt_layer_mm;   /* h of the optimisation (snapped to the stack); with
				* opt_layer_min_mm > 0 the thickest slice */
	double opt_layer_min_mm; /* > 0: adaptive slices between this (snapped to
				  * the stack) and opt_layer_mm (slices.c); 0:
				  * every slice opt_layer_mm thick */
	int smooth_passes;     /* section 6's P -> P~: a void that ends early is
				* built again from its loops smoothed by this many
				* truncated Laplacian passes, kept if larger (0: never) */
	double stack_layer_mm; /* layer height of the eroded stack */
	double pixel_mm;       /* erosion grid pitch */
	double sample_mm;      /* loop sampling step s; 0: derived for each slice
				* from its thinner slab (hl_sample_mm) */
	double alpha_rad;      /* overhang limit, from the vertical */
	double print_layer_mm; /* the print layer: a void's flat top may reach
				* print_layer_mm tan alpha from its edge (0: not checked) */
	double margin_rad;     /* safety subtracted from alpha in the constraints */
	double min_void_mm3;   /* smaller voids are dropped */
	int rounds;            /* at most this many rounds (0: none, the part copied) */
	double optimise_work;  /* work budget, reference seconds: each solve's Ipopt
				* iterations priced by a fixed formula of its problem's
				* size (rounds.c iter_cost_s), summed over solves and
				* rounds.  Every void of a round gets the same iteration
				* cap, the budget left over the round's price per
				* iteration, so what is solved does not depend on time,
				* load or threads; later rounds start while some is
				* left; 0 = none */
	double optimise_s;     /* wall-clock guard (s, from hl_opt_run's start): voids
				* not solved in it keep their support-free start,
				* later rounds do not start; 0 = none */
	int threads;           /* solver processes */
	enum hl_objective objective;
	double light_weight;   /* stability: weight of the lightweight term */
	/* stability: the convex counter-clockwise region (printer mm) the
	 * centre of mass must reach (borrowed); fewer than 3 points: the
	 * voids are optimised for weight alone */
	const struct hull_pt *target;
	size_t ntarget;
};

struct hl_opt_stats {
	int rounds;               /* rounds whose voids were kept */
	int budget_spent;         /* optimise_s (the wall clock) cut the rounds short */
	int work_spent;           /* optimise_work capped a round's solves or ended
				   * the rounds */
	double work_s;            /* solver work done, reference seconds (optimise_work) */
	size_t voids;             /* kept (optimised, or at their support-free start) */
	size_t voids_fallback;    /* of them: kept at their support-free start */
	size_t loops;             /* optimisation loops, all rounds (0: nothing inside
				   * the offset wide enough to sample) */
	size_t groups_failed;     /* optimised groups dropped (check failed, or a
				   * flat top wider than the print layers bridge) */
	size_t groups_small;      /* dropped: below min_void_mm3 */
	size_t groups_unbuilt;    /* runs of a chain no support-free strip joined
				   * (their top pair fails: docs/hollow.md limit 1) */
	size_t voids_too_close;   /* dropped: within wall_next_mm of a larger void */
	size_t voids_against_com; /* stability: dropped because they moved the centre
				   * of mass away from the target */
	double volume_mm3;        /* of the kept voids */
	double opt_layer_mm;      /* h actually used (a whole number of stack layers);
				   * adaptive: the thickest allowed */
	size_t slices;            /* optimisation slices (round 1's plan) */
	double opt_layer_min_used_mm; /* thinnest slab between two slices */
	double sample_mm;
	int iterations;           /* Ipopt iterations, all voids and rounds */
	double s_offset, s_groups, s_solve, s_mesh; /* seconds */
};

/* Hollow the placed, closed mesh part with the optimiser.  *out (a new
 * mesh, caller frees) is the part's surface followed by the kept voids'
 * surfaces (turned inward); the part copied when nothing was kept.  *st
 * is overwritten.  prog (may be NULL) moves from 0 to 1 over the rounds
 * and can cancel.  Returns 0, ERR_NOMEM, ERR_CANCELLED, ERR_LIMIT (too
 * many layers, grid too large) or an error of the slicer (*out NULL). */
int hl_opt_run(const struct mesh *part, const struct hl_opt_params *p, struct progress *prog,
	       struct mesh **out, struct hl_opt_stats *st, struct err *e);

/* The derived sampling step (mm) for slabs h_mm thick: h tan(alpha -
 * margin) / 2, so zigzag cross edges can meet eq. 5, clamped to
 * 0.1..0.5 mm. */
double hl_sample_mm(double h_mm, double alpha_rad, double margin_rad);

/* Volume (mm^3) and centre of mass (mm) of a closed, outward mesh
 * (mesh_mass, divided out; 0 for a mesh of no volume). */
void hl_mesh_mass(const struct mesh *m, double *vol, double com[3]);

#endif
