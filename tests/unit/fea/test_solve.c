/* test_solve.c - the FEA solver (fea.h) against independent answers:
 * a dense direct solve of the same model assembled here (absent and
 * rho_min elements, several multigrid depths), the patch test (uniform
 * strain reproduced exactly), mirror symmetry, Timoshenko's cantilever
 * (and the error shrinking with refinement), a thin-walled lattice with
 * rho_min voids, warm starts after fea_solver_set_rho, element energy
 * and stress outputs.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"

static const struct fea_material MAT = {1000, 0.3};

static void grid_box(struct fea_grid *g, int nx, int ny, int nz, double h)
{
	memset(g, 0, sizeof *g);
	g->nx = nx;
	g->ny = ny;
	g->nz = nz;
	g->h_mm = h;
	g->part_hi_mm = (struct vec3){nx * h, ny * h, nz * h};
	g->rho = mem_alloc((size_t)nx * ny * nz * sizeof *g->rho);
	for (size_t i = 0; i < (size_t)nx * ny * nz; i++)
		g->rho[i] = 1;
}

static size_t node_of(const struct fea_grid *g, int i, int j, int k)
{
	return ((size_t)k * (g->ny + 1) + j) * (g->nx + 1) + i;
}

static int solve_text(const struct fea_grid *g, const char *loads, const struct fea_opts *o,
		      struct fea_solver **s, struct fea_result *r, struct err *e)
{
	struct fea_loads l;
	int rc = fea_loads_parse(loads, MAT, &l, e);

	if (rc)
		return rc;
	rc = fea_solver_new(g, &l, o, s, e);
	fea_loads_fini(&l);
	if (rc)
		return rc;
	rc = fea_solve(*s, r, e);
	if (rc) {
		fea_solver_free(*s);
		*s = NULL;
	}
	return rc;
}

/* Dense Cholesky solve of a (n x n, row-major, SPD) x = b in place. */
static int dense_solve(double *a, double *b, int n)
{
	for (int j = 0; j < n; j++) {
		double d = a[(size_t)j * n + j];
		for (int k = 0; k < j; k++)
			d -= a[(size_t)j * n + k] * a[(size_t)j * n + k];
		if (!(d > 0))
			return -1;
		d = sqrt(d);
		a[(size_t)j * n + j] = d;
		for (int i = j + 1; i < n; i++) {
			double v = a[(size_t)i * n + j];
			for (int k = 0; k < j; k++)
				v -= a[(size_t)i * n + k] * a[(size_t)j * n + k];
			a[(size_t)i * n + j] = v / d;
		}
	}
	for (int i = 0; i < n; i++) {
		double v = b[i];
		for (int k = 0; k < i; k++)
			v -= a[(size_t)i * n + k] * b[k];
		b[i] = v / a[(size_t)i * n + i];
	}
	for (int i = n - 1; i >= 0; i--) {
		double v = b[i];
		for (int k = i + 1; k < n; k++)
			v -= a[(size_t)k * n + i] * b[k];
		b[i] = v / a[(size_t)i * n + i];
	}
	return 0;
}

/* The same model assembled densely: K = sum rho^3 K0 over present
 * elements, fixed = x = 0 face nodes (all axes), free = the rest of the
 * nodes touching an element; compare u. */
