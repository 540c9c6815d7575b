/* nlp.c - Ipopt problem of the support-free hollowing (see opt_int.h).
 *
 * Derivatives are exact and sparse (docs/hollow.md, "Derivatives"):
 *  - a face with corners p_a, p_b, p_c, p_i = (v_i + l_i r_i, z_i), has the
 *    normal N = p_a x p_b + p_b x p_c + p_c x p_a, dN/dl_a = r_a x (p_b - p_c)
 *    (cyclic), d2N/dl_a dl_b = r_a x r_b (cyclic), d2N/dl_i^2 = 0;
 *    eq. 3 as n.d >= -sin(alpha) becomes g = N_z + sin(alpha) |N| >= 0, with
 *    |N| smoothed to sqrt(|N|^2 + delta^2) - delta (never larger than |N|,
 *    so the smoothed constraint is the stricter one), scaled by 1/|N_0|;
 *  - a cross edge v' q (eq. 5) is |d|^2 / (h tan alpha)^2 - 1 <= 0 with
 *    d the horizontal part of v' - q;
 *  - a loop's area A = 1/2 sum C_j, C_j = p_j x p_{j+1}, is bilinear in
 *    (l_j, l_{j+1}); its first moments 1/6 sum (p_j + p_{j+1}) C_j are cubic.
 * The stability objective couples every void through the centre of mass;
 * three auxiliary variables (removed volume and moments, eq. 12) keep the
 * Hessian sparse: the objective's Hessian is 3 x 3 and each definition
 * constraint has the per-loop sparsity of the areas.
 */
#include "engine/hollow/opt/opt_int.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include <IpStdCInterface.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"

/* MUMPS (Ipopt's only linear solver here) is not thread-safe: solves in
 * this process are serialised; parallelism comes from worker processes
 * (solve.c).  This lock is the only process-wide state of the engine. */
static pthread_mutex_t ipopt_lock = PTHREAD_MUTEX_INITIALIZER;

struct nlp {
	const struct hl_nlp_opts *o;
	size_t nl, nx;             /* offset variables; all variables */
	double *px, *py, *rx, *ry, *pz;
	double *lo, *hi;           /* variable bounds */
	size_t nloops;
	size_t *lstart, *llen;
	size_t nf;
	uint32_t *fv;              /* 3 per face */
	double *fsig, *fdel;       /* scale 1/|N0| and smoothing delta */
	double *lh;                /* per loop: slab thickness it stands for (mm, eq. 11) */
	double *ekap;              /* per cross edge: 1 / (dz tan alpha)^2 (eq. 5) */
	size_t ne;
	uint32_t *ev;              /* lo, hi per edge */
	uint32_t *ef;              /* two faces per edge */
	unsigned char *active;
	size_t nact;
	uint32_t *act;
	size_t nceil;
	uint32_t *ceil_loop;
	double *ceil_a0;
	double *ceil_eps;          /* eq. 6 bound actually used (mm^2) */
	/* Hessian sparsity: sorted unique (row, col), row >= col */
	size_t nh;
	uint64_t *hkey;
	uint32_t *fslot, *eslot, *vdiag, *vnext, aux_slot[6];
	double vref;    /* lightweight normalisation: sum h A0 */
	double sin_a;
	int stab;
	double lenscale;
	int iterations;
	int capped; /* the work budget's cap (o->iter_cap) cut the solve */
	int cancelled;
};

static void nlp_fini(struct nlp *P)
{
	mem_free(P->px);
	mem_free(P->py);
	mem_free(P->rx);
	mem_free(P->ry);
	mem_free(P->pz);
	mem_free(P->lo);
	mem_free(P->hi);
	mem_free(P->lstart);
	mem_free(P->llen);
	mem_free(P->fv);
	mem_free(P->fsig);
	mem_free(P->fdel);
	mem_free(P->lh);
	mem_free(P->ekap);
	mem_free(P->ev);
	mem_free(P->ef);
	mem_free(P->active);
	mem_free(P->act);
	mem_free(P->ceil_loop);
	mem_free(P->ceil_a0);
	mem_free(P->ceil_eps);
	mem_free(P->hkey);
	mem_free(P->fslot);
	mem_free(P->eslot);
	mem_free(P->vdiag);
	mem_free(P->vnext);
}

/* Stability variables: after the nl offsets, per loop (A_k, Mx_k, My_k),
 * then the globals (w, sx, sy) at gaux(P). */
static size_t gaux(const struct nlp *P)
{
	return P->nl + 3 * P->nloops;
}

static struct vec3 pos(const struct nlp *P, const double *x, size_t i)
{
	return v3(P->px[i] + x[i] * P->rx[i], P->py[i] + x[i] * P->ry[i], P->pz[i]);
}

static struct vec3 rdir(const struct nlp *P, size_t i)
{
	return v3(P->rx[i], P->ry[i], 0);
}

static size_t loop_next(const struct nlp *P, size_t k, size_t i)
{
	return i + 1 < P->lstart[k] + P->llen[k] ? i + 1 : P->lstart[k];
}

/* ---------------- Hessian sparsity ---------------- */

static uint64_t hk(size_t r, size_t c)
{
	return r >= c ? ((uint64_t)r << 32) | c : ((uint64_t)c << 32) | r;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return (x > y) - (x < y);
}

static uint32_t slot_of(const struct nlp *P, size_t r, size_t c)
{
	uint64_t k = hk(r, c);
	size_t lo = 0, hi = P->nh;

	while (lo < hi) {
		size_t mid = (lo + hi) / 2;
		if (P->hkey[mid] < k)
			lo = mid + 1;
		else
			hi = mid;
	}
	return (uint32_t)lo; /* every queried pair was inserted */
}

