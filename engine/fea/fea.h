/* fea.h - linear elasticity on a voxel grid (the FEA core of rhombic and
 * hybrid, and of `infilld fea`).
 *
 * Model: a regular grid of nx * ny * nz trilinear hex8 elements of edge
 * h_mm, element (i, j, k) spanning [lo + (i, j, k) h, lo + (i+1, j+1, k+1) h]
 * in the printer frame (mm, z up).  Nodes are (nx+1) * (ny+1) * (nz+1),
 * node (i, j, k) at index n = (k * (ny+1) + j) * (nx+1) + i, x fastest;
 * its three unknowns (displacement in mm along x, y, z) are 3n, 3n+1, 3n+2.
 * Elements are indexed e = (k * ny + j) * nx + i, x fastest.
 *
 * Each element has a density rho_e: 0 = no element (outside the part: it
 * adds nothing, and nodes touching no element are not unknowns), else
 * clamped to [rho_min, 1]; its stiffness is rho_e^p K0 (SIMP, p = 3), K0
 * the 24 x 24 stiffness of a solid hex8 of edge h_mm (2x2x2 Gauss) for an
 * isotropic material (E_mpa, nu).  Units: mm, N, MPa (N/mm2), so
 * displacements are mm, compliance f.u is N mm, stresses MPa.
 *
 * Solver: conjugate gradients preconditioned by one geometric multigrid
 * V-cycle (Wu, Dick & Westermann 2016): the finest level matrix-free (K0
 * scaled per element), coarser levels Galerkin operators P^T A P of
 * trilinear prolongation with fixed unknowns masked, damped Jacobi
 * smoothing, a banded Cholesky (LAPACK dpbtrf) on the coarsest level.
 * Design and figures: docs/fea.md.
 */
#ifndef INFILLD_FEA_H
#define INFILLD_FEA_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;
struct mesh;

#define FEA_PENAL 3.0     /* SIMP exponent p */
#define FEA_RHO_MIN 0.001 /* lower clamp of a present element's density */

/* Material defaults (docs/fea.md): PLA and a standard resin. */
#define FEA_PLA_E_MPA 3500.0
#define FEA_PLA_NU 0.36
#define FEA_RESIN_E_MPA 2500.0
#define FEA_RESIN_NU 0.40

struct fea_material {
	double E_mpa; /* Young's modulus of the solid material, MPa, > 0 */
	double nu;    /* Poisson's ratio, in (-1, 0.5) */
};

/* Where a constraint or a force applies.  FEA_AT_BOX: box_mm is
 * {x0, y0, z0, x1, y1, z1} in mm from the placed part's bounding-box
 * minimum corner (fea_grid.part_lo_mm), bounds inclusive; a node belongs
 * when it lies in the box and touches an element.  FEA_AT_PLATE: the
 * nodes on the part's bottom face (z = part_lo.z, within half a voxel)
 * that touch an element: where the part sits on the build plate.
 * FEA_AT_TOP: the nodes within the part's top 1 mm (z >= part_hi.z - 1). */
enum fea_at { FEA_AT_BOX = 0, FEA_AT_PLATE, FEA_AT_TOP };

#define FEA_AXIS_X 1u
#define FEA_AXIS_Y 2u
#define FEA_AXIS_Z 4u

struct fea_fix {
	enum fea_at at;
	double box_mm[6];
	unsigned axes; /* FEA_AXIS_* bits: the constrained directions */
};

struct fea_force {
	enum fea_at at;
	double box_mm[6];
	double force_n[3]; /* total force in N, spread over the box's nodes in proportion
			      to the stiffness (sum of rho^p) of the elements each touches */
};

/* A load case.  Arrays owned (fea_loads_fini). */
struct fea_loads {
	struct fea_material material;
	struct fea_fix *fixed;
	size_t nfixed;
	struct fea_force *forces;
	size_t nforces;
};

/* The default case: material (E_mpa, nu) as given, "plate" fixed in xyz,
 * 1000 N down on "top".  0 or ERR_NOMEM. */
int fea_loads_default(struct fea_loads *l, struct fea_material mat, struct err *e);
/* Parse the engine's text form of a load case (what api/ and service/
 * convert the JSON object to; docs/fea.md gives the grammar):
 *   material E_mpa=3500 nu=0.36; fixed plate axes=xyz;
 *   fixed box=0,0,0,10,10,1 axes=z; force top n=0,0,-1000;
 *   force box=0,0,49,10,10,50 n=0,0,-10
 * Statements separated by ';'.  A missing material keeps mat.  An empty
 * text is the default case.  ERR_PARAM with field "loads" and a message
 * naming the statement and the problem. */