static void check_dense(int levels, int smooth)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	double ke[576];
	const int nx = 6, ny = 4, nz = 3;
	size_t nn = (size_t)(nx + 1) * (ny + 1) * (nz + 1);
	int *id = mem_alloc(3 * nn * sizeof *id), nf = 0;
	uint8_t *touch = mem_calloc(nn, 1);

	err_clear(&e);
	grid_box(&g, nx, ny, nz, 0.5);
	/* absent elements, rho_min elements, a graded one */
	g.rho[(0 * ny + 3) * nx + 5] = 0;
	g.rho[(2 * ny + 3) * nx + 5] = 0;
	g.rho[(1 * ny + 1) * nx + 3] = 0;
	g.rho[(2 * ny + 0) * nx + 2] = 0.001f;
	g.rho[(1 * ny + 2) * nx + 4] = 0.001f;
	g.rho[(0 * ny + 0) * nx + 1] = 0.5f;
	g.rho[(2 * ny + 2) * nx + 5] = 0.0001f; /* clamped to rho_min */
	fea_opts_default(&o);
	o.levels = levels;
	o.smooth = smooth;
	o.tol = 1e-12;
	REQUIRE_OK(solve_text(&g,
			      "fixed box=0,0,0,0,2,1.5 axes=xyz; force box=3,0,1.5,3,2,1.5 "
			      "n=0.3,-0.2,-1; force box=1,1,0,2,2,0 n=0,0.5,0",
			      &o, &s, &r, &e),
		   &e);
	CHECK_EQ_INT(r.levels, levels);
	for (int k = 0; k < nz; k++)
		for (int j = 0; j < ny; j++)
			for (int i = 0; i < nx; i++)
				if (g.rho[(k * ny + j) * nx + i] > 0)
					for (int c = 0; c < 8; c++)
						touch[node_of(&g, i + (c & 1), j + ((c >> 1) & 1),
							      k + ((c >> 2) & 1))] = 1;
	for (int k = 0; k <= nz; k++)
		for (int j = 0; j <= ny; j++)
			for (int i = 0; i <= nx; i++)
				for (int a = 0; a < 3; a++)
					id[3 * node_of(&g, i, j, k) + a] =
						(i == 0 || !touch[node_of(&g, i, j, k)]) ? -1 : nf++;
	CHECK_EQ_INT(r.dofs, nf);
	double *K = mem_calloc((size_t)nf * nf, sizeof *K), *b = mem_calloc(nf, sizeof *b);
	const double *f = fea_solver_force(s), *u = fea_displacement(s);
	fea_element_matrix(MAT, g.h_mm, ke);
	for (int k = 0; k < nz; k++)
		for (int j = 0; j < ny; j++)
			for (int i = 0; i < nx; i++) {
				double rho = g.rho[(k * ny + j) * nx + i];
				int dof[24];
				if (!(rho > 0))
					continue;
				rho = rho < 0.001 ? 0.001 : rho;
				for (int c = 0; c < 8; c++)
					for (int a = 0; a < 3; a++)
						dof[3 * c + a] = id[3 * node_of(&g, i + (c & 1),
										 j + ((c >> 1) & 1),
										 k + ((c >> 2) & 1)) +
								    a];
				for (int p = 0; p < 24; p++)
					for (int q = 0; q < 24; q++)
						if (dof[p] >= 0 && dof[q] >= 0)
							K[(size_t)dof[p] * nf + dof[q]] +=
								rho * rho * rho * ke[p * 24 + q];
			}
	double fsum[3] = {0, 0, 0};
	for (size_t n = 0; n < nn; n++)
		for (int a = 0; a < 3; a++) {
			fsum[a] += f[3 * n + a];
			if (id[3 * n + a] >= 0)
				b[id[3 * n + a]] = f[3 * n + a];
		}
	CHECK_NEAR(fsum[0], 0.3, 1e-12);
	CHECK_NEAR(fsum[1], 0.3, 1e-12);
	CHECK_NEAR(fsum[2], -1, 1e-12);
	REQUIRE(dense_solve(K, b, nf) == 0);
	double umax = 0, err = 0, comp = 0;
	for (size_t n = 0; n < nn; n++)
		for (int a = 0; a < 3; a++) {
			double ud = id[3 * n + a] >= 0 ? b[id[3 * n + a]] : 0;
			umax = fmax(umax, fabs(ud));
			err = fmax(err, fabs(ud - u[3 * n + a]));
			comp += f[3 * n + a] * ud;
		}
	CHECK_NUM(err, <=, 1e-6 * umax);
	CHECK_REL(r.compliance_nmm, comp, 1e-6);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "dense: levels %d smooth %d: %d iterations, max |u| %.6g, err %.3g\n",
			levels, smooth, r.iterations, umax, err);
	mem_free(K);
	mem_free(b);
	mem_free(id);
	mem_free(touch);
	fea_solver_free(s);
	fea_grid_fini(&g);
}

static void test_dense_direct(void)
{
	check_dense(1, 2);
	check_dense(2, 2);
	check_dense(3, 1);
	check_dense(3, 3);
}

/* Uniform uniaxial stress sigma along x: rollers on the three min faces,
 * consistent nodal forces sigma h^2 / 4 per face corner on x = max. */