static int build_hess(struct nlp *P)
{
	size_t cap = 6 * P->nf + 3 * P->ne + 2 * P->nl + 6, n = 0;
	uint64_t *k = mem_alloc(cap * sizeof *k);

	if (!k)
		return ERR_NOMEM;
	for (size_t f = 0; f < P->nf; f++) {
		const uint32_t *t = P->fv + 3 * f;
		k[n++] = hk(t[0], t[0]);
		k[n++] = hk(t[1], t[1]);
		k[n++] = hk(t[2], t[2]);
		k[n++] = hk(t[0], t[1]);
		k[n++] = hk(t[0], t[2]);
		k[n++] = hk(t[1], t[2]);
	}
	for (size_t q = 0; q < P->ne; q++) {
		k[n++] = hk(P->ev[2 * q], P->ev[2 * q]);
		k[n++] = hk(P->ev[2 * q + 1], P->ev[2 * q + 1]);
		k[n++] = hk(P->ev[2 * q], P->ev[2 * q + 1]);
	}
	for (size_t L = 0; L < P->nloops; L++)
		for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++) {
			k[n++] = hk(i, i);
			k[n++] = hk(i, loop_next(P, L, i));
		}
	if (P->stab) {
		size_t a = gaux(P);
		k[n++] = hk(a, a);
		k[n++] = hk(a + 1, a);
		k[n++] = hk(a + 1, a + 1);
		k[n++] = hk(a + 2, a);
		k[n++] = hk(a + 2, a + 1);
		k[n++] = hk(a + 2, a + 2);
	}
	qsort(k, n, sizeof *k, cmp_u64);
	P->nh = 0;
	for (size_t i = 0; i < n; i++)
		if (P->nh == 0 || k[i] != k[P->nh - 1])
			k[P->nh++] = k[i];
	P->hkey = k;
	P->fslot = mem_alloc((6 * P->nf + 1) * sizeof *P->fslot);
	P->eslot = mem_alloc((3 * P->ne + 1) * sizeof *P->eslot);
	P->vdiag = mem_alloc((P->nl + 1) * sizeof *P->vdiag);
	P->vnext = mem_alloc((P->nl + 1) * sizeof *P->vnext);
	if (!P->fslot || !P->eslot || !P->vdiag || !P->vnext)
		return ERR_NOMEM;
	for (size_t f = 0; f < P->nf; f++) {
		const uint32_t *t = P->fv + 3 * f;
		uint32_t *s = P->fslot + 6 * f;
		s[0] = slot_of(P, t[0], t[0]);
		s[1] = slot_of(P, t[1], t[1]);
		s[2] = slot_of(P, t[2], t[2]);
		s[3] = slot_of(P, t[0], t[1]);
		s[4] = slot_of(P, t[0], t[2]);
		s[5] = slot_of(P, t[1], t[2]);
	}
	for (size_t q = 0; q < P->ne; q++) {
		P->eslot[3 * q] = slot_of(P, P->ev[2 * q], P->ev[2 * q]);
		P->eslot[3 * q + 1] = slot_of(P, P->ev[2 * q + 1], P->ev[2 * q + 1]);
		P->eslot[3 * q + 2] = slot_of(P, P->ev[2 * q], P->ev[2 * q + 1]);
	}
	for (size_t L = 0; L < P->nloops; L++)
		for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++) {
			P->vdiag[i] = slot_of(P, i, i);
			P->vnext[i] = slot_of(P, i, loop_next(P, L, i));
		}
	if (P->stab) {
		size_t a = gaux(P);
		/* order: (w,w) (sx,w) (sx,sx) (sy,w) (sy,sx) (sy,sy) */
		P->aux_slot[0] = slot_of(P, a, a);
		P->aux_slot[1] = slot_of(P, a + 1, a);
		P->aux_slot[2] = slot_of(P, a + 1, a + 1);
		P->aux_slot[3] = slot_of(P, a + 2, a);
		P->aux_slot[4] = slot_of(P, a + 2, a + 1);
		P->aux_slot[5] = slot_of(P, a + 2, a + 2);
	}
	return 0;
}

/* ---------------- terms ---------------- */

/* Face f: value, gradient (3), Hessian (aa, bb, cc, ab, ac, bc). */
static double face_eval(const struct nlp *P, size_t f, const double *x, double *gr, double *he)
{
	const uint32_t *t = P->fv + 3 * f;
	struct vec3 p[3], R[3], dN[3], N;
	double s = P->sin_a, sig = P->fsig[f], del = P->fdel[f], psi, nd[3];

	for (int i = 0; i < 3; i++) {
		p[i] = pos(P, x, t[i]);
		R[i] = rdir(P, t[i]);
	}
	N = v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]));
	psi = sqrt(v3_len2(N) + del * del);
	if (!gr)
		return sig * (N.z + s * (psi - del));
	for (int i = 0; i < 3; i++) {
		dN[i] = v3_cross(R[i], v3_sub(p[(i + 1) % 3], p[(i + 2) % 3]));
		nd[i] = v3_dot(N, dN[i]);
		gr[i] = sig * (dN[i].z + s * nd[i] / psi);
	}
	if (he) {
		/* d2N: only z components, r_i x r_j */
		double ab = R[0].x * R[1].y - R[0].y * R[1].x; /* r_a x r_b */
		double ca = R[2].x * R[0].y - R[2].y * R[0].x; /* r_c x r_a = d2/da dc */
		double bc = R[1].x * R[2].y - R[1].y * R[2].x; /* r_b x r_c */
		double d2[3][3] = {{0, ab, ca}, {ab, 0, bc}, {ca, bc, 0}};
		static const int I[6] = {0, 1, 2, 0, 0, 1}, J[6] = {0, 1, 2, 1, 2, 2};
		double p3 = psi * psi * psi;
		for (int k = 0; k < 6; k++) {
			int i = I[k], j = J[k];
			double dd = v3_dot(dN[i], dN[j]) + N.z * d2[i][j];
			he[k] = sig * (d2[i][j] + s * (dd / psi - nd[i] * nd[j] / p3));
		}
	}
	return sig * (N.z + s * (psi - del));
}

