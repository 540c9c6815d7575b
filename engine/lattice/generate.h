/* generate.h - a graded, self-supporting lattice for a placed mesh.
 *
 * The whole of paper 000 section 5 behind one call: density field ->
 * raw tetrahedral lattice (for the Table 3 baseline) -> SO lattice -> PO
 * -> density matching -> independent density measurement.  Each stage's
 * figures go to struct lattice_gen_report (the engine's metrics).
 */
#ifndef INFILLD_LATTICE_GENERATE_H
#define INFILLD_LATTICE_GENERATE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/lattice/density.h"
#include "engine/lattice/lattice.h"

struct err;
struct mesh;
struct progress;

struct lattice_gen_opts {
	const struct lattice_density *density; /* target solid fraction */
	double min_radius_mm;   /* r_min; struts start at 2 r_min */
	double so_k;            /* SO factor (1 = none) */
	int po;                 /* run vertex position optimisation */
	int po_rounds;          /* at most (paper: 100) */
	int match;              /* density matching (else uniform 2 r_min struts) */
	int max_subdiv;
	int mc_samples;
	int match_passes;
	double voxel_mm;        /* 0 = 1.5 x the spacing at the mean density */
	double support_factor;  /* R = factor * largest radius */
	double alpha_rad;       /* self-supporting angle */
	int raw_baseline;       /* also build the k = 1 lattice for gamma_raw */
	size_t max_nodes;
	uint64_t seed;
	int threads;
	struct progress *progress; /* may be NULL; stages are reported as fractions */
};

struct lattice_gen_report {
	double gamma_raw, gamma_so, gamma_so_po; /* eq. 13, one radius (Table 3) */
	double psi_raw, psi_so, psi_so_po;       /* eq. 14 */
	double gamma_final, psi_final;           /* after matching (its subdivision) */
	size_t raw_nodes, raw_struts;
	size_t surface_nodes, interior_nodes, tets;
	int po_rounds;
	size_t po_moves;
	size_t subdivided_tets, voxels;
	double voxel_mm;
	double density_error_mean, density_error_max; /* independent measurement */
	double s_raw, s_sample, s_tetgen, s_po, s_match, s_measure; /* seconds */
};

/* Generate into *out (caller frees).  m: the placed, repaired part
 * (printer frame, mm); open meshes work (generalised winding number). */
int lattice_generate(const struct mesh *m, const struct lattice_gen_opts *o,
		     struct lattice **out, struct lattice_gen_report *rep, struct err *e);

#endif
