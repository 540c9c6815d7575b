/* solve.c - the solver's life cycle (fea_solver_new/set_rho/free), the
 * preconditioned conjugate gradients of fea_solve, and the results
 * (displacements, element energies, stresses).  docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* Automatic levels: coarsen while the coarsest has more nodes than this. */
#define COARSEST_NODES 2000

void fea_opts_default(struct fea_opts *o)
{
	o->tol = 1e-6;
	o->max_iter = 1000;
	o->threads = 1;
	o->levels = 0;
	o->jacobi_w = 0.6;
	o->smooth = 2;
	o->penal = FEA_PENAL;
	o->rho_min = FEA_RHO_MIN;
}

static double now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int ceil_div(int a, int b)
{
	return (a + b - 1) / b;
}

static double nodes_at(const int n[3], int lev)
{
	double p = 1;

	for (int a = 0; a < 3; a++)
		p *= ceil_div(n[a], 1 << lev) + 1;
	return p;
}

/* Multigrid levels for an nx x ny x nz grid (see fea.h, fea_opts). */
static int pick_levels(const int n[3], int want)
{
	int lev = 1;

	if (want > 0) {
		lev = want > FEA_MAX_LEVELS ? FEA_MAX_LEVELS : want;
		/* no level below one element per axis everywhere */
		while (lev > 1 && ceil_div(n[0], 1 << (lev - 2)) == 1 &&
		       ceil_div(n[1], 1 << (lev - 2)) == 1 && ceil_div(n[2], 1 << (lev - 2)) == 1)
			lev--;
		return lev;
	}
	while (lev < FEA_MAX_LEVELS && nodes_at(n, lev - 1) > COARSEST_NODES &&
	       ceil_div(n[0], 1 << lev) >= 2 && ceil_div(n[1], 1 << lev) >= 2 &&
	       ceil_div(n[2], 1 << lev) >= 2)
		lev++;
	return lev;
}

static void *alloc_count(struct fea_solver *s, size_t count, size_t size)
{
	void *p = mem_calloc(count, size);

	if (p)
		s->mem_bytes += count * size;
	return p;
}

/* Level-0 arrays keep L0_MARGIN spare bytes on both sides (fea_int.h). */
#define L0_MARGIN 128

static void *alloc0(struct fea_solver *s, size_t count, size_t size)
{
	char *p;

	if (count > (SIZE_MAX - 2 * L0_MARGIN) / size)
		return NULL;
	p = mem_calloc(1, count * size + 2 * L0_MARGIN);
	if (!p)
		return NULL;
	s->mem_bytes += count * size + 2 * L0_MARGIN;
	return p + L0_MARGIN;
}

static void free0(void *p)
{
	if (p)
		mem_free((char *)p - L0_MARGIN);
}

void fea_solver_free(struct fea_solver *s)
{
	if (!s)
		return;
	for (int l = 0; l < FEA_MAX_LEVELS; l++) {
		free0(s->lv[l].st);
		free0(s->lv[l].invd);
		free0(s->lv[l].b);
		free0(s->lv[l].x);
		free0(s->lv[l].t);
	}
	free0(s->w0);
	free0(s->mask0);
	free0(s->invd0);
	free0(s->b0);
	free0(s->x0);
	free0(s->t0);
	free0(s->u);
	free0(s->r);
	free0(s->p);
	free0(s->q);
	mem_free(s->plane_part);
	fea_spans_fini(s);
	mem_free(s->f_user);
	mem_free(s->u_user);
	fea_coarse_fini(&s->co);
	mem_free(s);
}

/* fea_opts.tol and fea_solver_set_tol: a relative residual in (0, 1). */
static int check_tol(double tol, struct err *e)
{
	if (!(tol > 0 && tol < 1))
		return ERR_FIELD(e, "tol", "tolerance must be in (0, 1), not %g", tol);
	return 0;
}

