/* apply.c - the coarse levels' kernels of the multigrid-CG solver: the
 * stencil operator fused with the residual and damped-Jacobi updates,
 * restriction P^T and prolongation P (trilinear) between levels >= 1,
 * parallel dot products.  The finest level's are in kernel0.c.
 * Design: docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include <string.h>

void fea_par(const struct fea_solver *s, size_t n, size_t chunk, parfor_fn fn, void *ctx)
{
	/* thread start-up costs ~50 us: small loops run on the caller */
	parfor_run(n, n * chunk < 4 ? 1 : s->threads, chunk, fn, ctx);
}

struct apply_ctx {
	struct fea_solver *s;
	const struct fea_level *l;
	enum fea_op op;
	const double *x, *b;
	double *y;
};

/* Write the node's three results through the op (masked -> 0). */
static inline void put3(const struct apply_ctx *c, size_t n, unsigned mask, const double acc[3])
{
	for (int a = 0; a < 3; a++) {
		size_t u = 3 * n + (size_t)a;
		double v;
		if (mask & (1u << a)) {
			c->y[u] = 0;
			continue;
		}
		if (c->op == FEA_OP_AX)
			v = acc[a];
		else if (c->op == FEA_OP_RES)
			v = c->b[u] - acc[a];
		else
			v = c->x[u] + c->l->invd[u] * (c->b[u] - acc[a]);
		c->y[u] = v;
	}
}

/* Stencil level, one node layer k. */
static void applyc_layer(void *vctx, size_t kk, int tid)
{
	const struct apply_ctx *c = vctx;
	const struct fea_level *l = c->l;
	const int NX = l->nx, NY = l->ny, NZ = l->nz, k = (int)kk;
	const double *x = c->x;

	(void)tid;
	for (int j = 0; j <= NY; j++)
		for (int i = 0; i <= NX; i++) {
			size_t n = fea_node(l, i, j, k);
			const float *st = l->st + n * 27 * 9;
			double acc[3] = {0, 0, 0};
			unsigned mask = 0;

			for (int dz = k > 0 ? -1 : 0; dz <= (k < NZ ? 1 : 0); dz++)
				for (int dy = j > 0 ? -1 : 0; dy <= (j < NY ? 1 : 0); dy++)
					for (int dx = i > 0 ? -1 : 0; dx <= (i < NX ? 1 : 0); dx++) {
						const float *bl =
							st + ((dz + 1) * 9 + (dy + 1) * 3 + dx + 1) * 9;
						const double *xm = x + 3 * fea_node(l, i + dx, j + dy, k + dz);
						for (int r = 0; r < 3; r++)
							acc[r] += bl[3 * r] * xm[0] + bl[3 * r + 1] * xm[1] +
								  bl[3 * r + 2] * xm[2];
					}
			for (int a = 0; a < 3; a++)
				if (!(l->invd[3 * n + a] > 0))
					mask |= 1u << a; /* zero-diagonal unknown: stays 0 */
			put3(c, n, mask, acc);
		}
}

void fea_apply(struct fea_solver *s, int level, enum fea_op op, const double *x,
	       const double *b, double *y)
{
	struct apply_ctx c = {s, &s->lv[level], op, x, b, y};

	fea_par(s, (size_t)c.l->nz + 1, 1, applyc_layer, &c);
}

struct grid_ctx {
	const struct fea_solver *s;
	const struct fea_level *f, *c; /* fine, coarse */
	int masked;
	const double *in;
	double *out;
};

/* bc[I] = sum over fine nodes 2I + o (o in {-1, 0, 1}^3) of w(o) r. */
static void restrict_layer(void *vctx, size_t kk, int tid)
{
	const struct grid_ctx *g = vctx;
	const struct fea_level *f = g->f, *c = g->c;
	const int K = (int)kk;

	(void)tid;
	for (int J = 0; J <= c->ny; J++)
		for (int I = 0; I <= c->nx; I++) {
			double acc[3] = {0, 0, 0};
			for (int oz = -1; oz <= 1; oz++) {
				int fk = 2 * K + oz;
				if (fk < 0 || fk > f->nz)
					continue;
				for (int oy = -1; oy <= 1; oy++) {
					int fj = 2 * J + oy;
					if (fj < 0 || fj > f->ny)
						continue;
					for (int ox = -1; ox <= 1; ox++) {
						int fi = 2 * I + ox;
						if (fi < 0 || fi > f->nx)
							continue;
						double w = (ox ? 0.5 : 1) * (oy ? 0.5 : 1) * (oz ? 0.5 : 1);
						const double *r = g->in + 3 * fea_node(f, fi, fj, fk);
						acc[0] += w * r[0];
						acc[1] += w * r[1];
						acc[2] += w * r[2];
					}
				}
			}
			double *o = g->out + 3 * fea_node(c, I, J, K);
			o[0] = acc[0];
			o[1] = acc[1];
			o[2] = acc[2];
		}
}

