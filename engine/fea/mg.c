/* mg.c - the multigrid hierarchy and the V-cycle.
 *
 * Level 1 is the Galerkin operator P^T (D K D) P of the finest level,
 * built element by element: a coarse element's 24 x 24 matrix is the sum
 * over its 8 children c of w_c (D_c P_c)^T K0 (D_c P_c), with D_c the
 * mask of the child's fixed unknowns; unmasked children (almost all) add
 * w_c M_c with M_c = P_c^T K0 P_c precomputed.  Coarse elements of one
 * z-layer parity are assembled into the node stencils in parallel (a
 * layer touches node layers K and K + 1 only).  Levels >= 2 are the
 * Galerkin triple product P^T A P on stencils, gathered per coarse node.
 * Masking the product (not re-discretising the coarse grid) is what keeps
 * fixed nodes that are not coarse nodes exact.  docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"

/* Largest eigenvalue of W D^-1 A allowed by the Jacobi weights. */
#define FEA_JACOBI_BOUND 1.9

struct l1_ctx {
	struct fea_solver *s;
	int parity;
};

/* Coarse elements of layer K = 2 kk + parity of level 1. */
static void level1_layer(void *vctx, size_t kk, int tid)
{
	const struct l1_ctx *c = vctx;
	struct fea_solver *s = c->s;
	const struct fea_level *l = &s->lv[1];
	const int K = 2 * (int)kk + c->parity;
	double a[24 * 24], q[24 * 24], t[24 * 24];

	(void)tid;
	if (K >= l->nz)
		return;
	for (int J = 0; J < l->ny; J++)
		for (int I = 0; I < l->nx; I++) {
			int any = 0, solid = 1;
			float w8[8];

			for (int ch = 0; ch < 8 && solid; ch++) {
				int fi = 2 * I + (ch & 1), fj = 2 * J + ((ch >> 1) & 1),
				    fk = 2 * K + ((ch >> 2) & 1);
				w8[ch] = s->w0[fea_n0(s, fi, fj, fk)];
				solid = w8[ch] > 0 && w8[ch] == w8[0];
			}
			for (int ln = 0; ln < 27 && solid; ln++)
				solid = !(s->mask0[fea_n0(s, 2 * I + ln % 3, 2 * J + (ln / 3) % 3,
							  2 * K + ln / 9)] &
					  FEA_NODE_ALL);
			if (solid) {
				/* equal weights, nothing fixed: w (sum of the M_c) */
				for (int x = 0; x < 24 * 24; x++)
					a[x] = w8[0] * s->msum[x];
				any = 1;
				goto scatter;
			}
			memset(a, 0, sizeof a);
			for (int ch = 0; ch < 8; ch++) {
				int fi = 2 * I + (ch & 1), fj = 2 * J + ((ch >> 1) & 1),
				    fk = 2 * K + ((ch >> 2) & 1);
				double w = s->w0[fea_n0(s, fi, fj, fk)];
				unsigned m8[8], masked = 0;

				if (!(w > 0))
					continue;
				any = 1;
				for (int ln = 0; ln < 8; ln++) {
					m8[ln] = s->mask0[fea_n0(s, fi + (ln & 1), fj + ((ln >> 1) & 1),
								 fk + ((ln >> 2) & 1))] &
						 FEA_NODE_ALL;
					masked |= m8[ln];
				}
				if (!masked) {
					const double *m = s->mc[ch];
					for (int x = 0; x < 24 * 24; x++)
						a[x] += w * m[x];
					continue;
				}
				/* q = D_c P_c; a += w q^T K0 q */
				memcpy(q, s->pc[ch], sizeof q);
				for (int ln = 0; ln < 8; ln++)
					for (int ax = 0; ax < 3; ax++)
						if (m8[ln] & (1u << ax))
							memset(q + (3 * ln + ax) * 24, 0, 24 * sizeof *q);
				for (int r = 0; r < 24; r++)
					for (int cc = 0; cc < 24; cc++) {
						double sum = 0;
						for (int x = 0; x < 24; x++)
							sum += s->ke[r * 24 + x] * q[x * 24 + cc];
						t[r * 24 + cc] = sum;
					}
				for (int r = 0; r < 24; r++)
					for (int cc = 0; cc < 24; cc++) {
						double sum = 0;
						for (int x = 0; x < 24; x++)
							sum += q[x * 24 + r] * t[x * 24 + cc];
						a[r * 24 + cc] += w * sum;
					}
			}
			if (!any)
				continue;
		scatter:
			for (int L = 0; L < 8; L++) {
				int lx = L & 1, ly = (L >> 1) & 1, lz = (L >> 2) & 1;
				ptrdiff_t nl = fea_nl(l, I + lx, J + ly, K + lz);
				for (int M = 0; M < 8; M++) {
					int d = ((M >> 2) - lz + 1) * 9 + (((M >> 1) & 1) - ly + 1) * 3 +
						((M & 1) - lx + 1);
					if (d < 13)
						continue; /* the neighbour's forward block */
					for (int r = 0; r < 3; r++)
						for (int cc = 0; cc < 3; cc++)
							*fea_st(l, nl, d - 13, 3 * r + cc) +=
								(float)a[(3 * L + r) * 24 + 3 * M + cc];
				}
			}
		}
}

