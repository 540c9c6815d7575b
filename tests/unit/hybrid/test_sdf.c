/* test_sdf.c - the shape diameter function and its normalisation
 * (engine/hybrid/sdf.c) against values computed here by an independent
 * route: the continuous SDF of the shape, i.e. the chord length from the
 * facet's centroid in every direction of the 120-degree cone (analytic
 * ray-cylinder, ray-sphere and ray-box exits, a fine grid uniform in
 * solid angle), filtered to one standard deviation around the median and
 * averaged with weights 1 / max(angle, a0) as hy_sdf documents.  The
 * code samples 30 rays, so it matches within a sampling tolerance; a
 * shape 15% larger is outside it (the checks can fail).  Also: rays that
 * meet a wall facing back are dropped (a flipped facet looking at a
 * second solid), thread-count independence, parameter errors, the
 * paper's log normalisation, and the SDF time on the armadillo.
 */
#include "harness.h"
#include "unit/slice/meshgen.h"

#include <time.h>

#include "engine/core/err.h"
#include "engine/hybrid/hybrid.h"
#include "engine/mesh/mesh.h"

#define RAYS 30
#define HALF_RAD (60 * M_PI / 180)

/* ---- the continuous SDF, computed without the code under test ---- */

/* Chord from p (inside) along the unit d to the shape's wall, mm. */
typedef double chord_fn(const void *shape, struct vec3 p, struct vec3 d);

struct cyl {
	double r_mm; /* infinite cylinder about the z axis */
};
struct ball {
	struct vec3 c;
	double r_mm;
};
struct slab {
	struct vec3 lo, hi;
};

/* Far root of |q + t d|^2 = r^2 (q inside: c < 0). */
static double quad_exit(double a, double b, double c)
{
	return (-b + sqrt(b * b - 4 * a * c)) / (2 * a);
}

static double chord_cyl(const void *s, struct vec3 p, struct vec3 d)
{
	const struct cyl *k = s;
	double a = d.x * d.x + d.y * d.y;
	return quad_exit(a, 2 * (p.x * d.x + p.y * d.y), p.x * p.x + p.y * p.y - k->r_mm * k->r_mm);
}

static double chord_ball(const void *s, struct vec3 p, struct vec3 d)
{
	const struct ball *k = s;
	struct vec3 q = v3_sub(p, k->c);
	return quad_exit(1, 2 * v3_dot(q, d), v3_dot(q, q) - k->r_mm * k->r_mm);
}

static double chord_box(const void *s, struct vec3 p, struct vec3 d)
{
	const struct slab *k = s;
	double t = INFINITY;
	for (int a = 0; a < 3; a++) {
		double da = v3_comp(d, a), pa = v3_comp(p, a);
		if (da > 0)
			t = fmin(t, (v3_comp(k->hi, a) - pa) / da);
		else if (da < 0)
			t = fmin(t, (v3_comp(k->lo, a) - pa) / da);
	}
	return t;
}

static int cmp_dbl(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;
	return (x > y) - (x < y);
}

/* The continuous SDF at p with inward unit axis n: a grid of NU x NP
 * directions uniform in solid angle over the cone. */
#define NU 120
#define NP 120
static double continuous_sdf_n(chord_fn *chord, const void *shape, struct vec3 p, struct vec3 n,
			       int rays)
{
	static double len[NU * NP], ang[NU * NP], sorted[NU * NP];
	struct vec3 e1 = fabs(n.x) < 0.9 ? v3(1, 0, 0) : v3(0, 1, 0), e2;
	double one_minus = 1 - cos(HALF_RAD), a0 = acos(1 - one_minus / rays);
	double med, mean = 0, var = 0, sd, ws = 0, ls = 0;
	int k = 0;

	e1 = v3_normalize(v3_sub(e1, v3_scale(n, v3_dot(e1, n))));
	e2 = v3_cross(n, e1);
	for (int i = 0; i < NU; i++)
		for (int j = 0; j < NP; j++) {
			double cz = 1 - (i + 0.5) / NU * one_minus, sz = sqrt(1 - cz * cz);
			double az = 2 * M_PI * (j + 0.5) / NP;
			struct vec3 d = v3_add(v3_add(v3_scale(e1, sz * cos(az)), v3_scale(e2, sz * sin(az))),
					       v3_scale(n, cz));
			len[k] = chord(shape, p, d);
			ang[k] = acos(cz);
			sorted[k] = len[k];
			mean += len[k];
			k++;
		}
	qsort(sorted, (size_t)k, sizeof *sorted, cmp_dbl);
	med = 0.5 * (sorted[k / 2 - 1] + sorted[k / 2]);
	mean /= k;
	for (int i = 0; i < k; i++)
		var += (len[i] - mean) * (len[i] - mean);
	sd = sqrt(var / k);
	for (int i = 0; i < k; i++)
		if (fabs(len[i] - med) <= sd) {
			double w = 1 / fmax(ang[i], a0);
			ws += w;
			ls += w * len[i];
		}
	return ls / ws;
}