static void check_patch(int levels)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_loads l;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	const int nx = 4, ny = 4, nz = 2;
	const double h = 0.5, sigma = 2.5;

	err_clear(&e);
	grid_box(&g, nx, ny, nz, h);
	fea_opts_default(&o);
	o.levels = levels;
	o.tol = 1e-14;
	REQUIRE_OK(fea_loads_parse("fixed box=0,0,0,0,2,1 axes=x; fixed box=0,0,0,2,0,1 axes=y;"
				   "fixed box=0,0,0,2,2,0 axes=z",
				   MAT, &l, &e),
		   &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	fea_loads_fini(&l);
	double *f = fea_solver_force(s);
	memset(f, 0, 3 * sizeof *f * (size_t)(nx + 1) * (ny + 1) * (nz + 1));
	for (int k = 0; k < nz; k++)
		for (int j = 0; j < ny; j++)
			for (int c = 0; c < 4; c++)
				f[3 * node_of(&g, nx, j + (c & 1), k + (c >> 1))] += sigma * h * h / 4;
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	const double *u = fea_displacement(s);
	double worst = 0, scale = sigma * nx * h / MAT.E_mpa;
	for (int k = 0; k <= nz; k++)
		for (int j = 0; j <= ny; j++)
			for (int i = 0; i <= nx; i++) {
				const double *un = u + 3 * node_of(&g, i, j, k);
				double ex = sigma * i * h / MAT.E_mpa;
				double ey = -MAT.nu * sigma * j * h / MAT.E_mpa;
				double ez = -MAT.nu * sigma * k * h / MAT.E_mpa;
				worst = fmax(worst, fabs(un[0] - ex));
				worst = fmax(worst, fabs(un[1] - ey));
				worst = fmax(worst, fabs(un[2] - ez));
			}
	CHECK_NUM(worst, <=, 1e-8 * scale);
	double mean6[6];
	float vm[32];
	fea_element_stress(s, vm, NULL, mean6);
	CHECK_REL(mean6[0], sigma, 1e-8);
	for (int a = 1; a < 6; a++)
		CHECK_NEAR(mean6[a], 0, 1e-8 * sigma);
	for (int el = 0; el < nx * ny * nz; el++)
		CHECK_REL(vm[el], sigma, 1e-6);
	/* energy: u_e^T K0 u_e = sigma^2 / E * h^3 per element (twice the
	 * strain energy density times the volume) */
	float en[32];
	fea_element_energy(s, en);
	for (int el = 0; el < nx * ny * nz; el++)
		CHECK_REL(en[el], sigma * sigma / MAT.E_mpa * h * h * h, 1e-6);
	CHECK_REL(r.compliance_nmm, sigma * sigma / MAT.E_mpa * nx * ny * nz * h * h * h, 1e-8);
	fea_solver_free(s);
	fea_grid_fini(&g);
}

static void test_patch(void)
{
	check_patch(1);
	check_patch(2);
}

/* Fixed at both ends, loaded at the middle of the top: mirror images in
 * x and y. */
