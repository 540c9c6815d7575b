/* kernel0.c - the finest level's matrix-free operator y = sum_e w_e K0 x_e
 * and the level-0 transfers.  Gathered per node (each node sums the three
 * K0 rows it owns in its up to 8 elements: no races, no colouring),
 * vectorised across 8 (float, V-cycle) or 4 (double, CG) consecutive
 * nodes of a row in the structure-of-arrays level-0 layout (fea_int.h),
 * whose zero halo removes every bounds check.  A group whose 8 element
 * weights are equal in every lane (inside a solid or a void) uses the
 * assembled solid stencil (153 nonzeros instead of 8 x 72 products).
 * Compiled twice: AVX2+FMA when the CPU has it, plain otherwise.
 * docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <string.h>

typedef float vf8 __attribute__((vector_size(32)));
typedef int vi8 __attribute__((vector_size(32)));
typedef float vf4 __attribute__((vector_size(16)));
typedef double vd4 __attribute__((vector_size(32)));
typedef long long vl4 __attribute__((vector_size(32)));

void fea_k0_init(struct fea_solver *s)
{
	struct fea_k0 *K = &s->k0;
	double st[27][9];

	memset(K, 0, sizeof *K);
	memset(st, 0, sizeof st);
	for (int d = 0; d < 27; d++)
		K->xoff[d] = (d % 3 - 1) + ((d / 3) % 3 - 1) * s->sx + (d / 9 - 1) * s->sx * s->sy;
	for (int p = 0; p < 8; p++) {
		int ex = p & 1, ey = (p >> 1) & 1, ez = (p >> 2) & 1;
		K->eoff[p] = (ex - 1) + (ey - 1) * s->sx + (ez - 1) * s->sx * s->sy;
		for (int b = 0; b < 8; b++) {
			int d = (ez + ((b >> 2) & 1)) * 9 + (ey + ((b >> 1) & 1)) * 3 + ex + (b & 1);
			K->pd[p][b] = (unsigned char)d;
			for (int r = 0; r < 3; r++)
				for (int c = 0; c < 3; c++) {
					double v = s->ke[(3 * (7 - p) + r) * 24 + 3 * b + c];
					K->kd[p][b][3 * r + c] = v;
					K->kf[p][b][3 * r + c] = (float)v;
					st[d][3 * r + c] += v;
				}
		}
	}
	/* the solid stencil's nonzeros (zeros by the cube's symmetries) */
	for (int r = 0; r < 3; r++)
		for (int d = 0; d < 27; d++)
			for (int c = 0; c < 3; c++)
				if (fabs(st[d][3 * r + c]) > 1e-12 * s->kdiag) {
					int q = K->snz[r]++;
					K->sidx[r][q] = (unsigned char)(3 * d + c);
					K->sd[r][q] = st[d][3 * r + c];
					K->sf[r][q] = (float)st[d][3 * r + c];
				}
}

struct k0_ctx {
	struct fea_solver *s;
	enum fea_op op;
	const void *x, *b;
	void *y;
};

#define INLINE static inline __attribute__((always_inline))