/* Cross edge q: value, gradient (lo, hi), Hessian (lolo, hihi, lohi). */
static double edge_eval(const struct nlp *P, size_t q, const double *x, double *gr, double *he)
{
	uint32_t a = P->ev[2 * q], b = P->ev[2 * q + 1];
	struct vec3 pa = pos(P, x, a), pb = pos(P, x, b);
	double dx = pb.x - pa.x, dy = pb.y - pa.y, k = P->ekap[q];

	if (gr) {
		gr[0] = -2 * k * (dx * P->rx[a] + dy * P->ry[a]);
		gr[1] = 2 * k * (dx * P->rx[b] + dy * P->ry[b]);
	}
	if (he) {
		he[0] = 2 * k * (P->rx[a] * P->rx[a] + P->ry[a] * P->ry[a]);
		he[1] = 2 * k * (P->rx[b] * P->rx[b] + P->ry[b] * P->ry[b]);
		he[2] = -2 * k * (P->rx[a] * P->rx[b] + P->ry[a] * P->ry[b]);
	}
	return k * (dx * dx + dy * dy) - 1;
}

/* Area (and first moments when mom != NULL) of loop L.  Derivatives are
 * accumulated scaled: grad[i] += ga * dA/dl_i (+ gm[0] dMx + gm[1] dMy),
 * hv[slot] += ha * d2A (+ hm[0] d2Mx + hm[1] d2My).  grad/hv may be NULL. */
static double loop_eval(const struct nlp *P, size_t L, const double *x, double *mom, double ga,
			const double *gm, double *grad, double ha, const double *hm, double *hv)
{
	double A = 0, Mx = 0, My = 0;

	for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++) {
		size_t j = loop_next(P, L, i);
		struct vec3 p = pos(P, x, i), q = pos(P, x, j);
		double rx = P->rx[i], ry = P->ry[i], sx = P->rx[j], sy = P->ry[j];
		double C = p.x * q.y - q.x * p.y;
		double Ca = rx * q.y - q.x * ry; /* dC/dl_i = r_i x q */
		double Cb = p.x * sy - sx * p.y; /* dC/dl_j = p x r_j */
		double Cab = rx * sy - sx * ry;  /* r_i x r_j */
		double ux = p.x + q.x, uy = p.y + q.y;

		A += 0.5 * C;
		if (mom) {
			Mx += ux * C / 6;
			My += uy * C / 6;
		}
		if (grad) {
			grad[i] += ga * 0.5 * Ca;
			grad[j] += ga * 0.5 * Cb;
			if (gm) {
				grad[i] += (gm[0] * (rx * C + ux * Ca) + gm[1] * (ry * C + uy * Ca)) / 6;
				grad[j] += (gm[0] * (sx * C + ux * Cb) + gm[1] * (sy * C + uy * Cb)) / 6;
			}
		}
		if (hv) {
			hv[P->vnext[i]] += ha * 0.5 * Cab;
			if (hm) {
				hv[P->vdiag[i]] += (hm[0] * 2 * rx * Ca + hm[1] * 2 * ry * Ca) / 6;
				hv[P->vdiag[j]] += (hm[0] * 2 * sx * Cb + hm[1] * 2 * sy * Cb) / 6;
				hv[P->vnext[i]] += (hm[0] * (rx * Cb + sx * Ca + ux * Cab) +
						    hm[1] * (ry * Cb + sy * Ca + uy * Cab)) /
						   6;
			}
		}
	}
	if (mom) {
		mom[0] = Mx;
		mom[1] = My;
	}
	return A;
}

/* Stability objective on the auxiliaries a = (w, sx, sy): the projected
 * centre of mass c = (c0 - s) / (1 - w) (eq. 12 divided by V), squared
 * distance D(c) to the target region (zero inside: eq. 13-14 where the
 * closest boundary point q is used only while c is outside), normalised
 * by lenscale^2, minus light_weight * w.  Gradient g[3], Hessian h[6]. */
static double stab_eval(const struct nlp *P, const double *a, double *g, double *h)
{
	const struct hl_nlp_opts *o = P->o;
	double q = 1 - a[0], L2 = P->lenscale * P->lenscale;
	struct hull_pt c = {(o->com_xy[0] - a[1]) / q, (o->com_xy[1] - a[2]) / q}, cp;
	int edge, vertex;
	double d = hull_closest_mm(o->target, o->ntarget, c, &cp, &edge, &vertex);
	double gD[2] = {2 * (c.x - cp.x), 2 * (c.y - cp.y)};
	double HD[2][2] = {{0, 0}, {0, 0}};
	/* J = dc/d(w, sx, sy): rows x, y */
	double J[2][3] = {{c.x / q, -1 / q, 0}, {c.y / q, 0, -1 / q}};

	if (d > 0) {
		if (vertex) {
			HD[0][0] = HD[1][1] = 2;
		} else {
			struct hull_pt A = o->target[edge], B = o->target[(edge + 1) % o->ntarget];
			double ex = B.x - A.x, ey = B.y - A.y, l = hypot(ex, ey);
			double nx = ey / l, ny = -ex / l; /* outward normal of a CCW edge */
			HD[0][0] = 2 * nx * nx;
			HD[0][1] = HD[1][0] = 2 * nx * ny;
			HD[1][1] = 2 * ny * ny;
		}
	}
	if (g) {
		for (int k = 0; k < 3; k++)
			g[k] = (gD[0] * J[0][k] + gD[1] * J[1][k]) / L2;
		g[0] -= o->light_weight;
	}
	if (h) {
		static const int I[6] = {0, 1, 1, 2, 2, 2}, K[6] = {0, 0, 1, 0, 1, 2};
		for (int s = 0; s < 6; s++) {
			int i = I[s], k = K[s];
			double v = 0;
			for (int r = 0; r < 2; r++)
				for (int t = 0; t < 2; t++)
					v += J[r][i] * HD[r][t] * J[t][k];
			/* second derivatives of c: (w,w) 2c/q^2, (w,s_r) -e_r/q^2 */
			if (i == 0 && k == 0)
				v += (gD[0] * 2 * c.x + gD[1] * 2 * c.y) / (q * q);
			else if (k == 0)
				v += -gD[i - 1] / (q * q);
			h[s] = v / L2;
		}
	}
	return d * d / L2 - o->light_weight * a[0];
}