int fea_loads_parse(const char *text, struct fea_material mat, struct fea_loads *l,
		    struct err *e);
/* Canonical text form of l (parseable by fea_loads_parse); 0, or
 * ERR_LIMIT when it needs more than len bytes. */
int fea_loads_format(const struct fea_loads *l, char *buf, size_t len, struct err *e);
void fea_loads_fini(struct fea_loads *l);

/* The voxel model.  rho owned by whoever filled it (fea_grid_fini frees
 * what fea_voxelize_mesh allocated). */
struct fea_grid {
	int nx, ny, nz;     /* elements per axis, >= 1 */
	double h_mm;        /* element edge */
	struct vec3 lo_mm;  /* min corner of element (0, 0, 0), printer frame */
	struct vec3 part_lo_mm, part_hi_mm; /* the placed part's bbox: load
					       boxes and presets refer to it */
	float *rho;         /* nx * ny * nz densities (see top): 0 = absent */
};

void fea_grid_fini(struct fea_grid *g);

/* Solid fraction of every voxel of edge h_mm over m's bounding box
 * (padded by one voxel: lo_mm = bbox.lo - h), exact area coverage in
 * x-y of the mesh sliced at ss = supersample heights inside each voxel
 * layer (1..64), averaged, so walls thinner than a voxel still count.
 * m must be welded (slice.h).  part_lo/hi = m's bbox.  threads as
 * parfor.  On success g->rho is owned by g (fea_grid_fini).  0,
 * ERR_PARAM (h_mm, supersample), ERR_GEOMETRY (empty mesh), ERR_LIMIT
 * (over max_elements, field fea_voxel_mm) or ERR_NOMEM. */
int fea_voxelize_mesh(const struct mesh *m, double h_mm, int supersample, size_t max_elements,
		      int threads, struct fea_grid *g, struct err *e);

struct fea_opts {
	double tol;      /* relative residual |r| / |f| to reach, default 1e-6 */
	int max_iter;    /* CG iterations, default 1000 */
	int threads;     /* parfor threads, <= 0 = 1 */
	int levels;      /* multigrid levels including the finest, 0 = automatic */
	double jacobi_w; /* damped Jacobi weight, default 0.6; lowered per row where
			    w lambda_max would reach 1.9 (docs/fea.md, "Smoother") */
	int smooth;      /* pre- and post-smoothing sweeps per level, default 2 */
	double penal;    /* SIMP p, default FEA_PENAL */
	double rho_min;  /* default FEA_RHO_MIN */
};

/* Defaults as documented above. */
void fea_opts_default(struct fea_opts *o);

struct fea_result {
	double compliance_nmm;      /* f . u */
	double max_displacement_mm; /* largest nodal |u| */
	double residual;            /* final |r| / |f| */
	double solve_s;             /* wall time of this solve (incl. coarse set-up) */
	int iterations;             /* CG iterations of this solve */
	int levels;                 /* multigrid levels used */
	size_t elements;            /* present elements (rho > 0) */
	size_t dofs;                /* free unknowns */
	size_t held_nodes;          /* nodes of parts with no path to a fixed node (or
				       held against no rigid motion) and no force: held
				       fixed, displacement 0 (see fea_solver_new) */
	size_t mem_bytes;           /* solver memory (vectors + coarse operators) */
};

struct fea_solver;

/* Build a solver for grid g (copied: the caller may free g afterwards)
 * and load case l (o NULL = defaults).  Errors, one line each, ERR_PARAM
 * field "loads": a constraint or force place that holds no material
 * node; a force on a node fixed along a direction the force pushes; no
 * constraint at all; E or nu out of range.  ERR_PARAM naming the option
 * for bad opts (field "rho" for a density outside [0, 1]).
 * ERR_GEOMETRY when the model is not constrained against rigid motion: a
 * loaded part (nodes joined through present elements) with no fixed
 * node, or whose fixed unknowns leave a rigid motion free (one fixed
 * line or point), or a singular coarsest operator (pieces joined only
 * along an edge or at a corner).  Parts with no force that are not held
 * are held fixed instead (fea_result.held_nodes).  ERR_LIMIT when the
 * grid is larger than memory allows, ERR_NOMEM. */
int fea_solver_new(const struct fea_grid *g, const struct fea_loads *l, const struct fea_opts *o,
		   struct fea_solver **out, struct err *e);
/* The assembled load vector (N), 3 per node as indexed above, owned by
 * s and writable: fea_solver_new fills it from the load case; callers
 * that need arbitrary nodal loads (consistent tractions, tests) may
 * overwrite it before fea_solve.  Entries on fixed, held or absent
 * unknowns are ignored (the reaction there is not modelled). */