static double continuous_sdf(chord_fn *chord, const void *shape, struct vec3 p, struct vec3 n)
{
	return continuous_sdf_n(chord, shape, p, n, RAYS);
}

/* ---- test shapes, CCW seen from outside ---- */

/* Closed cylinder about z, radius r, z in [0, h], nseg sides, nz rings. */
static struct mesh *cylinder(double r, double h, int nseg, int nz)
{
	struct mesh *m = tm_new();
	uint32_t bot, top;

	for (int k = 0; k <= nz; k++)
		for (int i = 0; i < nseg; i++) {
			double a = 2 * M_PI * i / nseg;
			tm_vert(m, r * cos(a), r * sin(a), h * k / nz);
		}
	bot = tm_vert(m, 0, 0, 0);
	top = tm_vert(m, 0, 0, h);
	for (int k = 0; k < nz; k++)
		for (int i = 0; i < nseg; i++) {
			uint32_t a = (uint32_t)(k * nseg + i), b = (uint32_t)(k * nseg + (i + 1) % nseg);
			tm_tri(m, a, b, b + (uint32_t)nseg);
			tm_tri(m, a, b + (uint32_t)nseg, a + (uint32_t)nseg);
		}
	for (int i = 0; i < nseg; i++) {
		uint32_t a = (uint32_t)i, b = (uint32_t)((i + 1) % nseg);
		tm_tri(m, bot, b, a);
		tm_tri(m, top, a + (uint32_t)(nz * nseg), b + (uint32_t)(nz * nseg));
	}
	return m;
}

/* Box [lo, hi] with every face split into n x n quads (welded). */
static void add_grid_box(struct mesh *m, struct vec3 lo, struct vec3 hi, int n)
{
	for (int ax = 0; ax < 3; ax++)
		for (int side = 0; side < 2; side++) {
			int u = (ax + 1) % 3, v = (ax + 2) % 3;
			uint32_t base = (uint32_t)m->nv;
			for (int j = 0; j <= n; j++)
				for (int i = 0; i <= n; i++) {
					double c[3];
					c[ax] = side ? v3_comp(hi, ax) : v3_comp(lo, ax);
					c[u] = v3_comp(lo, u) + (v3_comp(hi, u) - v3_comp(lo, u)) * i / n;
					c[v] = v3_comp(lo, v) + (v3_comp(hi, v) - v3_comp(lo, v)) * j / n;
					tm_vert(m, c[0], c[1], c[2]);
				}
			for (int j = 0; j < n; j++)
				for (int i = 0; i < n; i++) {
					uint32_t a = base + (uint32_t)(j * (n + 1) + i), b = a + 1,
						 c = a + (uint32_t)(n + 1) + 1, d = a + (uint32_t)(n + 1);
					/* (u, v, ax) is right-handed: u x v = +ax, CCW seen from +ax */
					if (side) {
						tm_tri(m, a, b, c);
						tm_tri(m, a, c, d);
					} else {
						tm_tri(m, a, c, b);
						tm_tri(m, a, d, c);
					}
				}
		}
	tm_weld(m);
}

static struct vec3 centroid(const struct mesh *m, size_t f)
{
	return v3_scale(v3_add(v3_add(m->v[m->tri[3 * f]], m->v[m->tri[3 * f + 1]]),
			       m->v[m->tri[3 * f + 2]]),
			1.0 / 3);
}

static struct vec3 inward(const struct mesh *m, size_t f)
{
	struct vec3 a = m->v[m->tri[3 * f]], b = m->v[m->tri[3 * f + 1]], c = m->v[m->tri[3 * f + 2]];
	return v3_scale(v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a))), -1);
}

static int run_sdf_n(const struct mesh *m, int threads, uint64_t seed, int rays, double *sdf,
		     struct err *e)
{
	struct mesh_bvh *b;
	struct hy_sdf_opts o;
	int rc;