struct gal_ctx {
	const struct fea_level *f, *c;
};

/* Whether any fine node 2 I + o (o in {-1, 0, 1}^3) under coarse node
 * (I, J, K) has a nonzero diagonal: otherwise their rows are zero and so
 * is the coarse node's Galerkin row (the fine halo's invd is 0). */
static int fine_active(const struct fea_level *f, int I, int J, int K)
{
	for (int oz = -1; oz <= 1; oz++)
		for (int oy = -1; oy <= 1; oy++) {
			ptrdiff_t n = fea_nl(f, 2 * I - 1, 2 * J + oy, 2 * K + oz);
			for (int ox = 0; ox < 3; ox++)
				if (fea_node_free(f, n + ox))
					return 1;
		}
	return 0;
}

/* Coarse node layer K of P^T A P (fine level f with stencils), forward
 * blocks only. */
static void galerkin_layer(void *vctx, size_t kk, int tid)
{
	const struct gal_ctx *g = vctx;
	const struct fea_level *f = g->f, *c = g->c;
	const int K = (int)kk;
	double acc[27 * 9];

	(void)tid;
	for (int J = 0; J <= c->ny; J++)
		for (int I = 0; I <= c->nx; I++) {
			memset(acc, 0, sizeof acc);
			if (!fine_active(f, I, J, K))
				goto store;
			for (int oz = -1; oz <= 1; oz++)
				for (int oy = -1; oy <= 1; oy++)
					for (int ox = -1; ox <= 1; ox++) {
						int fi = 2 * I + ox, fj = 2 * J + oy, fk = 2 * K + oz;
						if (fi < 0 || fj < 0 || fk < 0 || fi > f->nx || fj > f->ny ||
						    fk > f->nz)
							continue;
						double pw = (ox ? 0.5 : 1) * (oy ? 0.5 : 1) * (oz ? 0.5 : 1);
						ptrdiff_t fn = fea_nl(f, fi, fj, fk);
						for (int d = 0; d < 27; d++) {
							int j3[3] = {fi + d % 3 - 1, fj + d / 3 % 3 - 1,
								     fk + d / 9 - 1};
							const int lim[3] = {f->nx, f->ny, f->nz};
							int Jc[3][2], nj[3];
							double qw[3];
							float bl[9];
							int outside = 0;
							for (int ax = 0; ax < 3; ax++) {
								if (j3[ax] < 0 || j3[ax] > lim[ax])
									outside = 1;
								if (j3[ax] & 1) {
									Jc[ax][0] = (j3[ax] - 1) / 2;
									Jc[ax][1] = (j3[ax] + 1) / 2;
									nj[ax] = 2;
									qw[ax] = 0.5;
								} else {
									Jc[ax][0] = j3[ax] / 2;
									nj[ax] = 1;
									qw[ax] = 1;
								}
							}
							if (outside)
								continue;
							fea_block(f, fn, d, bl);
							double wq = pw * qw[0] * qw[1] * qw[2];
							for (int cz = 0; cz < nj[2]; cz++)
								for (int cy = 0; cy < nj[1]; cy++)
									for (int cx = 0; cx < nj[0]; cx++) {
										int D = (Jc[2][cz] - K + 1) * 9 +
											(Jc[1][cy] - J + 1) * 3 +
											(Jc[0][cx] - I + 1);
										if (D < 13)
											continue;
										double *ad = acc + D * 9;
										for (int x = 0; x < 9; x++)
											ad[x] += wq * bl[x];
									}
						}
					}
		store:;
			ptrdiff_t cn = fea_nl(c, I, J, K);
			for (int fb = 0; fb < FEA_ST; fb++)
				for (int x = 0; x < 9; x++)
					*fea_st(c, cn, fb, x) = (float)acc[(13 + fb) * 9 + x];
		}
}