static void test_symmetry(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	const int nx = 16, ny = 6, nz = 4;

	err_clear(&e);
	grid_box(&g, nx, ny, nz, 1);
	fea_opts_default(&o);
	o.levels = 3;
	o.tol = 1e-11;
	REQUIRE_OK(solve_text(&g,
			      "fixed box=0,0,0,0,6,4; fixed box=16,0,0,16,6,4; "
			      "force box=7,2,4,9,4,4 n=0.2,0,-10",
			      &o, &s, &r, &e),
		   &e);
	const double *u = fea_displacement(s);
	double worst = 0;
	for (int k = 0; k <= nz; k++)
		for (int j = 0; j <= ny; j++)
			for (int i = 0; i <= nx; i++) {
				const double *a = u + 3 * node_of(&g, i, j, k);
				const double *by = u + 3 * node_of(&g, i, ny - j, k);
				/* the load has an x part: mirror in y only */
				worst = fmax(worst, fabs(a[0] - by[0]));
				worst = fmax(worst, fabs(a[1] + by[1]));
				worst = fmax(worst, fabs(a[2] - by[2]));
			}
	CHECK_NUM(worst, <=, 1e-7 * r.max_displacement_mm);
	fea_solver_free(s);
	REQUIRE_OK(solve_text(&g,
			      "fixed box=0,0,0,0,6,4; fixed box=16,0,0,16,6,4; "
			      "force box=7,2,4,9,4,4 n=0,0,-10",
			      &o, &s, &r, &e),
		   &e);
	u = fea_displacement(s);
	worst = 0;
	for (int k = 0; k <= nz; k++)
		for (int j = 0; j <= ny; j++)
			for (int i = 0; i <= nx; i++) {
				const double *a = u + 3 * node_of(&g, i, j, k);
				const double *bx = u + 3 * node_of(&g, nx - i, j, k);
				const double *by = u + 3 * node_of(&g, i, ny - j, k);
				worst = fmax(worst, fabs(a[0] + bx[0]));
				worst = fmax(worst, fabs(a[1] - bx[1]));
				worst = fmax(worst, fabs(a[2] - bx[2]));
				worst = fmax(worst, fabs(a[0] - by[0]));
				worst = fmax(worst, fabs(a[1] + by[1]));
				worst = fmax(worst, fabs(a[2] - by[2]));
			}
	CHECK_NUM(worst, <=, 1e-7 * r.max_displacement_mm);
	CHECK_NUM(r.max_displacement_mm, >, 0);
	fea_solver_free(s);
	fea_grid_fini(&g);
}

/* Cantilever L = 40, b = d = 4 mm, E = 1000, nu = 0.3, clamped at x = 0,
 * F = 1 N down spread over the tip face.  Timoshenko: F L^3 / (3 E I) +
 * F L / (kappa G A), kappa = 10 (1 + nu) / (12 + 11 nu).  Tip deflection:
 * the mean u_z of the tip face. */
static double cantilever_error(int m, int *levels, int *iters, double *tip_mm)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	const double L = 40, b = 4, d = 4, F = 1;
	double I = b * d * d * d / 12, A = b * d, G = MAT.E_mpa / (2 * (1 + MAT.nu));
	double kappa = 10 * (1 + MAT.nu) / (12 + 11 * MAT.nu);
	double ref = F * L * L * L / (3 * MAT.E_mpa * I) + F * L / (kappa * G * A), tip = 0;
	int cnt = 0;

	err_clear(&e);
	grid_box(&g, 10 * m, m, m, d / m);
	fea_opts_default(&o);
	o.tol = 1e-9;
	if (solve_text(&g, "fixed box=0,0,0,0,4,4; force box=40,0,0,40,4,4 n=0,0,-1", &o, &s, &r,
		       &e)) {
		fprintf(stderr, "cantilever m=%d: %s\n", m, e.msg);
		fea_grid_fini(&g);
		return 1;
	}
	const double *u = fea_displacement(s);
	for (int k = 0; k <= m; k++)
		for (int j = 0; j <= m; j++) {
			tip += u[3 * node_of(&g, 10 * m, j, k) + 2];
			cnt++;
		}
	tip = -tip / cnt;
	*tip_mm = tip;
	/* compliance = f . u over the loaded nodes (the load is spread by
	 * stiffness: 1 : 2 : 4 at the end face's corners, edges and inside) */
	{
		const double *f = fea_solver_force(s);
		double fu = 0;
		size_t nn = (size_t)(10 * m + 1) * (m + 1) * (m + 1);
		for (size_t q = 0; q < 3 * nn; q++)
			fu += f[q] * u[q];
		CHECK_REL(r.compliance_nmm, fu, 1e-9);
	}
	*levels = r.levels;
	*iters = r.iterations;
	fea_solver_free(s);
	fea_grid_fini(&g);
	return (tip - ref) / ref;
}