/* ---------------- Ipopt callbacks ---------------- */

static Bool cb_f(Index n, Number *x, Bool new_x, Number *obj, UserDataPtr ud)
{
	struct nlp *P = ud;
	(void)n;
	(void)new_x;
	if (P->stab) {
		*obj = stab_eval(P, x + gaux(P), NULL, NULL);
		return TRUE;
	}
	double s = 0;
	for (size_t L = 0; L < P->nloops; L++)
		s += P->lh[L] * loop_eval(P, L, x, NULL, 0, NULL, NULL, 0, NULL, NULL);
	*obj = -s / P->vref;
	return TRUE;
}

static Bool cb_grad_f(Index n, Number *x, Bool new_x, Number *g, UserDataPtr ud)
{
	struct nlp *P = ud;
	(void)new_x;
	memset(g, 0, (size_t)n * sizeof *g);
	if (P->stab) {
		stab_eval(P, x + gaux(P), g + gaux(P), NULL);
		return TRUE;
	}
	for (size_t L = 0; L < P->nloops; L++)
		loop_eval(P, L, x, NULL, -P->lh[L] / P->vref, NULL, g, 0, NULL, NULL);
	return TRUE;
}

static Bool cb_g(Index n, Number *x, Bool new_x, Index m, Number *g, UserDataPtr ud)
{
	struct nlp *P = ud;
	size_t r = 0;
	(void)n;
	(void)new_x;
	(void)m;
	for (size_t f = 0; f < P->nf; f++)
		g[r++] = face_eval(P, f, x, NULL, NULL);
	for (size_t k = 0; k < P->nact; k++)
		g[r++] = edge_eval(P, P->act[k], x, NULL, NULL);
	for (size_t c = 0; c < P->nceil; c++)
		g[r++] = loop_eval(P, P->ceil_loop[c], x, NULL, 0, NULL, NULL, 0, NULL, NULL) /
			 P->ceil_a0[c];
	if (P->stab) {
		/* per loop: A_k = area, M_k = first moments; then the sums (eq. 12) */
		/* the sums carry each loop's thickness: w = sum h_k A_k / V */
		double A = 0, Mx = 0, My = 0, M[2], f = 1 / P->o->vol_mm3;
		size_t G = gaux(P);
		for (size_t L = 0; L < P->nloops; L++) {
			double a = loop_eval(P, L, x, M, 0, NULL, NULL, 0, NULL, NULL);
			size_t q = P->nl + 3 * L;
			g[r++] = x[q] - a;
			g[r++] = x[q + 1] - M[0];
			g[r++] = x[q + 2] - M[1];
			A += P->lh[L] * x[q];
			Mx += P->lh[L] * x[q + 1];
			My += P->lh[L] * x[q + 2];
		}
		g[r++] = x[G] - f * A;
		g[r++] = x[G + 1] - f * Mx;
		g[r++] = x[G + 2] - f * My;
	}
	return TRUE;
}