/* One plane (k) of y = op(A x), float, 8 nodes per step. */
INLINE void plane_f(const struct k0_ctx *c, int k)
{
	const struct fea_solver *s = c->s;
	const struct fea_k0 *K = &s->k0;
	const ptrdiff_t cs = s->cs;
	const float *x = c->x, *b = c->b, *invd = s->invd0;
	float *y = c->y;

	for (int j = 0; j <= s->lv[0].ny; j++) {
		ptrdiff_t row = fea_n0(s, -1, j, k);
		for (ptrdiff_t c0 = 0; c0 < s->sx; c0 += 8) {
			const ptrdiff_t n = row + c0;
			vf8 w[8], X[81], a0 = {0}, a1 = {0}, a2 = {0}, sum = {0};
			vi8 eq = {0}, m;
			long long e4[4];
			unsigned char mb[8];

			for (int p = 0; p < 8; p++) {
				memcpy(&w[p], s->w0 + n + K->eoff[p], sizeof w[p]);
				sum += w[p];
			}
			eq = sum == 0;
			memcpy(e4, &eq, sizeof e4);
			if ((e4[0] & e4[1] & e4[2] & e4[3]) != -1) {
				for (int d = 0; d < 27; d++)
					for (int q = 0; q < 3; q++)
						memcpy(&X[3 * d + q], x + q * cs + n + K->xoff[d], sizeof X[0]);
				eq = w[1] == w[0];
				for (int p = 2; p < 8; p++)
					eq &= w[p] == w[0];
				memcpy(e4, &eq, sizeof e4);
				if ((e4[0] & e4[1] & e4[2] & e4[3]) == -1) {
					for (int q = 0; q < K->snz[0]; q++)
						a0 += K->sf[0][q] * X[K->sidx[0][q]];
					for (int q = 0; q < K->snz[1]; q++)
						a1 += K->sf[1][q] * X[K->sidx[1][q]];
					for (int q = 0; q < K->snz[2]; q++)
						a2 += K->sf[2][q] * X[K->sidx[2][q]];
					a0 *= w[0];
					a1 *= w[0];
					a2 *= w[0];
				} else {
					for (int p = 0; p < 8; p++) {
						vf8 t0 = {0}, t1 = {0}, t2 = {0};
						vi8 z = w[p] == 0;
						memcpy(e4, &z, sizeof e4);
						if ((e4[0] & e4[1] & e4[2] & e4[3]) == -1)
							continue;
						for (int bn = 0; bn < 8; bn++) {
							const float *kb = K->kf[p][bn];
							const vf8 *xb = X + 3 * K->pd[p][bn];
							t0 += kb[0] * xb[0] + kb[1] * xb[1] + kb[2] * xb[2];
							t1 += kb[3] * xb[0] + kb[4] * xb[1] + kb[5] * xb[2];
							t2 += kb[6] * xb[0] + kb[7] * xb[1] + kb[8] * xb[2];
						}
						a0 += w[p] * t0;
						a1 += w[p] * t1;
						a2 += w[p] * t2;
					}
				}
			}
			memcpy(mb, s->mask0 + n, sizeof mb);
			m = (vi8){mb[0], mb[1], mb[2], mb[3], mb[4], mb[5], mb[6], mb[7]};
			for (int q = 0; q < 3; q++) {
				vf8 acc = q == 0 ? a0 : q == 1 ? a1 : a2, v, bv, xv, iv;
				vi8 fr = (m & (1 << q)) == 0;
				ptrdiff_t at = q * cs + n;
				if (c->op == FEA_OP_AX) {
					v = acc;
				} else {
					memcpy(&bv, b + at, sizeof bv);
					if (c->op == FEA_OP_RES) {
						v = bv - acc;
					} else {
						memcpy(&xv, x + at, sizeof xv);
						memcpy(&iv, invd + at, sizeof iv);
						v = xv + iv * (bv - acc);
					}
				}
				v = (vf8)((vi8)v & fr);
				memcpy(y + at, &v, sizeof v);
			}
		}
	}
}

