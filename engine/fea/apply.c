/* apply.c - the coarse levels' stencil operator (fused with the residual
 * and damped-Jacobi updates), restriction P^T and prolongation P
 * (trilinear) between any two levels, and the solver's parallel loop
 * (fea_par).  Every level uses level 0's structure-of-arrays layout with a
 * zero halo (fea_int.h),
 * so the stencil kernel runs across 8 nodes of a row without bounds
 * checks, AVX2+FMA when the CPU has it.  The finest level's operator is
 * in kernel0.c.  docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include <string.h>

typedef float vf8 __attribute__((vector_size(32)));
typedef float vf8u __attribute__((vector_size(32), aligned(4), may_alias));

void fea_par(const struct fea_solver *s, size_t n, size_t chunk, parfor_fn fn, void *ctx)
{
	/* thread start-up costs ~50 us: small loops run on the caller */
	parfor_run(n, n * chunk < 4 ? 1 : s->threads, chunk, fn, ctx);
}

struct apply_ctx {
	const struct fea_level *l;
	enum fea_op op;
	const float *x, *b;
	float *y;
};

#define LD(p) (*(const vf8u *)(p))

static inline __attribute__((always_inline)) int all_zero8(vf8 v)
{
	for (int i = 0; i < 8; i++)
		if (v[i] != 0)
			return 0;
	return 1;
}

/* One plane: y = op(A x), 8 nodes per step.  Forward blocks are read at
 * the node, backward ones (transposed) at the neighbour; halo entries
 * of st and x are 0, and so are the rows of zero-diagonal unknowns, so
 * no mask is needed. */
static inline __attribute__((always_inline)) void applyc_body(const struct apply_ctx *c, int k)
{
	const struct fea_level *l = c->l;
	const ptrdiff_t cs = l->cs;
	const float *x = c->x, *st = l->st;
	ptrdiff_t off[14];

	for (int f = 0; f < 14; f++) {
		int d = 13 + f;
		off[f] = (d % 3 - 1) + (d / 3 % 3 - 1) * l->sx + (d / 9 - 1) * l->sx * l->sy;
	}
	for (int j = 0; j <= l->ny; j++) {
		const ptrdiff_t row = fea_nl(l, -1, j, k);
		for (ptrdiff_t c0 = 0; c0 < l->sx; c0 += 8) {
			const ptrdiff_t n = row + c0;
			vf8 a0 = {0}, a1 = {0}, a2 = {0}, b0 = {0}, b1 = {0}, b2 = {0};
			const float *iv = l->invd + n;
			vf8 act = LD(iv) + LD(iv + cs) + LD(iv + 2 * cs);

			/* 8 nodes with zero diagonals (invd >= 0, 0 exactly
			 * there): zero rows, A x = 0 (outside the part most
			 * of a level is like this) */
			if (all_zero8(act))
				goto out;
			for (int f = 0; f < 14; f++) {
				const ptrdiff_t m = n + off[f];
				const float *sf = st + 9 * f * cs + n;
				vf8 x0 = LD(x + m), x1 = LD(x + cs + m), x2 = LD(x + 2 * cs + m);
				a0 += LD(sf) * x0;
				a1 += LD(sf + 3 * cs) * x0;
				a2 += LD(sf + 6 * cs) * x0;
				a0 += LD(sf + cs) * x1;
				a1 += LD(sf + 4 * cs) * x1;
				a2 += LD(sf + 7 * cs) * x1;
				a0 += LD(sf + 2 * cs) * x2;
				a1 += LD(sf + 5 * cs) * x2;
				a2 += LD(sf + 8 * cs) * x2;
			}
			for (int f = 1; f < 14; f++) {
				const ptrdiff_t m = n - off[f];
				const float *sf = st + 9 * f * cs + m;
				vf8 x0 = LD(x + m), x1 = LD(x + cs + m), x2 = LD(x + 2 * cs + m);
				b0 += LD(sf) * x0;
				b1 += LD(sf + cs) * x0;
				b2 += LD(sf + 2 * cs) * x0;
				b0 += LD(sf + 3 * cs) * x1;
				b1 += LD(sf + 4 * cs) * x1;
				b2 += LD(sf + 5 * cs) * x1;
				b0 += LD(sf + 6 * cs) * x2;
				b1 += LD(sf + 7 * cs) * x2;
				b2 += LD(sf + 8 * cs) * x2;
			}
		out:
			for (int q = 0; q < 3; q++) {
				vf8 acc = q == 0 ? a0 + b0 : q == 1 ? a1 + b1 : a2 + b2, v;
				const ptrdiff_t at = q * cs + n;
				if (c->op == FEA_OP_AX)
					v = acc;
				else if (c->op == FEA_OP_RES)
					v = LD(c->b + at) - acc;
				else
					v = LD(x + at) + LD(l->invd + at) * (LD(c->b + at) - acc);
				*(vf8u *)(c->y + at) = v;
			}
		}
	}
}

__attribute__((target("avx2,fma"), optimize("fp-contract=fast"))) static void
applyc_avx2(void *vctx, size_t k, int tid)
{
	(void)tid;
	applyc_body(vctx, (int)k);
}

static void applyc_base(void *vctx, size_t k, int tid)
{
	(void)tid;
	applyc_body(vctx, (int)k);
}