static void test_cantilever(void)
{
	const int ms[] = {2, 3, 4, 6, 8, 12, 16};
	double errs[7];

	for (int i = 0; i < 7; i++) {
		int lev = 0, it = 0;
		double tip = 0;
		errs[i] = cantilever_error(ms[i], &lev, &it, &tip);
		if (getenv("HARNESS_VERBOSE"))
			fprintf(stderr, "cantilever %d elements through the depth (h %.4g mm): tip %.5f mm "
					"= compliance %.5f N mm, error %+.2f %% (levels %d, %d "
					"iterations)\n",
				ms[i], 4.0 / ms[i], tip, tip, 100 * errs[i], lev, it);
	}
	CHECK_NUM(fabs(errs[2]), <=, 0.05);
	for (int i = 1; i < 7; i++)
		CHECK_NUM(fabs(errs[i]), <, fabs(errs[i - 1]));
	CHECK_NUM(fabs(errs[4]), <=, 0.02);
	CHECK_NUM(fabs(errs[6]), <=, 0.012);
}

/* Walls 2 voxels thick every 10 voxels in x, y and z, the rest rho_min:
 * stiffness contrast 1e-9.  Converges to 1e-6. */
static void test_lattice(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	const int n = 40;

	err_clear(&e);
	grid_box(&g, n, n, n, 0.5);
	for (int k = 0; k < n; k++)
		for (int j = 0; j < n; j++)
			for (int i = 0; i < n; i++) {
				int wall = i % 10 < 2 || j % 10 < 2 || k % 10 < 2;
				g.rho[((size_t)k * n + j) * n + i] = wall ? 1 : 0.001f;
			}
	fea_opts_default(&o);
	o.threads = 2;
	REQUIRE_OK(solve_text(&g, "", &o, &s, &r, &e), &e);
	CHECK_NUM(r.residual, <=, 1e-6);
	CHECK_NUM(r.max_displacement_mm, >, 0);
	fprintf(stderr, "lattice %d^3 with rho_min voids: %d levels, %d iterations, residual %.2g, "
			"%.2f s\n",
		n, r.levels, r.iterations, r.residual, r.solve_s);
	CHECK_INT(r.iterations, <=, 200);
	fea_solver_free(s);
	fea_grid_fini(&g);
}

/* set_rho: the same answer as a fresh solver, from a warm start. */
static void test_set_rho(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_loads l;
	struct fea_solver *s = NULL, *s2 = NULL;
	struct fea_result r, r2;
	struct err e;
	const int n = 16;

	err_clear(&e);
	grid_box(&g, n, n, n, 1);
	fea_opts_default(&o);
	o.tol = 1e-9;
	REQUIRE_OK(fea_loads_parse("", MAT, &l, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	int it_cold = r.iterations;
	for (size_t i = 0; i < (size_t)n * n * n; i++)
		g.rho[i] = (i % 7 == 0) ? 0.9f : 1.0f;
	REQUIRE_OK(fea_solver_set_rho(s, g.rho, &e), &e);
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s2, &e), &e);
	/* the same nodal loads (a fresh solver spreads them by the new densities) */
	memcpy(fea_solver_force(s2), fea_solver_force(s),
	       3 * (size_t)(n + 1) * (n + 1) * (n + 1) * sizeof(double));
	REQUIRE_OK(fea_solve(s2, &r2, &e), &e);
	CHECK_REL(r.compliance_nmm, r2.compliance_nmm, 1e-7);
	CHECK_INT(r.iterations, <, r2.iterations);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "set_rho: cold %d, warm %d, fresh %d iterations\n", it_cold,
			r.iterations, r2.iterations);
	/* a present element may not become absent */
	g.rho[5] = 0;
	CHECK_EQ_INT(fea_solver_set_rho(s, g.rho, &e), ERR_PARAM);
	CHECK_STR(e.field, "rho");
	fea_loads_fini(&l);
	fea_solver_free(s);
	fea_solver_free(s2);
	fea_grid_fini(&g);
}

/* set_tol: a loose solve stops early, tightening continues from it to the
 * fresh tight answer; tolerances outside (0, 1) are refused. */