struct diag_ctx {
	struct fea_solver *s;
	int level;
};

/* Jacobi weights of one node layer of a level >= 1 (level 0:
 * fea_jacobi0, the same rule): invd = w_i / a_ii with
 * w_i = min(jacobi_w, FEA_JACOBI_BOUND / g_i), g_i = sum_j |a_ij| / a_ii
 * the row's Gershgorin ratio (masked columns excluded).  Then every
 * eigenvalue of W D^-1 A is <= FEA_JACOBI_BOUND < 2, so each sweep
 * contracts in the energy norm and the V-cycle stays SPD whatever the
 * densities, Poisson's ratio or boundary shape (a lone element reaches
 * lambda_max(D^-1 A) = 6.7 at nu = 0.36, an infinite solid 3.1). */
static void diag_layer(void *vctx, size_t kk, int tid)
{
	const struct diag_ctx *c = vctx;
	struct fea_solver *s = c->s;
	const struct fea_level *l = &s->lv[c->level];
	const int k = (int)kk;
	const double w = s->opt.jacobi_w;
	double blk[27 * 9];

	(void)tid;
	for (int j = 0; j <= l->ny; j++)
		for (int i = 0; i <= l->nx; i++) {
			const ptrdiff_t n0 = fea_nl(l, i, j, k);

			if (!(*fea_st(l, n0, 0, 0) > 0) && !(*fea_st(l, n0, 0, 4) > 0) &&
			    !(*fea_st(l, n0, 0, 8) > 0)) {
				/* no free fine unknown under the node */
				for (int a = 0; a < 3; a++)
					l->invd[a * l->cs + n0] = 0;
				continue;
			}
			memset(blk, 0, sizeof blk);
			for (int d = 0; d < 27; d++) {
				int ii = i + d % 3 - 1, jj = j + (d / 3) % 3 - 1, kq = k + d / 9 - 1;
				float bl[9];
				if (ii < 0 || jj < 0 || kq < 0 || ii > l->nx || jj > l->ny || kq > l->nz)
					continue;
				fea_block(l, n0, d, bl);
				for (int x = 0; x < 9; x++)
					blk[d * 9 + x] = bl[x];
			}
			for (int a = 0; a < 3; a++) {
				double dg = blk[13 * 9 + 4 * a], g = 0, v = 0;
				if (dg > 0) {
					for (int x = 0; x < 27 * 3; x++)
						g += fabs(blk[x / 3 * 9 + 3 * a + x % 3]);
					g /= dg;
					v = (w * g < FEA_JACOBI_BOUND ? w : FEA_JACOBI_BOUND / g) / dg;
				}
				l->invd[a * l->cs + n0] = (float)v;
			}
		}
}