/* One plane of y = A x, double, 4 nodes per step (the CG's operator). */
INLINE void plane_d(const struct k0_ctx *c, int k)
{
	const struct fea_solver *s = c->s;
	const struct fea_k0 *K = &s->k0;
	const ptrdiff_t cs = s->cs;
	const double *x = c->x;
	double *y = c->y;

	for (int j = 0; j <= s->lv[0].ny; j++) {
		ptrdiff_t row = fea_n0(s, -1, j, k);
		for (ptrdiff_t c0 = 0; c0 < s->sx; c0 += 4) {
			const ptrdiff_t n = row + c0;
			vd4 w[8], X[81], a0 = {0}, a1 = {0}, a2 = {0}, sum = {0};
			vl4 eq, m;
			long long e4[4];
			unsigned char mb[4];

			for (int p = 0; p < 8; p++) {
				vf4 wf;
				memcpy(&wf, s->w0 + n + K->eoff[p], sizeof wf);
				w[p] = __builtin_convertvector(wf, vd4);
				sum += w[p];
			}
			eq = sum == 0;
			memcpy(e4, &eq, sizeof e4);
			if ((e4[0] & e4[1] & e4[2] & e4[3]) != -1) {
				for (int d = 0; d < 27; d++)
					for (int q = 0; q < 3; q++)
						memcpy(&X[3 * d + q], x + q * cs + n + K->xoff[d], sizeof X[0]);
				eq = w[1] == w[0];
				for (int p = 2; p < 8; p++)
					eq &= w[p] == w[0];
				memcpy(e4, &eq, sizeof e4);
				if ((e4[0] & e4[1] & e4[2] & e4[3]) == -1) {
					for (int q = 0; q < K->snz[0]; q++)
						a0 += K->sd[0][q] * X[K->sidx[0][q]];
					for (int q = 0; q < K->snz[1]; q++)
						a1 += K->sd[1][q] * X[K->sidx[1][q]];
					for (int q = 0; q < K->snz[2]; q++)
						a2 += K->sd[2][q] * X[K->sidx[2][q]];
					a0 *= w[0];
					a1 *= w[0];
					a2 *= w[0];
				} else {
					for (int p = 0; p < 8; p++) {
						vd4 t0 = {0}, t1 = {0}, t2 = {0};
						vl4 z = w[p] == 0;
						memcpy(e4, &z, sizeof e4);
						if ((e4[0] & e4[1] & e4[2] & e4[3]) == -1)
							continue;
						for (int bn = 0; bn < 8; bn++) {
							const double *kb = K->kd[p][bn];
							const vd4 *xb = X + 3 * K->pd[p][bn];
							t0 += kb[0] * xb[0] + kb[1] * xb[1] + kb[2] * xb[2];
							t1 += kb[3] * xb[0] + kb[4] * xb[1] + kb[5] * xb[2];
							t2 += kb[6] * xb[0] + kb[7] * xb[1] + kb[8] * xb[2];
						}
						a0 += w[p] * t0;
						a1 += w[p] * t1;
						a2 += w[p] * t2;
					}
				}
			}
			memcpy(mb, s->mask0 + n, sizeof mb);
			m = (vl4){mb[0], mb[1], mb[2], mb[3]};
			for (int q = 0; q < 3; q++) {
				vd4 v = q == 0 ? a0 : q == 1 ? a1 : a2;
				vl4 fr = (m & (1 << q)) == 0;
				v = (vd4)((vl4)v & fr);
				memcpy(y + q * cs + n, &v, sizeof v);
			}
		}
	}
}

#define FAST __attribute__((target("avx2,fma"), optimize("fp-contract=fast")))

FAST static void plane_f_avx2(void *ctx, size_t k, int tid)
{
	(void)tid;
	plane_f(ctx, (int)k);
}

static void plane_f_base(void *ctx, size_t k, int tid)
{
	(void)tid;
	plane_f(ctx, (int)k);
}

FAST static void plane_d_avx2(void *ctx, size_t k, int tid)
{
	(void)tid;
	plane_d(ctx, (int)k);
}

static void plane_d_base(void *ctx, size_t k, int tid)
{
	(void)tid;
	plane_d(ctx, (int)k);
}

static int have_avx2(void)
{
	__builtin_cpu_init();
	return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

void fea_apply0f(struct fea_solver *s, enum fea_op op, const float *x, const float *b, float *y)
{
	struct k0_ctx c = {s, op, x, b, y};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, have_avx2() ? plane_f_avx2 : plane_f_base, &c);
}

void fea_apply0d(struct fea_solver *s, const double *x, double *y)
{
	struct k0_ctx c = {s, FEA_OP_AX, x, NULL, y};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, have_avx2() ? plane_d_avx2 : plane_d_base, &c);
}

/* b0 = (float) r, x0 = invd0 b0, over one plane of all three axes. */
static void first_plane(void *vctx, size_t k, int tid)
{
	const struct k0_ctx *c = vctx;
	const struct fea_solver *s = c->s;
	const double *r = c->x;
	ptrdiff_t lo = fea_n0(s, -1, -1, (int)k), hi = lo + s->sx * s->sy;

	(void)tid;
	for (int q = 0; q < 3; q++)
		for (ptrdiff_t n = lo + q * s->cs; n < hi + q * s->cs; n++) {
			float bf = (float)r[n];
			s->b0[n] = bf;
			s->x0[n] = s->invd0[n] * bf;
		}
}