static int check_inputs(const struct fea_grid *g, const struct fea_loads *l,
			const struct fea_opts *o, struct err *e)
{
	int rc;

	if (!g || !g->rho || g->nx < 1 || g->ny < 1 || g->nz < 1)
		return ERR_SET(e, ERR_PARAM, "fea grid is empty");
	if (!(g->h_mm > 0) || !isfinite(g->h_mm))
		return ERR_FIELD(e, "fea_voxel_mm", "voxel edge must be a finite number > 0, not %g",
				 g->h_mm);
	if (!(l->material.E_mpa > 0) || !isfinite(l->material.E_mpa))
		return ERR_FIELD(e, "loads", "loads: E_mpa must be > 0 (got %g)", l->material.E_mpa);
	if (!(l->material.nu > -1 && l->material.nu < 0.5))
		return ERR_FIELD(e, "loads", "loads: nu must be in (-1, 0.5) (got %g)",
				 l->material.nu);
	if ((rc = check_tol(o->tol, e)) != 0)
		return rc;
	if (o->max_iter < 1)
		return ERR_FIELD(e, "max_iter", "max_iter must be >= 1, not %d", o->max_iter);
	if (o->levels < 0)
		return ERR_FIELD(e, "levels", "levels must be >= 0 (0 = automatic), not %d",
				 o->levels);
	if (!(o->jacobi_w > 0 && o->jacobi_w < 2))
		return ERR_FIELD(e, "jacobi_w", "Jacobi weight must be in (0, 2), not %g",
				 o->jacobi_w);
	if (o->smooth < 1 || o->smooth > 50)
		return ERR_FIELD(e, "smooth", "smoothing sweeps must be in 1..50, not %d", o->smooth);
	if (!(o->penal >= 1 && o->penal <= 10))
		return ERR_FIELD(e, "penal", "SIMP exponent must be in [1, 10], not %g", o->penal);
	if (!(o->rho_min > 0 && o->rho_min <= 1))
		return ERR_FIELD(e, "rho_min", "rho_min must be in (0, 1], not %g", o->rho_min);
	return 0;
}

/* w0 from rho (caller's layout) into the padded layout; checks a changed
 * rho keeps the set of present elements when `same` is set. */
static int fill_weights(struct fea_solver *s, const float *rho, int same, struct err *e)
{
	size_t present = 0;

	for (int k = 0; k < s->uz; k++)
		for (int j = 0; j < s->uy; j++)
			for (int i = 0; i < s->ux; i++) {
				size_t ue = ((size_t)k * s->uy + j) * s->ux + i;
				ptrdiff_t pe = fea_n0(s, i, j, k);
				double r = rho[ue], w = 0;
				if (!isfinite(r) || r < 0)
					return ERR_FIELD(e, "rho",
							 "density of element %d,%d,%d is %g (not in [0, 1])",
							 i, j, k, r);
				if (r > 0) {
					r = r < s->opt.rho_min ? s->opt.rho_min : r > 1 ? 1 : r;
					w = pow(r, s->opt.penal);
					present++;
				}
				if (same && (w > 0) != (s->w0[pe] > 0))
					return ERR_FIELD(e, "rho",
							 "element %d,%d,%d changed between absent and "
							 "present (a new solver is needed)",
							 i, j, k);
				if (!same)
					s->w0[pe] = (float)w;
			}
	if (same)
		for (int k = 0; k < s->uz; k++)
			for (int j = 0; j < s->uy; j++)
				for (int i = 0; i < s->ux; i++) {
					size_t ue = ((size_t)k * s->uy + j) * s->ux + i;
					ptrdiff_t pe = fea_n0(s, i, j, k);
					double r = rho[ue];
					if (r > 0) {
						r = r < s->opt.rho_min ? s->opt.rho_min : r > 1 ? 1 : r;
						s->w0[pe] = (float)pow(r, s->opt.penal);
					}
				}
	s->elements = present;
	return 0;
}

