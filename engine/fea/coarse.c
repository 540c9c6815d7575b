/* coarse.c - the coarsest multigrid level: a banded Cholesky factor
 * (LAPACK dpbtrf, lower band storage) of its operator, unknowns ordered
 * with the axis of fewest nodes fastest so the half bandwidth is
 * 3 (n0 n1 + n0 + 1) + 2 for node counts n0 <= n1 <= n2.  A one-level
 * solver (no multigrid) factors the finest level's element matrices
 * directly.  Unknowns with no free fine unknown under them get an
 * identity row.  A zero or relatively tiny pivot: on a one-level solver
 * the operator is singular (ERR_GEOMETRY); below the finest level the
 * Galerkin operator is refactored with its diagonal raised by
 * FEA_COARSE_SHIFT (relative).  docs/fea.md, "Coarsest level".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* LAPACK (Fortran ABI: by reference, hidden string lengths at the end). */
void dpbtrf_(const char *uplo, const int *n, const int *kd, double *ab, const int *ldab,
	     int *info, size_t uplo_len);
void dpbtrs_(const char *uplo, const int *n, const int *kd, const int *nrhs, const double *ab,
	     const int *ldab, double *b, const int *ldb, int *info, size_t uplo_len);

/* Largest band factor we build, bytes (the automatic levels keep it
 * near 20 MB; an explicit `levels` can ask for more). */
#define COARSE_MAX_BYTES ((size_t)2 << 30)

/* Relative diagonal shift of a semidefinite coarsest Galerkin operator. */
#ifndef FEA_COARSE_SHIFT
#define FEA_COARSE_SHIFT 1e-4
#endif

void fea_coarse_fini(struct fea_coarse *c)
{
	mem_free(c->ab);
	mem_free(c->rhs);
	memset(c, 0, sizeof *c);
}

/* Band index of node (i, j, k) of level l. */
static int band_node(const struct fea_coarse *c, const struct fea_level *l, int i, int j, int k)
{
	const int x[3] = {i, j, k}, n[3] = {l->nx + 1, l->ny + 1, l->nz + 1};
	int p0 = c->perm[0], p1 = c->perm[1], p2 = c->perm[2];

	return (x[p2] * n[p1] + x[p1]) * n[p0] + x[p0];
}

static void band_add(struct fea_coarse *c, int row, int col, double v)
{
	if (row >= col)
		c->ab[(size_t)(row - col) + (size_t)col * (size_t)(c->kd + 1)] += v;
}

