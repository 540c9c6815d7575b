/* test_bound.c - fea_relax_bound (engine/fea/bound.c) against the
 * compliances of designs solved here: with floor = ceiling the bound is
 * that one design's compliance (also under a load vector given by the
 * caller); otherwise no design of the set, random or graded, at p = 1 or
 * 3, with floors under rho_min and an absent element, is stiffer than it;
 * at p = 1 the relaxation is exact: on a bar in series the bound meets the
 * analytic optimum (the uniform design) within its gap; bad arguments get
 * errors naming them.
 */
#include "harness.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"

static const struct fea_material MAT = {1000, 0.3};
/* a cantilever: the left face fixed, a load on the right end's top edge */
static const char *const LOADS = "fixed box=0,0,0,0,3,4 axes=xyz; force box=12,0,4,12,3,4 "
				 "n=0,0,-1";

enum { NX = 12, NY = 3, NZ = 4, NE = NX * NY * NZ };

static void grid_init(struct fea_grid *g, float *rho)
{
	memset(g, 0, sizeof *g);
	g->nx = NX;
	g->ny = NY;
	g->nz = NZ;
	g->h_mm = 1;
	g->part_hi_mm = (struct vec3){NX, NY, NZ};
	g->rho = rho;
}

/* deterministic numbers in [0, 1) */
static double unit_rand(unsigned *state)
{
	*state = *state * 1103515245u + 12345u;
	return (double)((*state >> 8) & 0xffffff) / 16777216.0;
}

static double compliance(const float *rho, double penal, double rho_min)
{
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	float copy[NE];

	err_clear(&e);
	memcpy(copy, rho, sizeof copy);
	grid_init(&g, copy);
	fea_opts_default(&o);
	o.penal = penal;
	o.rho_min = rho_min;
	o.tol = 1e-10;
	if (fea_loads_parse(LOADS, MAT, &l, &e))
		return NAN;
	if (fea_solver_new(&g, &l, &o, &s, &e) || fea_solve(s, &r, &e))
		r.compliance_nmm = NAN;
	fea_solver_free(s);
	fea_loads_fini(&l);
	return r.compliance_nmm;
}

static int bound(const float *floor_rho, const float *ceil_rho, double vol, double penal,
		 struct fea_bound *b, struct err *e)
{
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_bound_opts bo = {.max_iter = 400, .gap = 1e-3};
	float copy[NE];
	int rc;

	memcpy(copy, floor_rho, sizeof copy);
	grid_init(&g, copy);
	fea_opts_default(&o);
	o.penal = penal;
	o.rho_min = 0.01;
	o.tol = 1e-10;
	if ((rc = fea_loads_parse(LOADS, MAT, &l, e)) != 0)
		return rc;
	rc = fea_relax_bound(&g, ceil_rho, vol, &l, NULL, &o, &bo, b, e);
	fea_loads_fini(&l);
	return rc;
}

/* Nothing to choose: the bound is the one design's compliance. */
static void test_exact_when_fixed(void)
{
	float f[NE];
	unsigned st = 7;
	double sum = 0;
	struct fea_bound b;
	struct err e;

	err_clear(&e);
	for (int q = 0; q < NE; q++) {
		f[q] = (float)(0.2 + 0.8 * unit_rand(&st));
		sum += f[q];
	}
	for (int p = 1; p <= 3; p += 2) {
		REQUIRE_OK(bound(f, f, sum, p, &b, &e), &e);
		CHECK_REL(b.lower_nmm, compliance(f, p, 0.01), 1e-6);
		CHECK_REL(b.upper_nmm, b.lower_nmm, 1e-6);
	}
}

/* A floor of 0.1 (0.4 in a few elements), ceiling 1, 45 % of the box:
 * random designs of the set and the uniform one are never stiffer than
 * the bound, at p = 3 (where the chord relaxation is loose) and at p = 1
 * (where it is exact: the bound then meets the best step within 1e-3). */