static void count_dofs(struct fea_solver *s)
{
	s->dofs = 0;
	for (ptrdiff_t n = 0; n < s->cs; n++)
		for (int a = 0; a < 3; a++)
			s->dofs += !(s->mask0[n] & (1u << a));
}

int fea_solver_new(const struct fea_grid *g, const struct fea_loads *l, const struct fea_opts *o,
		   struct fea_solver **out, struct err *e)
{
	struct fea_opts od;
	struct fea_solver *s;
	int n[3], rc, nlev;
	double t0 = now_s(), est = 0, phys;

	if (!o) {
		fea_opts_default(&od);
		o = &od;
	}
	if ((rc = check_inputs(g, l, o, e)))
		return rc;
	n[0] = g->nx;
	n[1] = g->ny;
	n[2] = g->nz;
	nlev = pick_levels(n, o->levels);

	/* memory estimate before allocating (ERR_LIMIT beyond physical memory):
	 * level 0 per node (halo included): 4 double and 4 float vectors of
	 * 3, weights, mask; the caller's f and u; level 1 and below (1/7 of
	 * it) per node: half stencils and 4 double vectors */
	{
		int m = 1 << (nlev - 1);
		double nn0 = 1, nn1 = 1;
		for (int a = 0; a < 3; a++) {
			nn0 *= ceil_div(n[a], m) * m + 3;
			nn1 *= ceil_div(n[a], m) * m / 2 + 1;
		}
		est = nn0 * (4 * 24 + 4 * 12 + 5) +
		      48.0 * (g->nx + 1.0) * (g->ny + 1.0) * (g->nz + 1.0);
		if (nlev > 1)
			est += nn1 * (FEA_ST * 9 * 4 + 4 * 24) * 8 / 7;
		phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGE_SIZE);
		if (phys > 0 && est > phys)
			return ERR_SET(e, ERR_LIMIT,
				       "fea grid %dx%dx%d needs about %.0f MB, more than the %.0f MB of "
				       "memory",
				       g->nx, g->ny, g->nz, est / 1e6, phys / 1e6);
	}

	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the fea solver");
	s->mem_bytes = sizeof *s;
	s->ux = g->nx;
	s->uy = g->ny;
	s->uz = g->nz;
	s->un_nodes = (size_t)(g->nx + 1) * (size_t)(g->ny + 1) * (size_t)(g->nz + 1);
	s->un_elems = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz;
	s->h_mm = g->h_mm;
	s->mat = l->material;
	s->opt = *o;
	s->threads = o->threads < 1 ? 1 : o->threads;
	s->nlev = nlev;
	for (int lev = 0; lev < nlev; lev++) {
		struct fea_level *lv = &s->lv[lev];
		int m = 1 << (nlev - 1);
		size_t cs;
		lv->nx = ceil_div(g->nx, m) * m >> lev;
		lv->ny = ceil_div(g->ny, m) * m >> lev;
		lv->nz = ceil_div(g->nz, m) * m >> lev;
		/* the layout of fea_int.h; + one row: the last plane's last row
		 * reads the next row */
		lv->sx = (lv->nx + 2 + 7) / 8 * 8;
		lv->sy = lv->ny + 2;
		lv->sz = lv->nz + 3;
		lv->cs = (lv->sx * lv->sy * lv->sz + lv->sx + 15) / 16 * 16;
		cs = (size_t)lv->cs;
		if (lev == 0)
			continue;
		lv->invd = alloc0(s, 3 * cs, sizeof(float));
		lv->x = alloc0(s, 3 * cs, sizeof(float));
		lv->t = alloc0(s, 3 * cs, sizeof(float));
		lv->b = alloc0(s, 3 * cs, sizeof(float));
		lv->st = alloc0(s, cs * FEA_ST * 9, sizeof(float));
		if (!lv->invd || !lv->x || !lv->t || !lv->b || !lv->st)
			goto nomem;
	}
	{
		const struct fea_level *L0 = &s->lv[0];
		size_t cs, v;
		s->sx = L0->sx;
		s->sy = L0->sy;
		s->sz = L0->sz;
		s->cs = L0->cs;
		cs = (size_t)s->cs;
		v = 3 * cs;
		s->w0 = alloc0(s, cs, sizeof(float));
		s->mask0 = alloc0(s, cs, 1);
		s->invd0 = alloc0(s, v, sizeof(float));
		s->b0 = alloc0(s, v, sizeof(float));
		s->x0 = alloc0(s, v, sizeof(float));
		s->t0 = alloc0(s, v, sizeof(float));
		s->u = alloc0(s, v, sizeof(double));
		s->r = alloc0(s, v, sizeof(double));
		s->p = alloc0(s, v, sizeof(double));
		s->q = alloc0(s, v, sizeof(double));
		s->plane_part = alloc_count(s, (size_t)s->lv[0].nz + 1, sizeof(double));
		s->f_user = alloc_count(s, 3 * s->un_nodes, sizeof(double));
		s->u_user = alloc_count(s, 3 * s->un_nodes, sizeof(double));
		if (!s->w0 || !s->mask0 || !s->invd0 || !s->b0 || !s->x0 || !s->t0 || !s->u ||
		    !s->r || !s->p || !s->q || !s->plane_part || !s->f_user || !s->u_user)
			goto nomem;
	}

	fea_element_matrix(s->mat, s->h_mm, s->ke);
	s->kdiag = s->ke[0];
	fea_k0_init(s);
	for (int c = 0; c < 8; c++) {
		double t[24 * 24];
		fea_child_prolong(c, s->pc[c]);
		for (int r = 0; r < 24; r++)
			for (int cc = 0; cc < 24; cc++) {
				double sum = 0;
				for (int x = 0; x < 24; x++)
					sum += s->ke[r * 24 + x] * s->pc[c][x * 24 + cc];
				t[r * 24 + cc] = sum;
			}
		for (int r = 0; r < 24; r++)
			for (int cc = 0; cc < 24; cc++) {
				double sum = 0;
				for (int x = 0; x < 24; x++)
					sum += s->pc[c][x * 24 + r] * t[x * 24 + cc];
				s->mc[c][r * 24 + cc] = sum;
				s->msum[r * 24 + cc] += sum;
			}
	}
	if ((rc = fill_weights(s, g->rho, 0, e)))
		goto fail;
	if ((rc = fea_select(s, g, l, e)))
		goto fail;
	count_dofs(s);
	if ((rc = fea_spans_build(s, e)) || (rc = fea_mg_build(s, e)))
		goto fail;
	s->mem_bytes += (size_t)(s->co.kd + 1) * (size_t)s->co.n * sizeof(double) +
			(size_t)s->co.n * sizeof(double);
	s->setup_s = now_s() - t0;
	*out = s;
	return 0;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "out of memory for the fea solver (%dx%dx%d elements)", g->nx,
		     g->ny, g->nz);
