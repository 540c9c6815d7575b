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
#define FEA_ST 14 /* stored 3 x 3 blocks per node, levels >= 1 */

/* mask0 bits of a finest-level node: bits 0..2 the fixed axes
 * (FEA_AXIS_*); an absent node (touching no present element) or a held
 * one has all three set. */
#define FEA_NODE_ABSENT 8u
#define FEA_NODE_HELD 16u
#define FEA_NODE_FORCE 32u /* carries load (selection bookkeeping) */
#define FEA_NODE_ALL 7u

/* One multigrid level.  Every level uses the layout of level 0 (below):
 * structure of arrays, one array of cs entries per axis, node (i, j, k)
 * at fea_nl(l, i, j, k), a zero halo.  Level 0 is matrix-free (element
 * weights w0 and K0); levels >= 1 hold 27-point stencils of 3 x 3
 * blocks: block d of node n, d = (dz + 1) * 9 + (dy + 1) * 3 + dx + 1,
 * couples unknown (n, r) to (n + d, c).  The operator is symmetric, so
 * only the self block and the 13 forward ones (d >= 13, f = d - 13) are
 * stored, entry (f, r, c) of all nodes in one array:
 * st[(9 f + 3 r + c) cs + n] (fea_st); block d < 13 of n is block
 * 26 - d of n + d, transposed.  Unknowns whose diagonal is 0 (no free
 * fine unknown under them) have all-zero rows and columns; their Jacobi
 * weight is 0 and they get an identity row in the coarsest factor. */
struct fea_level {
	int nx, ny, nz;             /* elements per axis */
	ptrdiff_t sx, sy, sz, cs;   /* row stride, rows per plane, planes, entries per array */
	float *st;                  /* levels >= 1: FEA_ST * 9 arrays of cs, owned */
	float *invd;                /* levels >= 1: 3 cs, Jacobi weight / diagonal, 0 on masked */
	float *b, *x, *t;           /* levels >= 1: 3 cs rhs, solution, scratch (x, t swap) */
};

static inline ptrdiff_t fea_nl(const struct fea_level *l, int i, int j, int k)
{
	return ((ptrdiff_t)(k + 1) * l->sy + (j + 1)) * l->sx + (i + 1);
}

/* Entry (f, r c) of node n's stored blocks. */
static inline float *fea_st(const struct fea_level *l, ptrdiff_t n, int f, int rc)
{
	return l->st + (ptrdiff_t)(9 * f + rc) * l->cs + n;
}

/* Block d of node n (any d; n + d inside the grid or its halo) into b. */
static inline void fea_block(const struct fea_level *l, ptrdiff_t n, int d, float b[9])
{
	if (d >= 13) {
		for (int x = 0; x < 9; x++)
			b[x] = *fea_st(l, n, d - 13, x);
	} else {
		ptrdiff_t m = n + (d % 3 - 1) + (d / 3 % 3 - 1) * l->sx + (d / 9 - 1) * l->sx * l->sy;
		for (int r = 0; r < 3; r++)
			for (int c = 0; c < 3; c++)
				b[3 * r + c] = *fea_st(l, m, 13 - d, 3 * c + r);
	}
}

/* The band Cholesky factor of the coarsest level (coarse.c). */
struct fea_coarse {
	int n, kd;       /* unknowns, half bandwidth */
	int perm[3];     /* axes from fastest to slowest in the band order */
	double *ab;      /* (kd + 1) * n, LAPACK lower band storage, owned */
	double *rhs;     /* n, owned */
	int shifted;     /* the last factor needed the diagonal shift (coarse.c) */
};

/* Tables of the finest level's kernels (kernel0.c), offsets in the
 * level-0 layout. */
struct fea_k0 {
	ptrdiff_t xoff[27];     /* the 27 neighbour nodes (d as in fea_level) */
	ptrdiff_t eoff[8];      /* the 8 elements around a node, octant p = ex + 2 ey + 4 ez:
				   element (i - 1 + ex, j - 1 + ey, k - 1 + ez) */
	unsigned char pd[8][8]; /* neighbour d of local node b of octant p's element */
	float kf[8][8][9];      /* K0 rows of the node (corner 7 - p) x columns of b */
	double kd[8][8][9];
	int snz[3];             /* the solid stencil (all 8 weights 1): nonzeros per row */
	ptrdiff_t soff[3][81];  /* their x offsets: axis * cs + xoff[d] */
	float sf[3][81];
	double sd[3][81];
};

/* The level layout: structure of arrays, one array of cs entries per
 * axis, node (i, j, k) at ((k + 1) sy + j + 1) sx + i + 1 with a zero halo
 * around the grid (i = -1, j = -1, k = -1 and k = nz + 1; the next row's
 * and plane's halo close the other sides), rows padded to a multiple of
 * 8 (sx).  Element (i, j, k) lives at the index of its low corner node
 * (w0: weight 0 outside the grid), so kernels need no bounds checks.
 * Every level array has 16 spare entries before and after (fea_n0 is
 * fea_nl of level 0). */

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
	double msum[24 * 24];    /* sum of the 8 M_c: a solid unmasked parent */
	struct fea_k0 k0;

	/* levels; level 0 padded to a multiple of 2^(nlev - 1) elements */
	int nlev;
	struct fea_level lv[FEA_MAX_LEVELS];

	/* level 0 arrays (layout above; lv[0] has the same strides) */
	ptrdiff_t sx, sy, sz, cs;
	float *w0;          /* element weights rho^p, 0 = absent */
	uint8_t *mask0;     /* FEA_NODE_* bits, halo: all masked */
	float *invd0;       /* 3 cs: Jacobi weight / diagonal, 0 on masked */
	float *b0, *x0, *t0; /* 3 cs: V-cycle rhs, solution, scratch (float) */
	double *u, *r, *p, *q; /* 3 cs: CG vectors */
	double *plane_part; /* nz + 1 level-0 plane sums of fea_apply0d_dot */
	/* vec.c: one span per level-0 row with active nodes, chunks of spans
	 * (span_chunk[c] .. span_chunk[c + 1]), two partial sums per chunk */
	struct fea_span {
		ptrdiff_t n; /* first active node of the row (level-0 index) */
		int len;     /* nodes to the row's last active one */
	} *span;
	size_t nspan, nchunk, *span_chunk;
	double *span_part;
	int *row_span; /* per row (j, k), k-major: first and last active i, 0 and -1 if none */

	double *f_user;   /* load, caller's numbering (fea_solver_force) */
	double *u_user;   /* displacement, caller's numbering */

	struct fea_coarse co;

	size_t elements, dofs, held_nodes, mem_bytes;
	double setup_s;   /* coarse set-up time not yet reported by a solve */
	int solved;
};