void fea_apply(struct fea_solver *s, int level, enum fea_op op, const float *x, const float *b,
	       float *y)
{
	struct apply_ctx c = {&s->lv[level], op, x, b, y};

	fea_par(s, (size_t)c.l->nz + 1, 1, fea_have_avx2() ? applyc_avx2 : applyc_base, &c);
}

struct grid_ctx {
	const struct fea_solver *s;
	const struct fea_level *f, *c; /* fine, coarse */
	int masked;
	const float *in;
	float *out;
};

/* bc[I] = sum over fine nodes 2I + o (o in {-1, 0, 1}^3) of w(o) r
 * (the fine halo is 0, so no bounds checks). */
static void restrict_plane(void *vctx, size_t kk, int tid)
{
	const struct grid_ctx *g = vctx;
	const struct fea_level *f = g->f, *c = g->c;
	const int K = (int)kk;
	static const float wt[3] = {0.5f, 1, 0.5f};

	(void)tid;
	for (int J = 0; J <= c->ny; J++)
		for (int I = 0; I <= c->nx; I++) {
			float acc[3] = {0, 0, 0};
			ptrdiff_t n = fea_nl(f, 2 * I, 2 * J, 2 * K), o = fea_nl(c, I, J, K);
			if (!fea_node_free(c, o)) {
				/* no free fine unknown under it: the fine residual is 0
				 * around it */
				for (int q = 0; q < 3; q++)
					g->out[q * c->cs + o] = 0;
				continue;
			}
			for (int oz = 0; oz < 3; oz++)
				for (int oy = 0; oy < 3; oy++) {
					float wyz = wt[oy] * wt[oz];
					ptrdiff_t m = n + (oy - 1) * f->sx + (oz - 1) * f->sx * f->sy;
					for (int q = 0; q < 3; q++) {
						const float *r = g->in + q * f->cs + m;
						acc[q] += wyz * (0.5f * r[-1] + r[0] + 0.5f * r[1]);
					}
				}
			for (int q = 0; q < 3; q++)
				g->out[q * c->cs + o] = acc[q];
		}
}

void fea_restrict(struct fea_solver *s, int level, const float *r, float *bc)
{
	struct grid_ctx g = {s, &s->lv[level], &s->lv[level + 1], 0, r, bc};

	fea_par(s, (size_t)g.c->nz + 1, 1, restrict_plane, &g);
}

/* Coarse nodes per chunk of a row in prolong_plane. */
#define PROLONG_CHUNK 256

/* x[i] += sum over the coarse nodes around i of w x_c (fine plane k):
 * per fine row, the (up to 4) coarse rows around it are blended in y and
 * z first, then interpolated along x. */
static void prolong_plane(void *vctx, size_t kk, int tid)
{
	const struct grid_ctx *g = vctx;
	const struct fea_level *f = g->f, *c = g->c;
	const int k = (int)kk;
	const int K[2] = {k >> 1, (k + 1) >> 1}, nk = (k & 1) ? 2 : 1;
	float tmp[3][PROLONG_CHUNK + 1];

	(void)tid;
	for (int j = 0; j <= f->ny; j++) {
		const int Jv[2] = {j >> 1, (j + 1) >> 1}, nj = (j & 1) ? 2 : 1;
		const float wyz = (nj == 2 ? 0.5f : 1) * (nk == 2 ? 0.5f : 1);
		/* level 0: a row without a free unknown is left alone */
		if (g->masked && fea_row_span(g->s, j, k)[1] < 0)
			continue;
		for (int I0 = 0; I0 < c->nx; I0 += PROLONG_CHUNK) {
			int I1 = I0 + PROLONG_CHUNK < c->nx ? I0 + PROLONG_CHUNK : c->nx;
			for (int q = 0; q < 3; q++) {
				const float *rw[4];
				int nr = 0;
				for (int c3 = 0; c3 < nk; c3++)
					for (int c2 = 0; c2 < nj; c2++)
						rw[nr++] = g->in + q * c->cs + fea_nl(c, 0, Jv[c2], K[c3]);
				for (int I = I0; I <= I1; I++) {
					float acc = rw[0][I];
					for (int r = 1; r < nr; r++)
						acc += rw[r][I];
					tmp[q][I - I0] = wyz * acc;
				}
			}
			const ptrdiff_t n0 = fea_nl(f, 0, j, k);
			const int iend = I1 < c->nx ? 2 * I1 - 1 : 2 * I1;
			for (int i = 2 * I0; i <= iend; i++) {
				const ptrdiff_t n = n0 + i;
				const unsigned mask = g->masked ? g->s->mask0[n] & FEA_NODE_ALL : 0;
				const int h = (i >> 1) - I0;
				for (int q = 0; q < 3; q++) {
					float v = (i & 1) ? 0.5f * (tmp[q][h] + tmp[q][h + 1]) : tmp[q][h];
					if (!(mask & (1u << q)))
						g->out[q * f->cs + n] += v;
				}
			}
		}
	}
}

void fea_prolong_add(struct fea_solver *s, int level, const float *xc, float *x)
{
	struct grid_ctx g = {s, &s->lv[level], &s->lv[level + 1], level == 0, xc, x};

	fea_par(s, (size_t)g.f->nz + 1, 1, prolong_plane, &g);
}