fail:
	fea_solver_free(s);
	return rc;
}

int fea_solver_set_rho(struct fea_solver *s, const float *rho, struct err *e)
{
	double t0 = now_s();
	int rc;

	if ((rc = fill_weights(s, rho, 1, e)))
		return rc;
	if ((rc = fea_mg_build(s, e)))
		return rc;
	s->setup_s += now_s() - t0;
	return 0;
}

double *fea_solver_force(struct fea_solver *s)
{
	return s->f_user;
}

const double *fea_displacement(const struct fea_solver *s)
{
	return s->u_user;
}

/* Copy between the caller's layout and level 0's (masked unknowns 0). */
static void user_to_padded(const struct fea_solver *s, const double *user, double *pad)
{
	memset(pad, 0, 3 * (size_t)s->cs * sizeof *pad);
	for (int k = 0; k <= s->uz; k++)
		for (int j = 0; j <= s->uy; j++)
			for (int i = 0; i <= s->ux; i++) {
				size_t un = ((size_t)k * (s->uy + 1) + j) * (s->ux + 1) + i;
				ptrdiff_t pn = fea_n0(s, i, j, k);
				for (int a = 0; a < 3; a++)
					if (!(s->mask0[pn] & (1u << a)))
						pad[a * s->cs + pn] = user[3 * un + a];
			}
}