double *fea_solver_force(struct fea_solver *s);
/* Replace the densities (same grid size, same set of present elements:
 * 0 stays 0 and > 0 stays > 0); the next solve starts from the previous
 * displacement (warm start). */
int fea_solver_set_rho(struct fea_solver *s, const float *rho, struct err *e);
/* The relative residual the next solves reach (fea_opts.tol); ERR_PARAM
 * field "tol" outside (0, 1).  An optimiser may rank its designs on loose
 * solves and tighten for the result (the next solve starts from the last
 * displacement). */
int fea_solver_set_tol(struct fea_solver *s, double tol, struct err *e);
/* Solve K(rho) u = f (f: fea_solver_force).  ERR_GEOMETRY if CG does not
 * reach tol within max_iter, or stalls above it (tol below the rounding
 * floor of K u); the message gives the true residual reached.  The
 * output r is filled on success only. */
int fea_solve(struct fea_solver *s, struct fea_result *r, struct err *e);
void fea_solver_free(struct fea_solver *s);

/* After fea_solve.  Displacements (mm), 3 per node as indexed above,
 * borrowed; 0 on unknowns that are fixed or absent. */
const double *fea_displacement(const struct fea_solver *s);
/* out[e] = u_e^T K0 u_e (N mm, the solid element's energy doubled, not
 * scaled by rho^p; 0 for absent elements), for every element.  The
 * sensitivity of eq. 10 of paper 001 is -p/2 rho^(p-1) out[e]. */
void fea_element_energy(const struct fea_solver *s, float *out);
/* Stress at element centres (MPa), rho^p-scaled: von Mises per element
 * into vm (may be NULL), and the volume-weighted mean stress tensor
 * {sxx, syy, szz, syz, sxz, sxy} over the elements with mask[e] != 0
 * (mask NULL = all present) into mean6 (may be NULL). */
void fea_element_stress(const struct fea_solver *s, float *vm, const uint8_t *mask,
			double mean6[6]);

/* ---- compliance bound (bound.c; docs/fea.md "Compliance bound") ---- */

struct progress;

struct fea_bound_opts {
	int max_iter; /* most solves, >= 1 */
	double gap;   /* stop when upper - lower <= gap * lower */
	struct progress *progress; /* may be NULL: updated from f0 to f1 of its stage
				      after each solve, which may cancel */
	double f0, f1;
};

struct fea_bound {
	double lower_nmm; /* no density field of the set is stiffer than this */
	double upper_nmm; /* the relaxed problem's compliance at its best step: the
			     bound is within upper / lower - 1 of that problem's optimum */
	int iterations;   /* solves */
	double solve_s;
};

/* A certified lower bound on the compliance f.u of every density field
 * rho with g->rho <= rho <= ceil_rho element by element and sum rho <=
 * vol, under the solver's weights max(rho, o->rho_min)^p, p = o->penal
 * >= 1.  The relaxation replaces each element's weight by its chord
 * between floor and ceiling (above it: the weight is convex in rho),
 * which makes the problem convex; lower comes from its dual at each
 * step's displacement, optimality-criteria steps drive it up until it
 * meets upper within bo->gap or bo->max_iter solves.  g->rho is the
 * floor: 0 < floor <= ceiling <= 1 per element, both 0 where there is no
 * element.  l and o as fea_solver_new; force, when not NULL, replaces the
 * assembled load
 * vector (3 per node, fea_solver_force's layout), e.g. with the one
 * another solver spread.  Each step's lower bound holds whatever its
 * displacement's accuracy (up to the element energies' float rounding,
 * ~1e-7 relative).  *out is set on success only.  0, ERR_FIELD "rho"
 * (a floor and ceiling not as above), "volume" (vol below the floor's
 * sum), "bound" (bo), the solver's errors, ERR_CANCELLED (bo->progress),
 * ERR_NOMEM. */
int fea_relax_bound(const struct fea_grid *g, const float *ceil_rho, double vol,
		    const struct fea_loads *l, const double *force, const struct fea_opts *o,
		    const struct fea_bound_opts *bo, struct fea_bound *out, struct err *e);

/* The 24 x 24 solid element stiffness K0 (row-major) of a hex8 of edge
 * h_mm, local node order (0,0,0) (1,0,0) (0,1,0) (1,1,0) (0,0,1) ...
 * (x fastest), unknowns 3 * node + axis.  For tests and the VTK writer. */
void fea_element_matrix(struct fea_material mat, double h_mm, double ke[24 * 24]);

#endif