	if ((rc = mesh_bvh_new(m, &b, e)))
		return rc;
	hy_sdf_opts_default(&o);
	o.threads = threads;
	o.seed = seed;
	o.rays = rays;
	rc = hy_sdf(m, b, &o, sdf, e);
	mesh_bvh_free(b);
	return rc;
}

static int run_sdf(const struct mesh *m, int threads, uint64_t seed, double *sdf, struct err *e)
{
	return run_sdf_n(m, threads, seed, RAYS, sdf, e);
}

/* ---- tests ---- */

/* A long cylinder of radius R: side facets away from the caps see the
 * infinite cylinder.  Each facet within 4% of the continuous value, the
 * mean within 2.5% (30 rays read about 1.4% short); the continuous value
 * of a 1.15 R cylinder is outside. */
static void test_cylinder(void)
{
	const double R = 5, H = 100;
	struct mesh *m = cylinder(R, H, 96, 40);
	double *sdf = malloc(m->nt * sizeof *sdf), sum = 0, worst = 0, expect = 0, wrong;
	struct cyl c = {R}, c_wrong = {1.15 * R};
	struct err e;
	size_t n = 0;

	REQUIRE_OK(run_sdf(m, 2, 0, sdf, &e), &e);
	for (size_t f = 0; f < m->nt; f++) {
		struct vec3 p = centroid(m, f), nin = inward(m, f);
		double x;
		if (p.z < 30 || p.z > 70 || fabs(nin.z) > 1e-9)
			continue;
		x = continuous_sdf(chord_cyl, &c, p, nin);
		CHECK_REL(sdf[f], x, 0.04);
		worst = fmax(worst, fabs(sdf[f] - x) / x);
		sum += sdf[f];
		expect += x;
		n++;
	}
	REQUIRE(n > 1000);
	CHECK_REL(sum / (double)n, expect / (double)n, 0.025);
	/* the expectation discriminates: 15% larger is far outside 2% */
	wrong = continuous_sdf(chord_cyl, &c_wrong, v3(1.15 * R, 0, 50), v3(-1, 0, 0));
	CHECK(fabs(sum / (double)n - wrong) > 0.05 * wrong);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "cylinder R %g: mean sdf %.4f mm, continuous %.4f (2R = %g), worst "
				"facet %.1f%%\n",
			R, sum / (double)n, expect / (double)n, 2 * R, 100 * worst);
	free(sdf);
	tm_free(m);
}

/* A sphere: chords 2 R cos(angle). */
static void test_sphere(void)
{
	const double R = 8;
	struct mesh *m = tm_icosphere(v3(0, 0, 0), R, 4);
	double *sdf = malloc(m->nt * sizeof *sdf), sum = 0, expect = 0;
	struct ball s = {{0, 0, 0}, R};
	struct err e;

	REQUIRE_OK(run_sdf(m, 2, 0, sdf, &e), &e);
	for (size_t f = 0; f < m->nt; f += 17) {
		double x = continuous_sdf(chord_ball, &s, centroid(m, f), inward(m, f));
		CHECK_REL(sdf[f], x, 0.05);
	}
	for (size_t f = 0; f < m->nt; f++)
		sum += sdf[f];
	expect = continuous_sdf(chord_ball, &s, v3(0, 0, R), v3(0, 0, -1));
	CHECK_REL(sum / (double)m->nt, expect, 0.02);
	CHECK(expect < 2 * R && expect > R); /* shorter than the diameter, as the cone tilts */
	CHECK(fabs(sum / (double)m->nt - 1.15 * expect) > 0.05 * 1.15 * expect);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "sphere R %g: mean sdf %.4f mm, continuous %.4f\n", R,
			sum / (double)m->nt, expect);
	free(sdf);
	tm_free(m);
}

/* A cube of side 20 with 10 x 10 quads a face.  From the middle of a
 * face the cone sees the opposite face (20 to 40 mm) and the side walls
 * (shorter): a spread, two-sided distribution whose median and standard
 * deviation 30 rays estimate coarsely, so a facet may be 16% off the
 * continuous value (the mean of the central facets 3%); with 400 rays the
 * estimator converges: every central facet within 3%. */