int fea_mg_build(struct fea_solver *s, struct err *e)
{
	for (int lev = 0; lev < s->nlev; lev++) {
		struct fea_level *l = &s->lv[lev];
		if (lev == 1) {
			memset(l->st, 0, (size_t)l->cs * FEA_ST * 9 * sizeof *l->st);
			for (int parity = 0; parity < 2; parity++) {
				struct l1_ctx c = {s, parity};
				fea_par(s, (size_t)(l->nz + 1) / 2, 1, level1_layer, &c);
			}
		} else if (lev >= 2) {
			struct gal_ctx g = {&s->lv[lev - 1], l};
			fea_par(s, (size_t)l->nz + 1, 1, galerkin_layer, &g);
		}
		struct diag_ctx dc = {s, lev};
		if (lev == 0)
			fea_jacobi0(s, FEA_JACOBI_BOUND);
		else
			fea_par(s, (size_t)l->nz + 1, 1, diag_layer, &dc);
	}
	return fea_coarse_factor(s, e);
}

struct scale_ctx {
	const float *a, *b;
	float *y;
	size_t n;
};

#define SCALE_BLOCK 16384

static void mul_block(void *vctx, size_t blk, int tid)
{
	const struct scale_ctx *c = vctx;
	size_t lo = blk * SCALE_BLOCK, hi = lo + SCALE_BLOCK < c->n ? lo + SCALE_BLOCK : c->n;

	(void)tid;
	for (size_t i = lo; i < hi; i++)
		c->y[i] = c->a[i] * c->b[i];
}

static void swap(float **a, float **b)
{
	float *t = *a;

	*a = *b;
	*b = t;
}

void fea_vcycle(struct fea_solver *s, const double *r)
{
	const int L = s->nlev - 1, nu = s->opt.smooth;

	/* level 0: b0 = r, x0 = invd0 b0 (the first sweep from 0) */
	fea_first_sweep0(s, r);
	if (L == 0) {
		fea_coarse_solve(s, s->b0, s->x0);
		return;
	}
	for (int it = 1; it < nu; it++) {
		fea_apply0f(s, FEA_OP_JAC, s->x0, s->b0, s->t0);
		swap(&s->x0, &s->t0);
	}
	fea_apply0f(s, FEA_OP_RES, s->x0, s->b0, s->t0);
	fea_restrict(s, 0, s->t0, s->lv[1].b);
	for (int lev = 1; lev < L; lev++) {
		struct fea_level *l = &s->lv[lev];
		struct scale_ctx c = {l->invd, l->b, l->x, 3 * (size_t)l->cs};

		fea_par(s, (c.n + SCALE_BLOCK - 1) / SCALE_BLOCK, 1, mul_block, &c);
		for (int it = 1; it < nu; it++) {
			fea_apply(s, lev, FEA_OP_JAC, l->x, l->b, l->t);
			swap(&l->x, &l->t);
		}
		fea_apply(s, lev, FEA_OP_RES, l->x, l->b, l->t);
		fea_restrict(s, lev, l->t, s->lv[lev + 1].b);
	}
	fea_coarse_solve(s, s->lv[L].b, s->lv[L].x);
	for (int lev = L - 1; lev >= 1; lev--) {
		struct fea_level *l = &s->lv[lev];
		fea_prolong_add(s, lev, s->lv[lev + 1].x, l->x);
		for (int it = 0; it < nu; it++) {
			fea_apply(s, lev, FEA_OP_JAC, l->x, l->b, l->t);
			swap(&l->x, &l->t);
		}
	}
	fea_prolong_add(s, 0, s->lv[1].x, s->x0);
	for (int it = 0; it < nu; it++) {
		fea_apply0f(s, FEA_OP_JAC, s->x0, s->b0, s->t0);
		swap(&s->x0, &s->t0);
	}
}