void fea_first_sweep0(struct fea_solver *s, const double *r)
{
	struct k0_ctx c = {s, FEA_OP_AX, r, NULL, NULL};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, first_plane, &c);
}

struct tr_ctx {
	struct fea_solver *s;
	const float *f;
	const double *d;
	float *fo;
	double *dout;
};

/* b1[I] = sum over fine nodes 2I + o (o in {-1, 0, 1}^3) of w(o) r0 */
static void restrict0_plane(void *vctx, size_t kk, int tid)
{
	const struct tr_ctx *c = vctx;
	const struct fea_solver *s = c->s;
	const struct fea_level *l1 = &s->lv[1];
	const int K = (int)kk;
	static const float wt[3] = {0.5f, 1, 0.5f};

	(void)tid;
	for (int J = 0; J <= l1->ny; J++)
		for (int I = 0; I <= l1->nx; I++) {
			double acc[3] = {0, 0, 0};
			ptrdiff_t n = fea_n0(s, 2 * I, 2 * J, 2 * K);
			for (int oz = 0; oz < 3; oz++)
				for (int oy = 0; oy < 3; oy++) {
					float wyz = wt[oy] * wt[oz];
					ptrdiff_t m = n + (oy - 1) * s->sx + (oz - 1) * s->sx * s->sy;
					for (int q = 0; q < 3; q++) {
						const float *r = c->f + q * s->cs + m;
						acc[q] += wyz * (0.5f * r[-1] + r[0] + 0.5f * r[1]);
					}
				}
			double *o = c->dout + 3 * fea_node(l1, I, J, K);
			o[0] = acc[0];
			o[1] = acc[1];
			o[2] = acc[2];
		}
}

void fea_restrict0(struct fea_solver *s, const float *r0, double *b1)
{
	struct tr_ctx c = {s, r0, NULL, NULL, b1};

	fea_par(s, (size_t)s->lv[1].nz + 1, 1, restrict0_plane, &c);
}

/* x0 += P x1 on fine plane k, masked */
static void prolong0_plane(void *vctx, size_t kk, int tid)
{
	const struct tr_ctx *c = vctx;
	const struct fea_solver *s = c->s;
	const struct fea_level *f = &s->lv[0], *l1 = &s->lv[1];
	const int k = (int)kk;
	const int K[2] = {k >> 1, (k + 1) >> 1}, nk = (k & 1) ? 2 : 1;

	(void)tid;
	for (int j = 0; j <= f->ny; j++) {
		int Jv[2] = {j >> 1, (j + 1) >> 1}, nj = (j & 1) ? 2 : 1;
		for (int i = 0; i <= f->nx; i++) {
			int Iv[2] = {i >> 1, (i + 1) >> 1}, ni = (i & 1) ? 2 : 1;
			ptrdiff_t n = fea_n0(s, i, j, k);
			unsigned mask = s->mask0[n] & FEA_NODE_ALL;
			double acc[3] = {0, 0, 0};
			double w = (ni == 2 ? 0.5 : 1) * (nj == 2 ? 0.5 : 1) * (nk == 2 ? 0.5 : 1);

			if (mask == FEA_NODE_ALL)
				continue;
			for (int c3 = 0; c3 < nk; c3++)
				for (int c2 = 0; c2 < nj; c2++)
					for (int c1 = 0; c1 < ni; c1++) {
						const double *xc = c->d + 3 * fea_node(l1, Iv[c1], Jv[c2], K[c3]);
						acc[0] += xc[0];
						acc[1] += xc[1];
						acc[2] += xc[2];
					}
			for (int q = 0; q < 3; q++)
				if (!(mask & (1u << q)))
					c->fo[q * s->cs + n] += (float)(w * acc[q]);
		}
	}
}

void fea_prolong0(struct fea_solver *s, const double *x1, float *x0)
{
	struct tr_ctx c = {s, NULL, x1, x0, NULL};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, prolong0_plane, &c);
}