static void padded_to_user(const struct fea_solver *s, const double *pad, double *user)
{
	for (int k = 0; k <= s->uz; k++)
		for (int j = 0; j <= s->uy; j++)
			for (int i = 0; i <= s->ux; i++) {
				size_t un = ((size_t)k * (s->uy + 1) + j) * (s->ux + 1) + i;
				ptrdiff_t pn = fea_n0(s, i, j, k);
				for (int a = 0; a < 3; a++)
					user[3 * un + a] = pad[a * s->cs + pn];
			}
}

int fea_solver_set_tol(struct fea_solver *s, double tol, struct err *e)
{
	int rc = check_tol(tol, e);

	if (rc == 0)
		s->opt.tol = tol;
	return rc;
}

int fea_solve(struct fea_solver *s, struct fea_result *res, struct err *e)
{
	const size_t nv = 3 * (size_t)s->cs;
	double t0 = now_s(), fnorm, rr, rz, rel = 0, true_rel = 0;
	int it = 0, converged = 0;
	struct fea_result R;

	memset(&R, 0, sizeof R);
	/* r = f - A u (u: previous solution, 0 at first) */
	user_to_padded(s, s->f_user, s->r);
	fnorm = sqrt(fea_vec_rr(s));
	if (!(fnorm > 0)) {
		memset(s->u, 0, nv * sizeof *s->u);
		converged = 1;
	}
	for (int restart = 0, stalls = 0; !converged && stalls < 3; restart++) {
		/* (re)start from the true residual r = f - A u */
		int it0 = it;

		user_to_padded(s, s->f_user, s->r);
		fea_apply0d(s, s->u, s->q);
		rr = fea_vec_sub_q(s);
		rel = sqrt(rr) / fnorm;
		if (rel <= s->opt.tol) {
			converged = 1;
			break;
		}
		/* a restart that gains less than a factor 2: the tolerance is
		 * below what rounding in A u allows (about 1e-16 times the
		 * stiffness contrast) */
		stalls = restart > 0 && rel > 0.5 * true_rel ? stalls + 1 : 0;
		true_rel = rel;
		if (it >= s->opt.max_iter)
			break;
		fea_vcycle(s, s->r);
		fea_vec_p_copy(s);
		rz = fea_vec_rz(s);
		while (it < s->opt.max_iter && rz > 0) {
			double pq, alpha, beta, rz_new, rz_old;

			pq = fea_apply0d_dot(s, s->p, s->q);
			if (!(pq > 0))
				break; /* breakdown: restart from the true residual */
			alpha = rz / pq;
			fea_vec_update(s, alpha, &rr, &rz_old);
			it++;
			rel = sqrt(rr) / fnorm;
			if (rel <= s->opt.tol)
				break; /* confirmed on the true residual at the restart */
			/* flexible (Polak-Ribiere) beta: the float V-cycle is not
			 * exactly linear, so keep r_new . z_old out of beta */
			fea_vcycle(s, s->r);
			rz_new = fea_vec_rz(s);
			beta = (rz_new - rz_old) / rz;
			rz = rz_new;
			fea_vec_p(s, beta);
		}
		if (it == it0)
			break; /* no progress (breakdown at once) */
	}
	if (!converged)
		return ERR_SET(e, ERR_GEOMETRY,
			       "the solver did not converge: relative residual %.3g after %d CG "
			       "iterations (tolerance %g)",
			       true_rel > 0 ? true_rel : rel, it, s->opt.tol);
	padded_to_user(s, s->u, s->u_user);
	{
		double c = 0, mx = 0;
		for (size_t n = 0; n < s->un_nodes; n++) {
			const double *u = &s->u_user[3 * n], *f = &s->f_user[3 * n];
			double m2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
			c += f[0] * u[0] + f[1] * u[1] + f[2] * u[2];
			mx = m2 > mx ? m2 : mx;
		}
		R.compliance_nmm = c;
		R.max_displacement_mm = sqrt(mx);
	}
	R.residual = rel;
	R.iterations = it;
	R.levels = s->nlev;
	R.elements = s->elements;
	R.dofs = s->dofs;
	R.held_nodes = s->held_nodes;
	R.mem_bytes = s->mem_bytes;
	R.solve_s = now_s() - t0 + s->setup_s;
	s->setup_s = 0;
	s->solved = 1;
	*res = R;
	return 0;
}