static Bool cb_jac(Index n, Number *x, Bool new_x, Index m, Index nele, Index *iRow, Index *jCol,
		   Number *val, UserDataPtr ud)
{
	struct nlp *P = ud;
	size_t r = 0, k = 0;
	(void)n;
	(void)new_x;
	(void)m;
	(void)nele;
	if (!val) {
		for (size_t f = 0; f < P->nf; f++, r++)
			for (int i = 0; i < 3; i++) {
				iRow[k] = (Index)r;
				jCol[k++] = (Index)P->fv[3 * f + i];
			}
		for (size_t q = 0; q < P->nact; q++, r++)
			for (int i = 0; i < 2; i++) {
				iRow[k] = (Index)r;
				jCol[k++] = (Index)P->ev[2 * P->act[q] + i];
			}
		for (size_t c = 0; c < P->nceil; c++, r++) {
			size_t L = P->ceil_loop[c];
			for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++) {
				iRow[k] = (Index)r;
				jCol[k++] = (Index)i;
			}
		}
		if (P->stab) {
			for (size_t L = 0; L < P->nloops; L++)
				for (int q = 0; q < 3; q++, r++) {
					for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++) {
						iRow[k] = (Index)r;
						jCol[k++] = (Index)i;
					}
					iRow[k] = (Index)r;
					jCol[k++] = (Index)(P->nl + 3 * L + (size_t)q);
				}
			for (int q = 0; q < 3; q++, r++) {
				for (size_t L = 0; L < P->nloops; L++) {
					iRow[k] = (Index)r;
					jCol[k++] = (Index)(P->nl + 3 * L + (size_t)q);
				}
				iRow[k] = (Index)r;
				jCol[k++] = (Index)(gaux(P) + (size_t)q);
			}
		}
		return TRUE;
	}
	for (size_t f = 0; f < P->nf; f++) {
		face_eval(P, f, x, val + k, NULL);
		k += 3;
	}
	for (size_t q = 0; q < P->nact; q++) {
		edge_eval(P, P->act[q], x, val + k, NULL);
		k += 2;
	}
	{
		/* dense scratch over the offset variables for loop sums */
		double *gsc = mem_calloc(P->nl + 1, sizeof *gsc);
		if (!gsc)
			return FALSE;
		for (size_t c = 0; c < P->nceil; c++) {
			size_t L = P->ceil_loop[c];
			memset(gsc, 0, P->nl * sizeof *gsc);
			loop_eval(P, L, x, NULL, 1 / P->ceil_a0[c], NULL, gsc, 0, NULL, NULL);
			for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++)
				val[k++] = gsc[i];
		}
		if (P->stab) {
			double f = 1 / P->o->vol_mm3, M[2];
			static const double ex[2] = {-1, 0}, ey[2] = {0, -1};
			for (size_t L = 0; L < P->nloops; L++)
				for (int q = 0; q < 3; q++) {
					for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++)
						gsc[i] = 0;
					loop_eval(P, L, x, M, q == 0 ? -1 : 0,
						  q == 0 ? NULL : q == 1 ? ex : ey, gsc, 0, NULL, NULL);
					for (size_t i = P->lstart[L]; i < P->lstart[L] + P->llen[L]; i++)
						val[k++] = gsc[i];
					val[k++] = 1;
				}
			for (int q = 0; q < 3; q++) {
				for (size_t L = 0; L < P->nloops; L++)
					val[k++] = -f * P->lh[L];
				val[k++] = 1;
			}
		}
		mem_free(gsc);
	}
	return TRUE;
}

static Bool cb_h(Index n, Number *x, Bool new_x, Number of, Index m, Number *lambda,
		 Bool new_lambda, Index nele, Index *iRow, Index *jCol, Number *val,
		 UserDataPtr ud)
{
	struct nlp *P = ud;
	size_t r = 0;
	(void)n;
	(void)new_x;
	(void)m;
	(void)new_lambda;
	(void)nele;
	if (!val) {
		for (size_t s = 0; s < P->nh; s++) {
			iRow[s] = (Index)(P->hkey[s] >> 32);
			jCol[s] = (Index)(P->hkey[s] & 0xffffffffu);
		}
		return TRUE;
	}
	memset(val, 0, P->nh * sizeof *val);
	/* objective */
	if (P->stab) {
		double h6[6];
		stab_eval(P, x + gaux(P), NULL, h6);
		for (int s = 0; s < 6; s++)
			val[P->aux_slot[s]] += of * h6[s];
	} else {
		for (size_t L = 0; L < P->nloops; L++)
			loop_eval(P, L, x, NULL, 0, NULL, NULL, -of * P->lh[L] / P->vref, NULL, val);
	}
	for (size_t f = 0; f < P->nf; f++, r++) {
		double he[6];
		face_eval(P, f, x, (double[3]){0}, he);
		for (int s = 0; s < 6; s++)
			val[P->fslot[6 * f + s]] += lambda[r] * he[s];
	}
	for (size_t q = 0; q < P->nact; q++, r++) {
		double he[3];
		size_t ei = P->act[q];
		edge_eval(P, ei, x, NULL, he);
		for (int s = 0; s < 3; s++)
			val[P->eslot[3 * ei + s]] += lambda[r] * he[s];
	}
	for (size_t c = 0; c < P->nceil; c++, r++)
		loop_eval(P, P->ceil_loop[c], x, NULL, 0, NULL, NULL, lambda[r] / P->ceil_a0[c], NULL,
			  val);
	if (P->stab) {
		/* per-loop definitions; the sums are linear */
		double M[2];
		for (size_t L = 0; L < P->nloops; L++, r += 3) {
			double hm[2] = {-lambda[r + 1], -lambda[r + 2]};
			loop_eval(P, L, x, M, 0, NULL, NULL, -lambda[r], hm, val);
		}
	}
	return TRUE;
}

static Bool cb_iter(Index alg_mod, Index iter, Number obj, Number inf_pr, Number inf_du,
		    Number mu, Number d_norm, Number reg, Number alpha_du, Number alpha_pr,
		    Index ls, UserDataPtr ud)
{
	struct nlp *P = ud;
	(void)alg_mod;
	(void)obj;
	(void)inf_pr;
	(void)inf_du;
	(void)mu;
	(void)d_norm;
	(void)reg;
	(void)alpha_du;
	(void)alpha_pr;
	(void)ls;
	P->iterations++;
	(void)iter;
	if (P->o->cancelled && P->o->cancelled(P->o->cancel_ctx)) {
		P->cancelled = 1;
		return FALSE;
	}
	/* the work budget's cap (restoration phases add callbacks max_iter misses) */
	if (P->o->iter_cap > 0 && P->iterations >= P->o->iter_cap) {
		P->capped = 1;
		return FALSE;
	}
	/* the time budget is wall-clock; max_cpu_time counts CPU seconds,
	 * which fall behind the wall when the cores are shared (Ipopt 3.11
	 * has no max_wall_time): stop here, the point reached is checked
	 * like any other (hl_nlp_solve) */
	if (P->o->deadline_s > 0 && progress_now_s() >= P->o->deadline_s)
		return FALSE;
	return TRUE;
}

/* ---------------- setup and outer loop ---------------- */

