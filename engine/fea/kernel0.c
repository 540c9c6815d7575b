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
/* unaligned views for loads and stores */
typedef float vf8u __attribute__((vector_size(32), aligned(4), may_alias));
typedef float vf4u __attribute__((vector_size(16), aligned(4), may_alias));
typedef double vd4u __attribute__((vector_size(32), aligned(8), may_alias));

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
					K->soff[r][q] = c * s->cs + K->xoff[d];
					K->sd[r][q] = st[d][3 * r + c];
					K->sf[r][q] = (float)st[d][3 * r + c];
				}
}

struct k0_ctx {
	struct fea_solver *s;
	enum fea_op op;
	const void *x, *b, *invd;
	void *y;
	double *part; /* FEA_OP_AX: x . y of plane k at part[k], or NULL */
};

#define INLINE static inline __attribute__((always_inline))

/* All lanes of a comparison true. */
#define ALL4(v)                                                                    \
	__extension__({                                                            \
		long long e4_[4];                                                  \
		memcpy(e4_, &(v), sizeof e4_);                                     \
		(e4_[0] & e4_[1] & e4_[2] & e4_[3]) == -1;                         \
	})

/* a += wt (the three K0 rows of this node's corner in octant p's
 * element) x, inside PLANE_BODY (uses its K, xn, cs, a0..a2). */
#define OCTANT(T, V, VU, KB, p, wt)                                                              \
	do {                                                                         \
		V t0 = {0}, t1 = {0}, t2 = {0}, v0 = {0}, v1 = {0}, v2 = {0};        \
		for (int bn = 0; bn < 8; bn += 2) {                                  \
			const T *kb = K->KB[p][bn];                                  \
			const T *xb = xn + K->xoff[K->pd[p][bn]];                    \
			V x0 = *(const VU *)xb, x1 = *(const VU *)(xb + cs),         \
			  x2 = *(const VU *)(xb + 2 * cs);                           \
			t0 += kb[0] * x0;                                            \
			t1 += kb[3] * x0;                                            \
			t2 += kb[6] * x0;                                            \
			t0 += kb[1] * x1;                                            \
			t1 += kb[4] * x1;                                            \
			t2 += kb[7] * x1;                                            \
			t0 += kb[2] * x2;                                            \
			t1 += kb[5] * x2;                                            \
			t2 += kb[8] * x2;                                            \
			kb = K->KB[p][bn + 1];                                       \
			xb = xn + K->xoff[K->pd[p][bn + 1]];                         \
			x0 = *(const VU *)xb;                                        \
			x1 = *(const VU *)(xb + cs);                                 \
			x2 = *(const VU *)(xb + 2 * cs);                             \
			v0 += kb[0] * x0;                                            \
			v1 += kb[3] * x0;                                            \
			v2 += kb[6] * x0;                                            \
			v0 += kb[1] * x1;                                            \
			v1 += kb[4] * x1;                                            \
			v2 += kb[7] * x1;                                            \
			v0 += kb[2] * x2;                                            \
			v1 += kb[5] * x2;                                            \
			v2 += kb[8] * x2;                                            \
		}                                                                    \
		const V wv_ = (wt);                                                  \
		a0 += wv_ * (t0 + v0);                                               \
		a1 += wv_ * (t1 + v1);                                               \
		a2 += wv_ * (t2 + v2);                                               \
	} while (0)

/* One plane (k) of y = op(A x), L nodes per step; T scalar, V vector,
 * VU its unaligned view, VI the comparison type, KB/SB the coefficient
 * tables, LOADW the weights as V. */