static void test_set_tol(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_loads l;
	struct fea_solver *s = NULL, *s2 = NULL;
	struct fea_result loose, tight, fresh;
	struct err e;
	const int n = 24;

	err_clear(&e);
	grid_box(&g, n, n / 2, n / 3, 1);
	for (size_t i = 0; i < (size_t)n * (n / 2) * (n / 3); i++)
		g.rho[i] = (i % 5 == 0) ? 0.2f : 1.0f;
	fea_opts_default(&o);
	o.tol = 1e-2;
	REQUIRE_OK(fea_loads_parse("", MAT, &l, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &loose, &e), &e);
	CHECK_NUM(loose.residual, <=, 1e-2);
	REQUIRE_OK(fea_solver_set_tol(s, 1e-8, &e), &e);
	REQUIRE_OK(fea_solve(s, &tight, &e), &e);
	CHECK_NUM(tight.residual, <=, 1e-8);
	o.tol = 1e-8;
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s2, &e), &e);
	REQUIRE_OK(fea_solve(s2, &fresh, &e), &e);
	CHECK_REL(tight.compliance_nmm, fresh.compliance_nmm, 1e-8);
	/* the loose solve stopped before the tight one's iterations */
	CHECK_INT(loose.iterations, <, fresh.iterations);
	/* and its compliance is not the tight one's to 1e-8 (it stopped early) */
	CHECK_NUM(fabs(loose.compliance_nmm / fresh.compliance_nmm - 1), >, 1e-8);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "set_tol: loose %d iterations (C %.9g), then %d more, fresh %d (C %.9g)\n",
			loose.iterations, loose.compliance_nmm, tight.iterations, fresh.iterations,
			fresh.compliance_nmm);
	CHECK_EQ_INT(fea_solver_set_tol(s, 0, &e), ERR_PARAM);
	CHECK_STR(e.field, "tol");
	CHECK_EQ_INT(fea_solver_set_tol(s, 1, &e), ERR_PARAM);
	fea_loads_fini(&l);
	fea_solver_free(s);
	fea_solver_free(s2);
	fea_grid_fini(&g);
}

/* Threads give the same answer (deterministic sums). */
static void test_threads(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r1, r2;
	struct err e;

	err_clear(&e);
	grid_box(&g, 24, 12, 10, 1);
	fea_opts_default(&o);
	REQUIRE_OK(solve_text(&g, "", &o, &s, &r1, &e), &e);
	fea_solver_free(s);
	o.threads = 2;
	REQUIRE_OK(solve_text(&g, "", &o, &s, &r2, &e), &e);
	fea_solver_free(s);
	CHECK_EQ_INT(r1.iterations, r2.iterations);
	CHECK_NUM(r1.compliance_nmm, ==, r2.compliance_nmm);
	fea_grid_fini(&g);
}

/* A long bar (rows of more than 256 coarse nodes: several chunks of the
 * prolongation) solved with 1, 2 and 3 levels: the same answer. */
static void test_long_bar(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	double c[3];

	err_clear(&e);
	grid_box(&g, 1100, 2, 4, 0.25);
	fea_opts_default(&o);
	o.tol = 1e-9;
	o.threads = 2;
	for (int lev = 1; lev <= 3; lev++) {
		o.levels = lev;
		REQUIRE_OK(solve_text(&g, "fixed box=0,0,0,0,1,1; force box=275,0,0,275,1,1 n=1,0,0",
				      &o, &s, &r, &e),
			   &e);
		c[lev - 1] = r.compliance_nmm;
		CHECK_EQ_INT(r.levels, lev);
		fea_solver_free(s);
	}
	/* axial: F^2 L / (E A) = 275 / (1000 * 0.5) */
	CHECK_REL(c[0], 275 / (1000 * 0.5), 0.01);
	CHECK_REL(c[1], c[0], 1e-7);
	CHECK_REL(c[2], c[0], 1e-7);
	fea_grid_fini(&g);
}

/* A part that fills a small share of its box (a tilted ring of
 * varying thickness with soft elements: rows with no element, rows with
 * gaps, spans that change from row to row): the multigrid solve, which
 * skips what is outside the part, against the one-level direct solve,
 * and 1 against 2 threads (bit for bit). */