/* Unit normal (into the void) of face f at x; zero for a degenerate face. */
static struct vec3 face_unit(const struct nlp *P, size_t f, const double *x)
{
	const uint32_t *t = P->fv + 3 * f;
	struct vec3 a = pos(P, x, t[0]), b = pos(P, x, t[1]), c = pos(P, x, t[2]);
	return v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

/* Mark edges facing down at x (eq. 5's sign gate); returns how many newly
 * facing-down edges violate the bound (by more than tol). */
static size_t gate_edges(struct nlp *P, const double *x, double tol)
{
	size_t bad = 0;

	for (size_t q = 0; q < P->ne; q++) {
		struct vec3 n = v3_add(face_unit(P, P->ef[2 * q], x), face_unit(P, P->ef[2 * q + 1], x));
		if (P->active[q] || !(0.5 * n.z < -P->o->gate_tau))
			continue;
		P->active[q] = 1;
		if (edge_eval(P, q, x, NULL, NULL) > tol)
			bad++;
	}
	P->nact = 0;
	for (size_t q = 0; q < P->ne; q++)
		if (P->active[q])
			P->act[P->nact++] = (uint32_t)q;
	return bad;
}

static int nlp_setup(struct nlp *P, struct hl_void *v, size_t nvoid,
		     const struct hl_nlp_opts *o)
{
	size_t nl = 0, nloops = 0, nf = 0, ne = 0, a = 0, L = 0, f = 0, q = 0;

	memset(P, 0, sizeof *P);
	P->o = o;
	P->stab = o->objective == HL_OBJ_STABILITY;
	for (size_t i = 0; i < nvoid; i++) {
		nl += v[i].nv;
		nloops += v[i].nloops;
		nf += v[i].nt;
		ne += v[i].nxe;
	}
	P->nl = nl;
	P->nx = nl + (P->stab ? 3 * nloops + 3 : 0);
	P->nloops = nloops;
	P->nf = nf;
	P->ne = ne;
	P->nceil = o->ceiling_literal ? nvoid : 0;
	P->px = mem_alloc((nl + 1) * sizeof *P->px);
	P->py = mem_alloc((nl + 1) * sizeof *P->py);
	P->rx = mem_alloc((nl + 1) * sizeof *P->rx);
	P->ry = mem_alloc((nl + 1) * sizeof *P->ry);
	P->pz = mem_alloc((nl + 1) * sizeof *P->pz);
	P->lo = mem_alloc((P->nx + 1) * sizeof *P->lo);
	P->hi = mem_alloc((P->nx + 1) * sizeof *P->hi);
	P->lstart = mem_alloc((nloops + 1) * sizeof *P->lstart);
	P->llen = mem_alloc((nloops + 1) * sizeof *P->llen);
	P->fv = mem_alloc((3 * nf + 1) * sizeof *P->fv);
	P->fsig = mem_alloc((nf + 1) * sizeof *P->fsig);
	P->fdel = mem_alloc((nf + 1) * sizeof *P->fdel);
	P->lh = mem_alloc((nloops + 1) * sizeof *P->lh);
	P->ekap = mem_alloc((ne + 1) * sizeof *P->ekap);
	P->ev = mem_alloc((2 * ne + 1) * sizeof *P->ev);
	P->ef = mem_alloc((2 * ne + 1) * sizeof *P->ef);
	P->active = mem_calloc(ne + 1, 1);
	P->act = mem_alloc((ne + 1) * sizeof *P->act);
	P->ceil_loop = mem_alloc((nvoid + 1) * sizeof *P->ceil_loop);
	P->ceil_a0 = mem_alloc((nvoid + 1) * sizeof *P->ceil_a0);
	P->ceil_eps = mem_alloc((nvoid + 1) * sizeof *P->ceil_eps);
	if (!P->ceil_eps || !P->px || !P->py || !P->rx || !P->ry || !P->pz || !P->lo || !P->hi || !P->lstart ||
	    !P->llen || !P->fv || !P->fsig || !P->fdel || !P->lh || !P->ekap || !P->ev || !P->ef || !P->active ||
	    !P->act || !P->ceil_loop || !P->ceil_a0)
		return ERR_NOMEM;
	P->sin_a = sin(o->alpha_rad);
	for (size_t i = 0; i < nvoid; i++) {
		const struct hl_void *V = &v[i];
		for (size_t j = 0; j < V->nv; j++) {
			P->px[a + j] = V->p[2 * j];
			P->py[a + j] = V->p[2 * j + 1];
			P->rx[a + j] = V->dir[2 * j];
			P->ry[a + j] = V->dir[2 * j + 1];
			P->pz[a + j] = V->vz[j];
			P->lo[a + j] = 0;
			P->hi[a + j] = V->ub[j];
		}
		for (size_t k = 0; k < V->nloops; k++, L++) {
			P->lstart[L] = a + V->off[k];
			P->llen[L] = V->off[k + 1] - V->off[k];
			P->lh[L] = hl_void_loop_h(V, k);
		}
		P->ceil_loop[i] = (uint32_t)(L - 1);
		if (!o->ceiling_literal) /* eq. 6 in its limit form: top loop on its poles */
			for (size_t j = V->off[V->nloops - 1]; j < V->nv; j++)
				P->lo[a + j] = V->ub[j];
		for (size_t t = 0; t < V->nt; t++) {
			for (int c = 0; c < 3; c++)
				P->fv[3 * (f + t) + c] = (uint32_t)(a + V->tri[3 * t + c]);
		}
		for (size_t k = 0; k < V->nxe; k++, q++) {
			P->ev[2 * q] = (uint32_t)(a + V->xe[k].lo);
			P->ev[2 * q + 1] = (uint32_t)(a + V->xe[k].hi);
			P->ef[2 * q] = (uint32_t)(f + V->xe[k].f[0]);
			P->ef[2 * q + 1] = (uint32_t)(f + V->xe[k].f[1]);
			/* eq. 5's h is this edge's rise (slices may differ in
			 * thickness); loops of one void lie at increasing z, so
			 * it is > 0: the floor only guards hand-built voids */
			P->ekap[q] = 1 / pow(fmax(V->vz[V->xe[k].hi] - V->vz[V->xe[k].lo], 1e-6) *
						     tan(o->alpha_rad), 2);
		}
		f += V->nt;
		a += V->nv;
	}
	{
		double *x0 = mem_calloc(nl + 1, sizeof *x0);
		if (!x0)
			return ERR_NOMEM;
		for (size_t t = 0; t < nf; t++) {
			const uint32_t *c = P->fv + 3 * t;
			struct vec3 N = v3_cross(v3_sub(pos(P, x0, c[1]), pos(P, x0, c[0])),
						 v3_sub(pos(P, x0, c[2]), pos(P, x0, c[0])));
			double nn = v3_len(N);
			if (nn < 1e-12)
				nn = 1e-12;
			P->fsig[t] = 1 / nn;
			P->fdel[t] = 1e-3 * nn;
		}
		P->vref = 0;
		for (size_t k = 0; k < nloops; k++) {
			double A = loop_eval(P, k, x0, NULL, 0, NULL, NULL, 0, NULL, NULL);
			P->vref += P->lh[k] * A;
		}
		if (P->vref <= 0)
			P->vref = 1;
		for (size_t c = 0; c < nvoid; c++) {
			double A = loop_eval(P, P->ceil_loop[c], x0, NULL, 0, NULL, NULL, 0, NULL, NULL);
			P->ceil_a0[c] = A > 1e-9 ? A : 1e-9;
		}
		/* from here on the ceiling arrays index voids, also when nceil = 0 */
		/* eq. 6 asks for area < epsilon; the smallest area the bounds allow
		 * is that of the loop collapsed onto its poles (l = l^U), a
		 * polygon traced forth and back along the medial axis whose area
		 * is tiny but not exactly 0.  Use epsilon or just above it. */
		for (size_t i = 0; i < nl; i++)
			x0[i] = P->hi[i];
		for (size_t c = 0; c < nvoid; c++) {
			double A = loop_eval(P, P->ceil_loop[c], x0, NULL, 0, NULL, NULL, 0, NULL, NULL);
			P->ceil_eps[c] = fmax(o->ceil_eps_mm2, A + 0.05 * fabs(A) + 1e-7);
			v[c].ceil_eps_mm2 = P->ceil_eps[c];
		}
		mem_free(x0);
	}
	if (P->stab) {
		for (size_t i = nl; i < P->nx; i++) {
			P->lo[i] = -1e19;
			P->hi[i] = 1e19;
		}
		P->hi[gaux(P)] = 0.999;
		P->lenscale = 1;
		if (o->ntarget >= 3) {
			double ar = hull_area_mm2(o->target, o->ntarget);
			P->lenscale = ar > 0 ? sqrt(ar) : 1;
		}
	}
	return build_hess(P);
}

/* Fill the auxiliaries from the offsets (consistent start point). */
static void aux_from(struct nlp *P, double *x)
{
	double A = 0, Mx = 0, My = 0, M[2], f = 1 / P->o->vol_mm3;
	size_t G = gaux(P);

	for (size_t L = 0; L < P->nloops; L++) {
		size_t q = P->nl + 3 * L;
		x[q] = loop_eval(P, L, x, M, 0, NULL, NULL, 0, NULL, NULL);
		x[q + 1] = M[0];
		x[q + 2] = M[1];
		A += P->lh[L] * x[q];
		Mx += P->lh[L] * M[0];
		My += P->lh[L] * M[1];
	}
	x[G] = f * A;
	x[G + 1] = f * Mx;
	x[G + 2] = f * My;
}

/* Ipopt's max_cpu_time (s) for one solve: without a time budget none (1e6:
 * a clock would tie the result to the machine), else what is left of it,
 * 0.5-600 s (the caller does not start a solve past the deadline). */
static double cpu_limit_s(const struct hl_nlp_opts *o)
{
	double left;

	if (!(o->deadline_s > 0))
		return 1e6;
	left = o->deadline_s - progress_now_s();
	return left < 0.5 ? 0.5 : left > 600 ? 600 : left;
}

/* One Ipopt solve from x (updated in place) of at most max_iter
 * iterations. */
static int solve_once(struct nlp *P, double *x, int max_iter, int *app_status, struct err *e)
{
	size_t m = P->nf + P->nact + P->nceil + (P->stab ? 3 * P->nloops + 3 : 0), r = 0;
	size_t nj = 3 * P->nf + 2 * P->nact +
		    (P->stab ? 3 * (P->nl + P->nloops) + 3 * (P->nloops + 1) : 0);
	double *gl = mem_alloc((m + 1) * sizeof *gl), *gu = mem_alloc((m + 1) * sizeof *gu);
	IpoptProblem ip = NULL;
	int rc = 0;

	for (size_t c = 0; c < P->nceil; c++)
		nj += P->llen[P->ceil_loop[c]];
	if (!gl || !gu) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory setting up the solver");
		goto out;
	}
	for (size_t f = 0; f < P->nf; f++, r++) {
		gl[r] = 0;
		gu[r] = 2e19;
	}
	for (size_t q = 0; q < P->nact; q++, r++) {
		gl[r] = -2e19;
		gu[r] = 0;
	}
	for (size_t c = 0; c < P->nceil; c++, r++) {
		gl[r] = -2e19;
		gu[r] = P->ceil_eps[c] / P->ceil_a0[c];
	}
	for (size_t k = 0; P->stab && k < 3 * P->nloops + 3; k++, r++)
		gl[r] = gu[r] = 0;
	if (m > (size_t)INT32_MAX || nj > (size_t)INT32_MAX || P->nh > (size_t)INT32_MAX) {
		rc = ERR_SET(e, ERR_LIMIT, "hollow: optimisation problem too large (%zu constraints)", m);
		goto out;
	}
	ip = CreateIpoptProblem((Index)P->nx, P->lo, P->hi, (Index)m, gl, gu, (Index)nj,
				(Index)P->nh, 0, cb_f, cb_g, cb_grad_f, cb_jac, cb_h);
	if (!ip) {
		rc = ERR_SET(e, ERR_INTERNAL, "hollow: Ipopt refused the problem (%zu variables)",
			     P->nx);
		goto out;
	}
	AddIpoptStrOption(ip, (char *)"sb", (char *)"yes");
	AddIpoptIntOption(ip, (char *)"print_level", 0);
	AddIpoptStrOption(ip, (char *)"linear_solver", (char *)"mumps");
	AddIpoptStrOption(ip, (char *)"mu_strategy", (char *)"adaptive");
	AddIpoptIntOption(ip, (char *)"max_iter", max_iter);
	AddIpoptNumOption(ip, (char *)"tol", 1e-6);
	AddIpoptNumOption(ip, (char *)"constr_viol_tol", 1e-6);
	AddIpoptNumOption(ip, (char *)"acceptable_tol", 1e-4);
	AddIpoptNumOption(ip, (char *)"max_cpu_time", cpu_limit_s(P->o));
	SetIntermediateCallback(ip, cb_iter);
	*app_status = IpoptSolve(ip, x, NULL, NULL, NULL, NULL, NULL, P);
	if (P->cancelled)
		rc = ERR_SET(e, ERR_CANCELLED, "hollow: cancelled during optimisation");
out:
	if (ip)
		FreeIpoptProblem(ip);
	mem_free(gl);
	mem_free(gu);
	return rc;
}