static void test_cube(void)
{
	const double a = 20;
	struct mesh *m = tm_new();
	struct slab s = {{0, 0, 0}, {a, a, a}};
	double *sdf, *fine, worst = 0, worst_fine = 0, sum = 0, expect = 0;
	struct err e;
	size_t n = 0;

	add_grid_box(m, s.lo, s.hi, 10);
	sdf = malloc(m->nt * sizeof *sdf);
	fine = malloc(m->nt * sizeof *fine);
	REQUIRE_OK(run_sdf(m, 1, 0, sdf, &e), &e);
	REQUIRE_OK(run_sdf_n(m, 2, 0, 400, fine, &e), &e);
	for (size_t f = 0; f < m->nt; f++) {
		struct vec3 p = centroid(m, f), nin = inward(m, f);
		double x, xf;
		int central = 1;
		for (int ax = 0; ax < 3; ax++)
			if (fabs(v3_comp(nin, ax)) < 0.5 && fabs(v3_comp(p, ax) - a / 2) > a / 4)
				central = 0;
		if (!central)
			continue;
		x = continuous_sdf(chord_box, &s, p, nin);
		xf = continuous_sdf_n(chord_box, &s, p, nin, 400);
		CHECK_REL(sdf[f], x, 0.16);
		CHECK_REL(fine[f], xf, 0.03);
		worst = fmax(worst, fabs(sdf[f] - x) / x);
		worst_fine = fmax(worst_fine, fabs(fine[f] - xf) / xf);
		sum += sdf[f];
		expect += x;
		n++;
	}
	CHECK_INT(n, >=, 6 * 4 * 4 * 2);
	CHECK_REL(sum, expect, 0.03);
	/* the SDF scales with the shape: a cube 15% larger is outside the bound */
	CHECK(fabs(sum - 1.15 * expect) > 0.06 * 1.15 * expect);
	if (getenv("HARNESS_VERBOSE"))
		fprintf(stderr, "cube %g: %zu central facets, mean sdf %.3f mm (continuous %.3f), "
				"worst %.1f%% at 30 rays, %.1f%% at 400\n",
			a, n, sum / (double)n, expect / (double)n, 100 * worst, 100 * worst_fine);
	free(sdf);
	free(fine);
	tm_free(m);
}

/* Two spheres 5 mm apart; one facet of the first, facing the second, is
 * flipped: its rays leave the first solid and meet the second one's
 * outside (a wall facing back), so all are dropped and the facet gets
 * the mean of the others, not the 5 mm gap.  Unflipped it has its
 * sphere's value. */
static void test_facing(void)
{
	struct mesh *m = tm_icosphere(v3(0, 0, 0), 5, 3), *m2 = tm_icosphere(v3(15, 0, 0), 5, 3);
	double *sdf, *plain, mean = 0, best = -1;
	size_t flip = 0, nt1 = m->nt;
	uint32_t nv1 = (uint32_t)m->nv;
	struct err e;

	for (size_t i = 0; i < m2->nv; i++)
		tm_vert(m, m2->v[i].x, m2->v[i].y, m2->v[i].z);
	for (size_t t = 0; t < m2->nt; t++)
		tm_tri(m, m2->tri[3 * t] + nv1, m2->tri[3 * t + 1] + nv1, m2->tri[3 * t + 2] + nv1);
	for (size_t f = 0; f < nt1; f++) {
		double x = -inward(m, f).x;
		if (x > best) {
			best = x;
			flip = f;
		}
	}
	sdf = malloc(m->nt * sizeof *sdf);
	plain = malloc(m->nt * sizeof *plain);
	REQUIRE_OK(run_sdf(m, 1, 0, plain, &e), &e);
	{
		uint32_t t = m->tri[3 * flip + 1];
		m->tri[3 * flip + 1] = m->tri[3 * flip + 2];
		m->tri[3 * flip + 2] = t;
	}
	REQUIRE_OK(run_sdf(m, 1, 0, sdf, &e), &e);
	for (size_t f = 0; f < m->nt; f++)
		if (f != flip)
			mean += sdf[f];
	mean /= (double)(m->nt - 1);
	CHECK_NEAR(sdf[flip], mean, 1e-9 * mean);
	CHECK(fabs(sdf[flip] - 5) > 1);
	CHECK_REL(plain[flip], continuous_sdf(chord_ball, &(struct ball){{0, 0, 0}, 5},
					      centroid(m, flip), v3(-1, 0, 0)),
		  0.06);
	free(sdf);
	free(plain);
	tm_free(m);
	tm_free(m2);
}

/* Same values on 1 and 3 threads (bitwise); another seed turns the
 * pattern: values move, but stay close. */