static void test_no_design_below(void)
{
	float fl[NE], cl[NE], d[NE];
	double vfloor = 0, vol = 0.45 * NE;
	unsigned st = 11;

	for (int q = 0; q < NE; q++) {
		/* some floors under rho_min (0.01: the solver clamps their
		 * weight, the budget counts them as they are), one element absent */
		fl[q] = q % 7 == 3 ? 0.4f : q % 5 == 1 ? 0.004f : 0.1f;
		cl[q] = 1;
		if (q == (2 * NY + 1) * NX + 6)
			fl[q] = cl[q] = 0;
		vfloor += fl[q];
	}
	for (int p = 1; p <= 3; p += 2) {
		struct fea_bound b;
		struct err e;
		double best = INFINITY;
		err_clear(&e);
		REQUIRE_OK(bound(fl, cl, vol, p, &b, &e), &e);
		CHECK_NUM(b.lower_nmm, >, 0);
		CHECK_NUM(b.lower_nmm, <=, b.upper_nmm * (1 + 1e-12));
		CHECK_NUM(b.iterations, <, 400);
		for (int trial = 0; trial < 40; trial++) {
			double w[NE], ws = 0;
			/* trial 0: the budget spread evenly; then random shares,
			 * some concentrated near the fixed end and the top and
			 * bottom fibres, where a cantilever wants material */
			for (int q = 0; q < NE; q++) {
				int i = q % NX, k = q / (NX * NY);
				double bias = trial % 2 ? (1.0 - i / (double)NX) * (k == 0 || k == NZ - 1)
							: 0;
				w[q] = cl[q] == 0 ? 0 : trial == 0 ? 1 : unit_rand(&st) + 3 * bias;
				ws += w[q];
			}
			double left = vol - vfloor, over = 0;
			for (int q = 0; q < NE; q++) {
				double add = left * w[q] / ws;
				double room = cl[q] - fl[q];
				if (add > room) {
					over += add - room;
					add = room;
				}
				d[q] = (float)(fl[q] + add);
			}
			/* whatever the cap cut off goes to the rest evenly (a design
			 * using less than the budget is in the set too) */
			for (int q = 0; q < NE && over > 0; q++) {
				double room = cl[q] - d[q], add = fmin(room, over);
				if (cl[q] == 0)
					continue;
				d[q] = (float)(d[q] + add);
				over -= add;
			}
			double c = compliance(d, p, 0.01);
			CHECK(isfinite(c));
			CHECK_NUM(c, >=, b.lower_nmm * (1 - 1e-6));
			best = fmin(best, c);
		}
		/* the bound is not vacuous: at p = 1 it is the optimum, which the
		 * random designs do not reach; at p = 3 it stays within a factor
		 * of what they reach */
		if (p == 1)
			CHECK_REL(b.upper_nmm, b.lower_nmm, 1.01e-3);
		CHECK_NUM(b.lower_nmm, >, (p == 1 ? 0.5 : 0.2) * best);
		printf("  p=%d: bound %.6g, best of 40 designs %.6g, %d solves\n", p, b.lower_nmm, best,
		       b.iterations);
	}
}

/* A bar of 20 elements in series under an axial load, nu = 0: each
 * element's compliance is h F^2 / (E A rho), so at p = 1 the best design
 * with a given total is the uniform one (the sum of 1 / rho_i at a fixed
 * sum of rho_i is least when they are equal).  The bound must meet the
 * uniform design's compliance, solved apart, within its gap. */