int hl_nlp_solve(struct hl_void *v, size_t n, const struct hl_nlp_opts *o, struct err *e)
{
	struct nlp P;
	double *x = NULL, t0 = progress_now_s();
	int rc, st = 0, outer = 0;

	rc = nlp_setup(&P, v, n, o);
	if (rc) {
		rc = ERR_SET(e, rc, "hollow: out of memory building the problem");
		goto out;
	}
	x = mem_calloc(P.nx + 1, sizeof *x);
	if (!x) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	if (P.stab)
		aux_from(&P, x);
	{
		/* support-free start (start.c), also the fallback of each void */
		size_t a = 0;
		for (size_t i = 0; i < n; i++) {
			rc = hl_void_support_start(&v[i], hl_reach_slope(o->alpha_rad), x + a, e);
			if (rc)
				goto out;
			a += v[i].nv;
		}
	}
	gate_edges(&P, x, INFINITY);
	pthread_mutex_lock(&ipopt_lock);
	for (outer = 1; outer <= o->max_outer; outer++) {
		int max_iter = o->max_iter; /* m makes <= m + 1 callbacks */
		if (o->iter_cap != 0) { /* < 0: none left, the start stays */
			int left = o->iter_cap - P.iterations - 1;
			if (left < 1) {
				P.capped = 1;
				outer--; /* this round did not run */
				break;
			}
			if (left < max_iter)
				max_iter = left;
		}
		rc = solve_once(&P, x, max_iter, &st, e);
		if (rc)
			break;
		if (st == Maximum_Iterations_Exceeded && max_iter < o->max_iter)
			P.capped = 1;
		if (P.capped)
			break;
		/* eq. 5's sign gate at the new point: add newly facing-down edges;
		 * solve again only if one of them is violated (and time is left) */
		if (gate_edges(&P, x, 1e-6) == 0 ||
		    (o->deadline_s > 0 && progress_now_s() >= o->deadline_s))
			break;
		if (P.stab)
			aux_from(&P, x);
	}
	pthread_mutex_unlock(&ipopt_lock);
	if (rc)
		goto out;
	{
		size_t a = 0;
		for (size_t i = 0; i < n; i++) {
			struct hl_check c;
			double *l = mem_alloc((v[i].nv + 1) * sizeof *l);
			if (!l) {
				rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
				goto out;
			}
			for (size_t j = 0; j < v[i].nv; j++) /* clamp Ipopt's bound relaxation */
				l[j] = fmin(fmax(x[a + j], 0), v[i].ub[j]);
			a += v[i].nv;
			mem_free(v[i].l);
			v[i].l = l;
			v[i].iterations = P.iterations;
			v[i].capped = P.capped;
			v[i].outer = outer > o->max_outer ? o->max_outer : outer;
			v[i].seconds = progress_now_s() - t0;
			hl_void_check(&v[i], l, o->alpha_rad, o->gate_tau, &c);
			/* tolerances: 1e-4 rad on faces, 1 um on edges, 1e-3 mm^2 on top */
			v[i].status = (c.worst_face <= 1e-4 && c.worst_edge_mm <= 1e-3 &&
				       c.top_area_mm2 <= v[i].ceil_eps_mm2 + 1e-3)
					      ? 0
					      : (st < 0 ? st : -1000);
			v[i].volume_mm3 = hl_void_volume(&v[i], l);
		}
	}
out:
	mem_free(x);
	nlp_fini(&P);
	return rc;
}