static void test_deterministic(void)
{
	struct mesh *m = cylinder(4, 40, 32, 16);
	double *a = malloc(m->nt * sizeof *a), *b = malloc(m->nt * sizeof *b),
	       *c = malloc(m->nt * sizeof *c);
	struct err e;
	size_t moved = 0;

	REQUIRE_OK(run_sdf(m, 1, 7, a, &e), &e);
	REQUIRE_OK(run_sdf(m, 3, 7, b, &e), &e);
	REQUIRE_OK(run_sdf(m, 1, 8, c, &e), &e);
	CHECK(memcmp(a, b, m->nt * sizeof *a) == 0);
	for (size_t f = 0; f < m->nt; f++) {
		moved += a[f] != c[f];
		CHECK_REL(c[f], a[f], 0.25);
	}
	CHECK(moved > m->nt / 2);
	free(a);
	free(b);
	free(c);
	tm_free(m);
}

static void test_params(void)
{
	struct mesh *m = cylinder(1, 4, 8, 2);
	struct mesh_bvh *b;
	struct hy_sdf_opts o;
	double sdf[64];
	struct err e;

	REQUIRE(m->nt <= 64);
	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	hy_sdf_opts_default(&o);
	CHECK_EQ_INT(o.rays, 30);
	CHECK_NUM(o.cone_deg, ==, 120);
	o.rays = 0;
	CHECK_EQ_INT(hy_sdf(m, b, &o, sdf, &e), ERR_PARAM);
	CHECK_STR(e.field, "sdf_rays");
	o.rays = 30;
	o.cone_deg = 180;
	CHECK_EQ_INT(hy_sdf(m, b, &o, sdf, &e), ERR_PARAM);
	CHECK_STR(e.field, "sdf_cone_deg");
	mesh_bvh_free(b);
	tm_free(m);
}

static void test_nsdf(void)
{
	const double sdf[4] = {3, 5, 7, 11}, flat[3] = {2, 2, 2};
	double n[4];

	hy_nsdf(sdf, 4, 4, n);
	CHECK_NEAR(n[0], 0, 1e-15);
	CHECK_NEAR(n[1], log(2) / log(5), 1e-15); /* x = 1/4: log(1 + 1) / log 5 */
	CHECK_NEAR(n[2], log(3) / log(5), 1e-15);
	CHECK_NEAR(n[3], 1, 1e-15);
	hy_nsdf(sdf, 4, 0, n);
	CHECK_NEAR(n[1], 0.25, 1e-15);
	hy_nsdf(flat, 3, 4, n);
	CHECK_NUM(n[0] + n[1] + n[2], ==, 0);
}

static double seconds(void)
{
	struct timespec t;
	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The SDF time on a 52k-facet mesh, one thread (a figure for the log). */
static void test_armadillo_time(void)
{
	struct mesh *m;
	struct mesh_bvh *b;
	struct mesh_placement pl = {MESH_UNITS_MM, 1, 60, MESH_UP_Y, 0, 0};
	struct hy_sdf_opts o;
	struct mesh_report rep;
	double *sdf, t0, t1, lo = INFINITY, hi = 0;
	struct err e;

	REQUIRE_OK(mesh_read_file(shared_path("meshes/armadillo.off"), MESH_FMT_AUTO, &m, NULL, &e),
		   &e);
	REQUIRE_OK(mesh_repair(m, &rep, &e), &e);
	REQUIRE_OK(mesh_place(m, &pl, &e), &e);
	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	sdf = malloc(m->nt * sizeof *sdf);
	hy_sdf_opts_default(&o);
	t0 = seconds();
	REQUIRE_OK(hy_sdf(m, b, &o, sdf, &e), &e);
	t1 = seconds();
	for (size_t f = 0; f < m->nt; f++) {
		lo = fmin(lo, sdf[f]);
		hi = fmax(hi, sdf[f]);
	}
	CHECK(lo > 0 && hi < 60);
	fprintf(stderr, "armadillo at 60 mm: %zu facets, SDF %.2f s on 1 thread (%d rays), "
			"%.2f..%.2f mm\n",
		m->nt, t1 - t0, o.rays, lo, hi);
	free(sdf);
	mesh_bvh_free(b);
	mesh_free(m);
}

int main(void)
{
	RUN(test_nsdf);
	RUN(test_params);
	RUN(test_cylinder);
	RUN(test_sphere);
	RUN(test_cube);
	RUN(test_facing);
	RUN(test_deterministic);
	RUN(test_armadillo_time);
	return harness_report();
}