/* The caller's element (i, j, k): its 24 displacements and weight. */
static double element_u(const struct fea_solver *s, int i, int j, int k, double ue[24])
{
	for (int a = 0; a < 8; a++) {
		size_t n = ((size_t)(k + ((a >> 2) & 1)) * (s->uy + 1) + (j + ((a >> 1) & 1))) *
				   (s->ux + 1) +
			   (i + (a & 1));
		for (int x = 0; x < 3; x++)
			ue[3 * a + x] = s->u_user[3 * n + x];
	}
	return s->w0[fea_n0(s, i, j, k)];
}

void fea_element_energy(const struct fea_solver *s, float *out)
{
	for (int k = 0; k < s->uz; k++)
		for (int j = 0; j < s->uy; j++)
			for (int i = 0; i < s->ux; i++) {
				double ue[24], en = 0;
				size_t el = ((size_t)k * s->uy + j) * s->ux + i;
				if (!(element_u(s, i, j, k, ue) > 0)) {
					out[el] = 0;
					continue;
				}
				for (int r = 0; r < 24; r++) {
					double t = 0;
					for (int c = 0; c < 24; c++)
						t += s->ke[r * 24 + c] * ue[c];
					en += ue[r] * t;
				}
				out[el] = (float)en;
			}
}

void fea_element_stress(const struct fea_solver *s, float *vm, const uint8_t *mask,
			double mean6[6])
{
	double d[36], b[6 * 24], sum[6] = {0};
	size_t count = 0;

	fea_dmatrix(s->mat, d);
	fea_bcentre(s->h_mm, b);
	for (int k = 0; k < s->uz; k++)
		for (int j = 0; j < s->uy; j++)
			for (int i = 0; i < s->ux; i++) {
				double ue[24], eps[6], sg[6], w;
				size_t el = ((size_t)k * s->uy + j) * s->ux + i;
				w = element_u(s, i, j, k, ue);
				if (!(w > 0)) {
					if (vm)
						vm[el] = 0;
					continue;
				}
				for (int r = 0; r < 6; r++) {
					eps[r] = 0;
					for (int c = 0; c < 24; c++)
						eps[r] += b[r * 24 + c] * ue[c];
				}
				for (int r = 0; r < 6; r++) {
					sg[r] = 0;
					for (int c = 0; c < 6; c++)
						sg[r] += w * d[r * 6 + c] * eps[c];
				}
				if (vm) {
					double a = sg[0] - sg[1], bb = sg[1] - sg[2], c = sg[2] - sg[0];
					vm[el] = (float)sqrt(0.5 * (a * a + bb * bb + c * c) +
							     3 * (sg[3] * sg[3] + sg[4] * sg[4] +
								  sg[5] * sg[5]));
				}
				if (mean6 && (!mask || mask[el])) {
					for (int r = 0; r < 6; r++)
						sum[r] += sg[r];
					count++;
				}
			}
	if (mean6)
		for (int r = 0; r < 6; r++)
			mean6[r] = count ? sum[r] / (double)count : 0;
}