static inline ptrdiff_t fea_n0(const struct fea_solver *s, int i, int j, int k)
{
	return ((ptrdiff_t)(k + 1) * s->sy + (j + 1)) * s->sx + (i + 1);
}

/* Level-0 row (j, k)'s first and last active i ({0, -1}: none; vec.c). */
static inline const int *fea_row_span(const struct fea_solver *s, int j, int k)
{
	return s->row_span + 2 * ((ptrdiff_t)k * (s->lv[0].ny + 1) + j);
}

/* Levels >= 1: whether node n has an unknown with a nonzero diagonal
 * (invd > 0; the others' rows and columns are 0). */
static inline int fea_node_free(const struct fea_level *l, ptrdiff_t n)
{
	return l->invd[n] != 0 || l->invd[l->cs + n] != 0 || l->invd[2 * l->cs + n] != 0;
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

/* Kernels.  op selects what is written to y:
 *   FEA_OP_AX   y = A x
 *   FEA_OP_RES  y = b - A x
 *   FEA_OP_JAC  y = x + invd (b - A x)   (one damped Jacobi sweep)
 * A is the masked operator (identity on masked unknowns); x must be 0 on
 * masked unknowns (all vectors of the solver are), and so is y. */
enum fea_op { FEA_OP_AX = 0, FEA_OP_RES, FEA_OP_JAC };

/* kernel0.c: level 0.  fea_k0_init fills s->k0 from s->ke.
 * fea_have_avx2: the CPU runs the AVX2+FMA builds of the kernels. */
int fea_have_avx2(void);
void fea_k0_init(struct fea_solver *s);
void fea_apply0f(struct fea_solver *s, enum fea_op op, const float *x, const float *b, float *y);
void fea_apply0d(struct fea_solver *s, const double *x, double *y); /* y = A x */
/* y = A x, returns x . y (per-plane sums added in plane order) */
double fea_apply0d_dot(struct fea_solver *s, const double *x, double *y);
/* invd0 from w0 and mask0 (weights capped at bound / Gershgorin ratio) */
void fea_jacobi0(struct fea_solver *s, double bound);

/* vec.c: level-0 vector operations over the active rows (nodes with a
 * free axis; every other entry of the solver's vectors stays 0).
 * fea_spans_build after mask0 is set. */
int fea_spans_build(struct fea_solver *s, struct err *e);
void fea_spans_fini(struct fea_solver *s);
/* b0 = (float) r, x0 = invd0 b0: the first Jacobi sweep from 0 */
void fea_first_sweep0(struct fea_solver *s, const double *r);
double fea_vec_rr(struct fea_solver *s); /* r . r */
double fea_vec_sub_q(struct fea_solver *s); /* r -= q, returns r . r */
double fea_vec_rz(struct fea_solver *s); /* r . x0 */
/* u += alpha p, r -= alpha q; *rr = |r|^2, *rz = r . x0 (new r) */
void fea_vec_update(struct fea_solver *s, double alpha, double *rr, double *rz);
void fea_vec_p(struct fea_solver *s, double beta); /* p = x0 + beta p */
void fea_vec_p_copy(struct fea_solver *s);         /* p = x0 */

/* apply.c: the stencil operator of levels >= 1 (float vectors), and
 * b_{l+1} = P^T r_l, x_l += P x_{l+1} between any two levels (level 0:
 * masked unknowns left alone). */
void fea_apply(struct fea_solver *s, int level, enum fea_op op, const float *x, const float *b,
	       float *y);
void fea_restrict(struct fea_solver *s, int level, const float *r, float *bc);
void fea_prolong_add(struct fea_solver *s, int level, const float *xc, float *x);
/* parfor_run with the solver's threads, serial for small n. */
void fea_par(const struct fea_solver *s, size_t n, size_t chunk, parfor_fn fn, void *ctx);

/* mg.c: operators of levels 1.. and the Jacobi weights of every level
 * (after w0 or mask0 change), then the coarsest factor. */
int fea_mg_build(struct fea_solver *s, struct err *e);
/* One V-cycle: s->x0 = M r (float). */
void fea_vcycle(struct fea_solver *s, const double *r);

/* coarse.c */
int fea_coarse_factor(struct fea_solver *s, struct err *e);
/* x = A^-1 b on the coarsest level (its layout; level 0 when there is
 * one level: masked unknowns 0). */
void fea_coarse_solve(struct fea_solver *s, const float *b, float *x);
void fea_coarse_fini(struct fea_coarse *c);

#endif