static void test_bar_exact(void)
{
	enum { N = 20 };
	const char *loads = "material E_mpa=1000 nu=0; fixed box=0,0,0,0,1,1 axes=xyz; "
			    "force box=20,0,0,20,1,1 n=1,0,0";
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct fea_bound b;
	struct fea_bound_opts bo = {.max_iter = 400, .gap = 1e-4};
	float fl[N], cl[N], u[N];
	struct err e;

	err_clear(&e);
	for (int q = 0; q < N; q++) {
		fl[q] = 0.05f;
		cl[q] = 1;
		u[q] = 0.5f;
	}
	memset(&g, 0, sizeof g);
	g.nx = N;
	g.ny = g.nz = 1;
	g.h_mm = 1;
	g.part_hi_mm = (struct vec3){N, 1, 1};
	fea_opts_default(&o);
	o.penal = 1;
	o.tol = 1e-10;
	REQUIRE_OK(fea_loads_parse(loads, MAT, &l, &e), &e);
	g.rho = u;
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	fea_solver_free(s);
	CHECK_REL(r.compliance_nmm, N * 1.0 / (1000 * 0.5), 1e-6);
	g.rho = fl;
	REQUIRE_OK(fea_relax_bound(&g, cl, 0.5 * N, &l, NULL, &o, &bo, &b, &e), &e);
	CHECK_NUM(b.lower_nmm, <=, r.compliance_nmm * (1 + 1e-6));
	CHECK_NUM(b.lower_nmm, >=, r.compliance_nmm / (1 + 1e-4 + 1e-6));
	CHECK_NUM(b.iterations, <, 400);
	fea_loads_fini(&l);
}

/* force != NULL: the bound of one fixed design under a load vector spread
 * by another solver is that solver's compliance. */
static void test_given_force(void)
{
	float f[NE], copy[NE];
	unsigned st = 5;
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct fea_bound b;
	struct fea_bound_opts bo = {.max_iter = 10, .gap = 1e-6};
	double *force;
	size_t nn = (size_t)(NX + 1) * (NY + 1) * (NZ + 1);
	double sum = 0;
	struct err e;

	err_clear(&e);
	for (int q = 0; q < NE; q++) {
		f[q] = (float)(0.05 + 0.95 * unit_rand(&st));
		sum += f[q];
	}
	memcpy(copy, f, sizeof copy);
	grid_init(&g, copy);
	fea_opts_default(&o);
	o.rho_min = 0.01;
	o.tol = 1e-10;
	REQUIRE_OK(fea_loads_parse(LOADS, MAT, &l, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	/* a load of its own: along y on every top node */
	force = fea_solver_force(s);
	for (size_t q = 0; q < 3 * nn; q++)
		force[q] = 0;
	for (int i = 1; i <= NX; i++)
		for (int j = 0; j <= NY; j++)
			force[3 * (((size_t)NZ * (NY + 1) + j) * (NX + 1) + i) + 1] = 0.1 * i;
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	REQUIRE_OK(fea_relax_bound(&g, f, sum, &l, force, &o, &bo, &b, &e), &e);
	CHECK_REL(b.lower_nmm, r.compliance_nmm, 1e-6);
	fea_solver_free(s);
	fea_loads_fini(&l);
}

static void test_errors(void)
{
	/* {floor, ceiling} of element 5 (the rest 0.3 and 1), budget per
	 * element, the field the error names */
	static const struct {
		float f, c;
		double vol;
		const char *field;
	} cases[] = {
		{0.3f, 1, 0.1, "volume"}, /* under the floors' sum */
		{1, 0.5f, 0.5, "rho"},    /* floor above ceiling */
		{0, 1, 0.5, "rho"},       /* an element without a floor */
		{0.3f, 0, 0.5, "rho"},    /* a floor without an element */
	};
	float fl[NE], cl[NE];
	struct fea_bound b;
	struct err e;

	for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
		for (int q = 0; q < NE; q++) {
			fl[q] = 0.3f;
			cl[q] = 1;
		}
		fl[5] = cases[k].f;
		cl[5] = cases[k].c;
		err_clear(&e);
		CHECK_NUM(bound(fl, cl, cases[k].vol * NE, 3, &b, &e), !=, 0);
		CHECK_STR(e.field, cases[k].field);
	}
}

int main(void)
{
	RUN(test_exact_when_fixed);
	RUN(test_no_design_below);
	RUN(test_bar_exact);
	RUN(test_given_force);
	RUN(test_errors);
	return harness_report();
}