int fea_coarse_factor(struct fea_solver *s, struct err *e)
{
	struct fea_coarse *c = &s->co;
	const struct fea_level *l = &s->lv[s->nlev - 1];
	const int n3[3] = {l->nx + 1, l->ny + 1, l->nz + 1};
	double *diag = NULL, *keep = NULL;
	int info = 0, rc = 0, ldab;
	size_t bytes;

	if (!c->ab) {
		int p[3] = {0, 1, 2};
		/* fewest nodes fastest */
		for (int a = 0; a < 3; a++)
			for (int b = a + 1; b < 3; b++)
				if (n3[p[b]] < n3[p[a]]) {
					int t = p[a];
					p[a] = p[b];
					p[b] = t;
				}
		memcpy(c->perm, p, sizeof p);
		double nd = 3.0 * n3[0] * n3[1] * n3[2];
		double kd = 3.0 * ((double)n3[p[0]] * n3[p[1]] + n3[p[0]] + 1) + 2;
		if (kd > nd - 1)
			kd = nd - 1;
		if ((kd + 1) * nd * 8 > (double)COARSE_MAX_BYTES || nd > 2e9)
			return ERR_FIELD(e, "levels",
					 "coarsest level too large for a direct solve (%.0f unknowns, "
					 "half bandwidth %.0f: %.0f MB); use more multigrid levels",
					 nd, kd, (kd + 1) * nd * 8 / 1e6);
		c->n = (int)nd;
		c->kd = (int)kd;
		c->ab = mem_alloc((size_t)(c->kd + 1) * (size_t)c->n * sizeof *c->ab);
		c->rhs = mem_alloc((size_t)c->n * sizeof *c->rhs);
		if (!c->ab || !c->rhs) {
			fea_coarse_fini(c);
			return ERR_SET(e, ERR_NOMEM, "out of memory for the coarsest level");
		}
	}
	ldab = c->kd + 1;
	bytes = (size_t)ldab * (size_t)c->n * sizeof *c->ab;
	memset(c->ab, 0, bytes);
	diag = mem_alloc((size_t)c->n * sizeof *diag);
	if (!diag)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the coarsest level");

	if (s->nlev == 1) {
		/* the finest level itself: element matrices, masked */
		for (int k = 0; k < l->nz; k++)
			for (int j = 0; j < l->ny; j++)
				for (int i = 0; i < l->nx; i++) {
					double w = s->w0[fea_n0(s, i, j, k)];
					int id[8];
					unsigned m8[8];
					if (!(w > 0))
						continue;
					for (int a = 0; a < 8; a++) {
						int ii = i + (a & 1), jj = j + ((a >> 1) & 1),
						    kk = k + ((a >> 2) & 1);
						id[a] = band_node(c, l, ii, jj, kk);
						m8[a] = s->mask0[fea_n0(s, ii, jj, kk)];
					}
					for (int a = 0; a < 24; a++) {
						if (m8[a / 3] & (1u << (a % 3)))
							continue;
						for (int b = 0; b < 24; b++) {
							if (m8[b / 3] & (1u << (b % 3)))
								continue;
							band_add(c, 3 * id[a / 3] + a % 3, 3 * id[b / 3] + b % 3,
								 w * s->ke[a * 24 + b]);
						}
					}
				}
	} else {
		for (int k = 0; k <= l->nz; k++)
			for (int j = 0; j <= l->ny; j++)
				for (int i = 0; i <= l->nx; i++) {
					ptrdiff_t nl = fea_nl(l, i, j, k);
					int row = 3 * band_node(c, l, i, j, k);
					for (int d = 13; d < 27; d++) {
						int ii = i + d % 3 - 1, jj = j + (d / 3) % 3 - 1,
						    kk = k + d / 9 - 1;
						if (ii < 0 || jj < 0 || ii > l->nx || jj > l->ny || kk > l->nz)
							continue;
						int col = 3 * band_node(c, l, ii, jj, kk);
						for (int r = 0; r < 3; r++)
							for (int cc = 0; cc < 3; cc++) {
								float v = *fea_st(l, nl, d - 13, 3 * r + cc);
								band_add(c, row + r, col + cc, v);
								if (d != 13)
									band_add(c, col + cc, row + r, v);
							}
					}
				}
	}
	/* identity rows for unknowns with nothing under them */
	for (int u = 0; u < c->n; u++) {
		double *d = &c->ab[(size_t)u * (size_t)ldab];
		if (!(*d > 0))
			*d = 1;
		diag[u] = *d;
	}
	/* Below the finest level the Galerkin operator P^T A P is only
	 * semidefinite where two coarse unknowns see the same few free fine
	 * unknowns (thin walls, a part a voxel or two thick, masked supports):
	 * its null directions are prolonged to zero, so a relative shift of
	 * the diagonal keeps the preconditioner exact elsewhere.  The
	 * model's own rigid motions were refused by fea_select; a one-level
	 * solver factors the true operator, where a tiny pivot is a real
	 * singularity. */
	if (s->nlev > 1 && !(keep = mem_alloc(bytes))) {
		mem_free(diag);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the coarsest level");
	}
	if (keep)
		memcpy(keep, c->ab, bytes);
	for (int attempt = 0; attempt < 2; attempt++) {
		info = 0;
		dpbtrf_("L", &c->n, &c->kd, c->ab, &ldab, &info, 1);
		if (info == 0) {
			/* a pivot tiny against its own diagonal: singular up to rounding */
			for (int u = 0; u < c->n; u++) {
				double piv = c->ab[(size_t)u * (size_t)ldab];
				if (piv * piv < 1e-10 * diag[u]) {
					info = u + 1;
					break;
				}
			}
		}
		if (info <= 0 || !keep || attempt)
			break;
		memcpy(c->ab, keep, bytes);
		for (int u = 0; u < c->n; u++)
			c->ab[(size_t)u * (size_t)ldab] += FEA_COARSE_SHIFT * diag[u];
		c->shifted = 1;
	}
	mem_free(keep);
	if (info > 0) {
		int u = info - 1, b = u / 3, x[3], rest = b;
		x[c->perm[0]] = rest % n3[c->perm[0]];
		rest /= n3[c->perm[0]];
		x[c->perm[1]] = rest % n3[c->perm[1]];
		x[c->perm[2]] = rest / n3[c->perm[1]];
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "the stiffness is singular (coarsest multigrid level %d, node %d,%d,%d, "
			     "axis %c): the part can move without deforming (not held against rigid "
			     "motion, or pieces joined only along an edge or at a corner)",
			     s->nlev - 1, x[0], x[1], x[2], "xyz"[u % 3]);
	} else if (info < 0) {
		rc = ERR_SET(e, ERR_INTERNAL, "dpbtrf argument %d invalid", -info);
	}
	mem_free(diag);
	return rc;
}

void fea_coarse_solve(struct fea_solver *s, const float *b, float *x)
{
	struct fea_coarse *c = &s->co;
	const struct fea_level *l = &s->lv[s->nlev - 1];
	const float *invd = s->nlev == 1 ? s->invd0 : l->invd;
	int one = 1, info = 0, ldab = c->kd + 1;

	for (int k = 0; k <= l->nz; k++)
		for (int j = 0; j <= l->ny; j++)
			for (int i = 0; i <= l->nx; i++) {
				ptrdiff_t n = fea_nl(l, i, j, k);
				int bn = band_node(c, l, i, j, k);
				for (int a = 0; a < 3; a++)
					c->rhs[3 * bn + a] = b[a * l->cs + n];
			}
	dpbtrs_("L", &c->n, &c->kd, &one, c->ab, &ldab, c->rhs, &c->n, &info, 1);
	/* unknowns with a zero Jacobi weight are masked or have an identity
	 * row: 0 */
	for (int k = 0; k <= l->nz; k++)
		for (int j = 0; j <= l->ny; j++)
			for (int i = 0; i <= l->nx; i++) {
				ptrdiff_t n = fea_nl(l, i, j, k);
				int bn = band_node(c, l, i, j, k);
				for (int a = 0; a < 3; a++)
					x[a * l->cs + n] =
						invd[a * l->cs + n] > 0 ? (float)c->rhs[3 * bn + a] : 0;
			}
}