void fea_restrict(struct fea_solver *s, int level, const double *r, double *bc)
{
	struct grid_ctx g = {s, &s->lv[level], &s->lv[level + 1], 0, r, bc};

	fea_par(s, (size_t)g.c->nz + 1, 1, restrict_layer, &g);
}

/* x[i] += sum over the coarse nodes around i of w x_c (fine layer k). */
static void prolong_layer(void *vctx, size_t kk, int tid)
{
	const struct grid_ctx *g = vctx;
	const struct fea_level *f = g->f, *c = g->c;
	const int k = (int)kk;
	int K[2], nk = (k & 1) ? 2 : 1;

	(void)tid;
	K[0] = k >> 1;
	K[1] = (k + 1) >> 1;
	for (int j = 0; j <= f->ny; j++) {
		int Jv[2] = {j >> 1, (j + 1) >> 1}, nj = (j & 1) ? 2 : 1;
		for (int i = 0; i <= f->nx; i++) {
			int Iv[2] = {i >> 1, (i + 1) >> 1}, ni = (i & 1) ? 2 : 1;
			size_t n = fea_node(f, i, j, k);
			unsigned mask = 0;
			double acc[3] = {0, 0, 0};
			double w = (ni == 2 ? 0.5 : 1) * (nj == 2 ? 0.5 : 1) * (nk == 2 ? 0.5 : 1);

			if (mask == FEA_NODE_ALL)
				continue;
			for (int c3 = 0; c3 < nk; c3++)
				for (int c2 = 0; c2 < nj; c2++)
					for (int c1 = 0; c1 < ni; c1++) {
						const double *xc =
							g->in + 3 * fea_node(c, Iv[c1], Jv[c2], K[c3]);
						acc[0] += xc[0];
						acc[1] += xc[1];
						acc[2] += xc[2];
					}
			for (int a = 0; a < 3; a++)
				if (!(mask & (1u << a)))
					g->out[3 * n + a] += w * acc[a];
		}
	}
}

void fea_prolong_add(struct fea_solver *s, int level, const double *xc, double *x)
{
	struct grid_ctx g = {s, &s->lv[level], &s->lv[level + 1], 0, xc, x};

	fea_par(s, (size_t)g.f->nz + 1, 1, prolong_layer, &g);
}

struct dot_ctx {
	const double *a, *b;
	const float *bf;
	size_t n;
	double *part;
};

static void dot_block(void *vctx, size_t blk, int tid)
{
	const struct dot_ctx *d = vctx;
	size_t lo = blk * FEA_DOT_BLOCK, hi = lo + FEA_DOT_BLOCK < d->n ? lo + FEA_DOT_BLOCK : d->n;
	double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
	size_t i = lo;

	(void)tid;
	if (d->bf) {
		for (; i < hi; i++)
			s0 += d->a[i] * (double)d->bf[i];
		d->part[blk] = s0;
		return;
	}
	for (; i + 4 <= hi; i += 4) {
		s0 += d->a[i] * d->b[i];
		s1 += d->a[i + 1] * d->b[i + 1];
		s2 += d->a[i + 2] * d->b[i + 2];
		s3 += d->a[i + 3] * d->b[i + 3];
	}
	for (; i < hi; i++)
		s0 += d->a[i] * d->b[i];
	d->part[blk] = (s0 + s1) + (s2 + s3);
}

double fea_dot(struct fea_solver *s, const double *a, const double *b, size_t n)
{
	size_t nb = (n + FEA_DOT_BLOCK - 1) / FEA_DOT_BLOCK;
	struct dot_ctx d = {a, b, NULL, n, s->dot_part};
	double sum = 0;

	fea_par(s, nb, 1, dot_block, &d);
	for (size_t i = 0; i < nb; i++)
		sum += s->dot_part[i];
	return sum;
}

double fea_dot_df(struct fea_solver *s, const double *a, const float *b, size_t n)
{
	size_t nb = (n + FEA_DOT_BLOCK - 1) / FEA_DOT_BLOCK;
	struct dot_ctx d = {a, NULL, b, n, s->dot_part};
	double sum = 0;

	fea_par(s, nb, 1, dot_block, &d);
	for (size_t i = 0; i < nb; i++)
		sum += s->dot_part[i];
	return sum;
}