static void test_sparse_box(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r[3];
	struct err e;
	const int nx = 34, ny = 30, nz = 16;
	double *u[3];
	size_t present = 0, nn = (size_t)(nx + 1) * (ny + 1) * (nz + 1);

	err_clear(&e);
	grid_box(&g, nx, ny, nz, 0.5);
	for (int k = 0; k < nz; k++)
		for (int j = 0; j < ny; j++)
			for (int i = 0; i < nx; i++) {
				double x = i - 15.5, y = j - 13.5 - 0.4 * k, rr = sqrt(x * x + y * y);
				float *rho = &g.rho[((size_t)k * ny + j) * nx + i];
				*rho = rr > 7 && rr < 10 + 0.2 * k && k < 14 ? 1 : 0;
				if (*rho > 0 && (i + 2 * j + 3 * k) % 11 == 0)
					*rho = 0.05f;
				present += *rho > 0;
			}
	CHECK_NUM((double)present, <, 0.3 * nx * ny * nz);
	fea_opts_default(&o);
	o.tol = 1e-10;
	for (int run = 0; run < 3; run++) {
		o.levels = run == 0 ? 1 : 0;
		o.threads = run == 2 ? 2 : 1;
		REQUIRE_OK(solve_text(&g, "fixed plate; force box=0,0,6.5,17,15,7 n=0.3,0,-5", &o, &s,
				      &r[run], &e),
			   &e);
		u[run] = mem_alloc(3 * nn * sizeof *u[run]);
		REQUIRE(u[run] != NULL);
		memcpy(u[run], fea_displacement(s), 3 * nn * sizeof *u[run]);
		fea_solver_free(s);
	}
	CHECK_EQ_INT(r[0].levels, 1);
	CHECK_NUM(r[1].levels, >=, 3);
	CHECK_REL(r[1].compliance_nmm, r[0].compliance_nmm, 1e-8);
	double worst = 0, umax = 0;
	for (size_t x = 0; x < 3 * nn; x++) {
		worst = fmax(worst, fabs(u[1][x] - u[0][x]));
		umax = fmax(umax, fabs(u[0][x]));
	}
	CHECK_NUM(umax, >, 0);
	CHECK_NUM(worst, <=, 1e-7 * umax);
	CHECK_EQ_INT(r[2].iterations, r[1].iterations);
	CHECK_NUM(r[2].compliance_nmm, ==, r[1].compliance_nmm);
	CHECK_EQ_INT(memcmp(u[1], u[2], 3 * nn * sizeof *u[1]), 0);
	for (int run = 0; run < 3; run++)
		mem_free(u[run]);
	fea_grid_fini(&g);
}

/* A force is spread by the stiffness around each node: on a full 4 x 4
 * face the 25 nodes carry 1 : 2 : 4 (corners, edges, inside; weights sum
 * to 64), and a node that touches only a 1 % voxel carries 1 % of a full
 * node's share. */
static void test_force_spread(void)
{
	struct fea_grid g;
	struct fea_opts o;
	struct fea_loads l;
	struct fea_solver *s = NULL;
	struct err e;

	err_clear(&e);
	grid_box(&g, 4, 4, 4, 1);
	fea_opts_default(&o);
	REQUIRE_OK(fea_loads_parse("fixed plate; force box=0,0,4,4,4,4 n=0,0,-64", MAT, &l, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	const double *f = fea_solver_force(s);
	CHECK_REL(f[3 * node_of(&g, 0, 0, 4) + 2], -1.0, 1e-12);
	CHECK_REL(f[3 * node_of(&g, 2, 0, 4) + 2], -2.0, 1e-12);
	CHECK_REL(f[3 * node_of(&g, 2, 2, 4) + 2], -4.0, 1e-12);
	fea_solver_free(s);
	/* the top corner element 1 % full: rho^p = 1e-6 */
	g.rho[(3 * 4 + 3) * 4 + 3] = 0.01f;
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	f = fea_solver_force(s);
	double wsum = 64 - 4 * (1 - 1e-6);
	CHECK_REL(f[3 * node_of(&g, 4, 4, 4) + 2], -64 * 1e-6 / wsum, 1e-4);
	CHECK_REL(f[3 * node_of(&g, 0, 0, 4) + 2], -64 / wsum, 1e-6);
	fea_solver_free(s);
	fea_loads_fini(&l);
	fea_grid_fini(&g);
}

int main(void)
{
	RUN(test_force_spread);
	RUN(test_dense_direct);
	RUN(test_patch);
	RUN(test_symmetry);
	RUN(test_cantilever);
	RUN(test_lattice);
	RUN(test_set_rho);
	RUN(test_set_tol);
	RUN(test_threads);
	RUN(test_long_bar);
	RUN(test_sparse_box);
	return harness_report();
}
