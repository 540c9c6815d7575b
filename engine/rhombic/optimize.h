/* optimize.h - the rhombic engine's design updates (paper 001 section 5):
 * uniform refinement, stiffness (eq. 5-13, optimize.c, with the FEA core
 * of engine/fea/fea.h) and static stability (eq. 14-16, stability.c).
 * docs/rhombic.md sections 5-6.
 */
#ifndef INFILLD_RHOMBIC_OPTIMIZE_H
#define INFILLD_RHOMBIC_OPTIMIZE_H

#include "engine/rhombic/rhombic.h"

struct err;
struct mesh;

/* Solid volume and centre of mass of the part less t's cavities. */
void rh_tree_mass(const struct rh_tree *t, double part_vol, struct vec3 part_moment, double *vol,
		  struct vec3 *com);

struct rh_stab_report {
	struct vec3 com_solid;   /* the solid part's centre of mass (mm) */
	struct vec3 com_initial; /* with the initial cavities */
	struct vec3 com_after;   /* after the refinement */
	struct vec3 hull_center; /* c_h: area centroid of the contact hull (z = 0) */
	size_t hull_points;
	int solid_inside;        /* the solid part's projected centre is inside the hull */
	int inside;              /* the result's is */
	double hull_distance_mm; /* signed distance of the result's to the hull edge (> 0 in) */
	size_t splits;           /* leaves refined */
	int updates;             /* sorts of eq. 16 (one per 2 % of the leaves) */
};

/* Refine t's cavity leaves in ascending order of eq. 16, re-sorting after
 * every 2 % of them, until the projected centre of mass lies inside the
 * convex hull of the first layer's section (or no leaf is left, or the
 * solid fraction reaches max_fraction > 0).  ERR_GEOMETRY when the first
 * layer has no area. */
int rh_stability(struct rh_tree *t, const struct mesh *part, double layer_mm, double max_fraction,
		 struct rh_stab_report *r, struct err *e);

/* Uniform refinement: split every cavity leaf, one whole step at a time,
 * until the solid fraction (part_vol - cavities) / part_vol first reaches
 * target or no cavity is left.  *steps gets the number of steps. */
int rh_uniform(struct rh_tree *t, double part_vol, double target, int *steps, struct err *e);

/* ---- stiffness (optimize.c) ---- */

struct fea_loads;
struct progress;

struct rh_stiff_opts {
	double part_vol_mm3;  /* the solid part's volume (the fractions' denominator) */
	double target;        /* volume fraction not to exceed (eq. 7) */
	double split_pct;     /* share of the leaves split per iteration */
	int max_iterations;
	int adaptive;         /* 0: evaluate t as it is (uniform refinement) */
	double fea_voxel_mm;  /* element edge, > 0 */
	int supersample;      /* cavity sample points per element axis */
	double penal;         /* SIMP exponent of the element densities (fea_opts.penal) */
	double rho_min;       /* density of the cavities' elements (fea_opts.rho_min) */
	double fea_tol;       /* relative residual of the solves that rank the leaves
				 (warm-started); the result's and the solid part's
				 solves reach the FEA's default (1e-6).  0 = that default */
	int binary;           /* eq. 10 at rho_min for every element of S_C (the paper's
				 binary densities) instead of at each element's density */
	int bound;            /* with adaptive: also the lower bound on the compliance of
				 every refinement of the initial structure with the
				 result's material (fea_relax_bound) */
	size_t max_elements;
	int threads;
	struct progress *progress; /* may be NULL */
};

/* One FEA solve of the history (the compliance-vs-volume curve). */
struct rh_stiff_step {
	double fraction;        /* solid volume / part volume */
	double compliance_nmm;
	double max_displacement_mm;
	int cg_iterations;
	double solve_s;
};

struct rh_stiff_report {
	double compliance_nmm;       /* of the result */
	double max_displacement_mm;
	double compliance_solid_nmm; /* the solid part under the same load */
	double max_displacement_solid_mm;
	double fea_voxel_mm;
	size_t elements;             /* present elements */
	int iterations;              /* design updates (adaptive) */
	double solve_s;              /* all solves */
	struct rh_stiff_step *hist;  /* owned (rh_stiff_report_fini), one per solve, the
					solid's last */
	/* o->bound: no refinement of the initial structure with the result's
	 * material (sum of element densities) is more compliant than
	 * bound_nmm (N mm) in this model; 0 when not computed */
	double bound_nmm;
	double bound_upper_nmm;      /* the relaxed design the bound's steps reached */
	int bound_iterations;
	double bound_s;
	size_t nhist, caphist;
};

void rh_stiff_report_fini(struct rh_stiff_report *r);

/* Section 5.1: voxelise the part (fea_voxelize_mesh), densities rho_e =
 * max(part_fraction - cavity_fraction, rho_min) (cavity fraction by
 * supersampling), then, with o->adaptive, iterate: solve (eq. 6), rank
 * the leaves by G_C (eq. 10-13: the energy sensitivity per volume of the
 * material S_C their split adds), split the top split_pct % one by one,
 * stop as soon as the next split would pass o->target.  Ends with the
 * solid part's solve, then, with o->bound, the bound (its floor: the
 * densities of the initial structure; ceiling: the solid part's; budget:
 * the result's sum; the load vector of the stiffness solves).  Errors of
 * the FEA core (ERR_PARAM "loads" for a load box without material,
 * ERR_LIMIT "fea_voxel_mm") pass through. */
int rh_stiffness(struct rh_tree *t, const struct mesh *part, const struct fea_loads *loads,
		 const struct rh_stiff_opts *o, struct rh_stiff_report *r, struct err *e);

#endif
