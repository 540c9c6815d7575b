/* fea_int.h - what the files of engine/fea/ share: the solver's state,
 * the multigrid levels and the kernels between them.  Not for other
 * modules (they use fea.h).  Design: docs/fea.md.
 *
 * Padded grid: the finest level's grid is the caller's grid padded at
 * the high end of each axis with absent elements to a multiple of
 * 2^(levels-1), so level l has exactly nx0 / 2^l elements per axis.
 * Internal vectors use the padded node numbering (x fastest); the
 * caller's numbering (fea.h) is used only by f_user and u_user.
 */
#ifndef INFILLD_FEA_INT_H
#define INFILLD_FEA_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/core/parfor.h"
#include "engine/fea/fea.h"

#define FEA_MAX_LEVELS 12

/* mask0 bits of a finest-level node: bits 0..2 the fixed axes
 * (FEA_AXIS_*); an absent node (touching no present element) or a held
 * one has all three set. */
#define FEA_NODE_ABSENT 8u
#define FEA_NODE_HELD 16u
#define FEA_NODE_FORCE 32u /* carries load (selection bookkeeping) */
#define FEA_NODE_ALL 7u

/* One multigrid level.  Level 0 is matrix-free (element weights w0 and
 * K0); levels >= 1 hold 27-point stencils of 3 x 3 blocks:
 * st[(n * 27 + d) * 9 + 3 r + c], d = (dz + 1) * 9 + (dy + 1) * 3 + dx + 1,
 * the coupling of unknown (n, r) to (n + d, c).  Unknowns whose diagonal
 * is 0 (no free fine unknown under them) have all-zero rows and columns;
 * they stay 0 in every vector (their Jacobi weight is 0) and get an
 * identity row in the coarsest factor. */
struct fea_level {
	int nx, ny, nz; /* elements per axis */
	size_t nn;      /* nodes */
	float *st;      /* levels >= 1, owned */
	double *invd;   /* 3 nn: jacobi_w / diagonal, 0 on masked unknowns */
	double *b;      /* 3 nn right-hand side (level 0: the CG residual, borrowed) */
	double *x;      /* 3 nn solution (owned; swapped with t by smoothing) */
	double *t;      /* 3 nn scratch */
};

/* The band Cholesky factor of the coarsest level (coarse.c). */
struct fea_coarse {
	int n, kd;       /* unknowns, half bandwidth */
	int perm[3];     /* axes from fastest to slowest in the band order */
	double *ab;      /* (kd + 1) * n, LAPACK lower band storage, owned */
	double *rhs;     /* n, owned */
};

struct fea_solver {
	/* the caller's grid */
	int ux, uy, uz;
	size_t un_nodes, un_elems;
	double h_mm;
	struct fea_material mat;
	struct fea_opts opt;
	int threads;

	/* element data */
	double ke[24 * 24];      /* K0 */
	double kdiag;            /* K0's diagonal entry (all 24 are equal) */
	double mc[8][24 * 24];   /* P_c^T K0 P_c of the 8 children (mg.c) */
	double pc[8][24 * 24];   /* P_c */

	/* finest level, padded */
	int nlev;
	struct fea_level lv[FEA_MAX_LEVELS];
	float *w0;        /* padded elements: rho^p, 0 = absent */
	uint8_t *mask0;   /* padded nodes: FEA_NODE_* bits */
	double *u, *r, *p, *q; /* CG vectors, 3 per padded node */
	double *dot_part;  /* partial sums of fea_dot, one per FEA_DOT_BLOCK */

	double *f_user;   /* load, caller's numbering (fea_solver_force) */
	double *u_user;   /* displacement, caller's numbering */

	struct fea_coarse co;

	size_t elements, dofs, held_nodes, mem_bytes;
	double setup_s;   /* coarse set-up time not yet reported by a solve */
	int solved;
};

static inline size_t fea_node(const struct fea_level *l, int i, int j, int k)
{
	return ((size_t)k * (size_t)(l->ny + 1) + (size_t)j) * (size_t)(l->nx + 1) + (size_t)i;
}

/* element.c */
void fea_dmatrix(struct fea_material mat, double d[36]);
void fea_bcentre(double h_mm, double b[6 * 24]);
void fea_child_prolong(int c, double p[24 * 24]);

/* select.c: fill mask0 and f_user from the load case, hold parts with
 * no path to a constraint, check rigid motion.  0 or ERR_PARAM /
 * ERR_GEOMETRY / ERR_NOMEM. */
int fea_select(struct fea_solver *s, const struct fea_grid *g, const struct fea_loads *l,
	       struct err *e);

/* apply.c: level kernels.  op selects what is written to y:
 *   FEA_OP_AX   y = A x
 *   FEA_OP_RES  y = b - A x
 *   FEA_OP_JAC  y = x + invd (b - A x)   (one damped Jacobi sweep)
 * A is the masked operator (identity on masked unknowns); x must be 0 on
 * masked unknowns (all vectors of the solver are), and so is y. */
enum fea_op { FEA_OP_AX = 0, FEA_OP_RES, FEA_OP_JAC };
void fea_apply(struct fea_solver *s, int level, enum fea_op op, const double *x,
	       const double *b, double *y);
/* b_{l+1} = P^T r_l, x_l += P x_{l+1} (level 0: masked). */
void fea_restrict(struct fea_solver *s, int level, const double *r, double *bc);
void fea_prolong_add(struct fea_solver *s, int level, const double *xc, double *x);
/* Parallel dot product of n <= 3 nn0 doubles, summed in a fixed order
 * (results do not depend on the thread count). */
#define FEA_DOT_BLOCK 16384
double fea_dot(struct fea_solver *s, const double *a, const double *b, size_t n);
/* parfor_run with the solver's threads, serial for small n. */
void fea_par(const struct fea_solver *s, size_t n, size_t chunk, parfor_fn fn, void *ctx);

/* mg.c: operators of levels 1.. and the Jacobi weights of every level
 * (after w0 or mask0 change), then the coarsest factor. */
int fea_mg_build(struct fea_solver *s, struct err *e);
/* One V-cycle from level 0: lv[0].x = M lv[0].b. */
void fea_vcycle(struct fea_solver *s);

/* coarse.c */
int fea_coarse_factor(struct fea_solver *s, struct err *e);
void fea_coarse_solve(struct fea_solver *s, const double *b, double *x);
void fea_coarse_fini(struct fea_coarse *c);

#endif