#define PLANE_BODY(T, V, VU, VI, L, KB, SB, LOADW)                                   \
	const struct fea_solver *s = c->s;                                           \
	const struct fea_k0 *K = &s->k0;                                             \
	const ptrdiff_t cs = s->cs;                                                  \
	const T *x = c->x, *b = c->b, *iv = c->invd;                                 \
	T *y = c->y;                                                                 \
	V xy = {0};                                                                  \
                                                                                     \
	for (int j = 0; j <= s->lv[0].ny; j++) {                                     \
		const ptrdiff_t row = fea_n0(s, -1, j, k);                           \
		const int *rs = fea_row_span(s, j, k);                               \
		/* nodes i = c0 - 1 .. c0 + L - 2; the rest of the row is 0 */       \
		if (rs[1] < 0)                                                       \
			continue;                                                    \
		for (ptrdiff_t c0 = (rs[0] + 1) / L * L; c0 < rs[1] + 2; c0 += L) {  \
			const ptrdiff_t n = row + c0;                                \
			const T *xn = x + n;                                         \
			V w[8], a0 = {0}, a1 = {0}, a2 = {0}, sum = {0};             \
			VI eq;                                                       \
                                                                                     \
			for (int p = 0; p < 8; p++) {                                \
				w[p] = LOADW(s->w0 + n + K->eoff[p]);                \
				sum += w[p];                                         \
			}                                                            \
			eq = sum == 0;                                               \
			if (ALL4(eq))                                                \
				goto out_##T;                                        \
			unsigned dm = 0;                                             \
			int nd = 0;                                                  \
			for (int p = 1; p < 8; p++) {                                \
				VI e1 = w[p] == w[0];                                \
				if (!ALL4(e1))                                       \
					dm |= 1u << p, nd++;                         \
			}                                                            \
			if (nd <= 5) {                                               \
				/* solid stencil, 3 partial sums per row */          \
				for (int r = 0; r < 3; r++) {                        \
					V u0 = {0}, u1 = {0}, u2 = {0};              \
					const ptrdiff_t *so = K->soff[r];            \
					const T *sc = K->SB[r];                      \
					int q = 0, nz = K->snz[r];                   \
					for (; q + 3 <= nz; q += 3) {                \
						u0 += sc[q] * *(const VU *)(xn + so[q]); \
						u1 += sc[q + 1] * *(const VU *)(xn + so[q + 1]); \
						u2 += sc[q + 2] * *(const VU *)(xn + so[q + 2]); \
					}                                            \
					for (; q < nz; q++)                          \
						u0 += sc[q] * *(const VU *)(xn + so[q]); \
					u0 = (u0 + u1 + u2) * w[0];                  \
					if (r == 0)                                  \
						a0 = u0;                             \
					else if (r == 1)                             \
						a1 = u0;                             \
					else                                         \
						a2 = u0;                             \
				}                                                    \
				/* w = w[0] everywhere + (w[p] - w[0]) on octant p */ \
				for (int p = 1; p < 8; p++)                          \
					if (dm & (1u << p))                          \
						OCTANT(T, V, VU, KB, p, w[p] - w[0]); \
			} else {                                                     \
				for (int p = 0; p < 8; p++) {                        \
					VI z = w[p] == 0;                            \
					if (!ALL4(z))                                \
						OCTANT(T, V, VU, KB, p, w[p]);      \
				}                                                    \
			}                                                            \
		out_##T:;                                                            \
			VI m = {0};                                                  \
			for (int l = 0; l < L; l++)                                  \
				m[l] = s->mask0[n + l];                              \
			for (int q = 0; q < 3; q++) {                                \
				V acc = q == 0 ? a0 : q == 1 ? a1 : a2, v;           \
				VI fr = (m & (1 << q)) == 0;                         \
				const ptrdiff_t at = q * cs + n;                     \
				if (c->op == FEA_OP_AX)                              \
					v = acc;                                     \
				else if (c->op == FEA_OP_RES)                        \
					v = *(const VU *)(b + at) - acc;             \
				else                                                 \
					v = *(const VU *)(x + at) +                  \
					    *(const VU *)(iv + at) *                 \
						    (*(const VU *)(b + at) - acc);   \
				v = (V)((VI)v & fr);                                 \
				*(VU *)(y + at) = v;                                 \
				if (c->part)                                         \
					xy += *(const VU *)(x + at) * v;             \
			}                                                            \
		}                                                                    \
	}                                                                            \
	if (c->part) {                                                               \
		double sum_ = 0;                                                     \
		for (int l = 0; l < L; l++)                                          \
			sum_ += xy[l];                                               \
		c->part[k] = sum_;                                                   \
	}

#define LOADW_F(p) (*(const vf8u *)(p))
#define LOADW_D(p) __builtin_convertvector(*(const vf4u *)(p), vd4)

INLINE void plane_f(const struct k0_ctx *c, int k)
{
	PLANE_BODY(float, vf8, vf8u, vi8, 8, kf, sf, LOADW_F)
}

INLINE void plane_d(const struct k0_ctx *c, int k)
{
	PLANE_BODY(double, vd4, vd4u, vl4, 4, kd, sd, LOADW_D)
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

int fea_have_avx2(void)
{
	__builtin_cpu_init();
	return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}

void fea_apply0f(struct fea_solver *s, enum fea_op op, const float *x, const float *b, float *y)
{
	struct k0_ctx c = {s, op, x, b, s->invd0, y, NULL};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, fea_have_avx2() ? plane_f_avx2 : plane_f_base, &c);
}

void fea_apply0d(struct fea_solver *s, const double *x, double *y)
{
	struct k0_ctx c = {s, FEA_OP_AX, x, NULL, NULL, y, NULL};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, fea_have_avx2() ? plane_d_avx2 : plane_d_base, &c);
}

double fea_apply0d_dot(struct fea_solver *s, const double *x, double *y)
{
	struct k0_ctx c = {s, FEA_OP_AX, x, NULL, NULL, y, s->plane_part};
	double sum = 0;

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, fea_have_avx2() ? plane_d_avx2 : plane_d_base, &c);
	for (int k = 0; k <= s->lv[0].nz; k++)
		sum += s->plane_part[k];
	return sum;
}

/* Jacobi weights of level 0, one plane, 8 nodes per step: the 27 blocks
 * of each node's row assembled from its elements (as the operator), then
 * invd = min(jacobi_w, bound / g) / a_ii with g the row's Gershgorin
 * ratio over the unmasked columns (mg.c explains the bound). */
INLINE void jacobi0_body(const struct k0_ctx *c, int k)
{
	const struct fea_solver *s = c->s;
	const struct fea_k0 *K = &s->k0;
	const float w = (float)s->opt.jacobi_w, bound = (float)*(const double *)c->b;

	for (int j = 0; j <= s->lv[0].ny; j++) {
		const ptrdiff_t row = fea_n0(s, -1, j, k);
		for (ptrdiff_t c0 = 0; c0 < s->sx; c0 += 8) {
			const ptrdiff_t n = row + c0;
			vf8 wv[8], blk[27 * 9], sum = {0};
			vi8 z;

			for (int p = 0; p < 8; p++) {
				wv[p] = LOADW_F(s->w0 + n + K->eoff[p]);
				sum += wv[p];
			}
			z = sum == 0;
			if (ALL4(z)) {
				vf8 zero = {0};
				for (int q = 0; q < 3; q++)
					*(vf8u *)(s->invd0 + q * s->cs + n) = zero;
				continue;
			}
			memset(blk, 0, sizeof blk);
			for (int p = 0; p < 8; p++)
				for (int bn = 0; bn < 8; bn++) {
					const float *kb = K->kf[p][bn];
					vf8 *bl = blk + 9 * K->pd[p][bn];
					for (int x = 0; x < 9; x++)
						bl[x] += kb[x] * wv[p];
				}
			vi8 own = {0}, nm[27];
			for (int d = 0; d < 27; d++)
				for (int l = 0; l < 8; l++)
					nm[d][l] = s->mask0[n + K->xoff[d] + l];
			own = nm[13];
			for (int a = 0; a < 3; a++) {
				vf8 g = {0}, dg = blk[13 * 9 + 4 * a], v;
				for (int d = 0; d < 27; d++)
					for (int cc = 0; cc < 3; cc++) {
						vf8 e = blk[d * 9 + 3 * a + cc];
						vi8 fr = (nm[d] & (1 << cc)) == 0;
						e = (vf8)((vi8)e & (vi8){0x7fffffff, 0x7fffffff, 0x7fffffff,
									  0x7fffffff, 0x7fffffff, 0x7fffffff,
									  0x7fffffff, 0x7fffffff}); /* |e| */
						g += (vf8)((vi8)e & fr);
					}
				for (int l = 0; l < 8; l++) {
					float gl = dg[l] > 0 ? g[l] / dg[l] : 0;
					v[l] = dg[l] > 0 && !(own[l] & (1 << a))
						       ? (w * gl < bound ? w : bound / gl) / dg[l]
						       : 0;
				}
				*(vf8u *)(s->invd0 + a * s->cs + n) = v;
			}
		}
	}
}

FAST static void jacobi0_avx2(void *ctx, size_t k, int tid)
{
	(void)tid;
	jacobi0_body(ctx, (int)k);
}

static void jacobi0_base(void *ctx, size_t k, int tid)
{
	(void)tid;
	jacobi0_body(ctx, (int)k);
}

void fea_jacobi0(struct fea_solver *s, double bound)
{
	struct k0_ctx c = {s, FEA_OP_AX, NULL, &bound, NULL, NULL, NULL};

	fea_par(s, (size_t)s->lv[0].nz + 1, 1, fea_have_avx2() ? jacobi0_avx2 : jacobi0_base, &c);
}
