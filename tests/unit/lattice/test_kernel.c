/* test_kernel.c - closed-form strut integral and gradient against quadrature,
 * the weight <-> radius map, and C1 continuity of the blended field. */
#include "harness.h"

#include "engine/lattice/kernel.h"

/* Deterministic uniform numbers in [0, 1). */
static double rnd(unsigned long long *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*s >> 11) / 9007199254740992.0;
}

static double kernel_f(double d2, double R)
{
	double t = 1 - d2 / (R * R);
	return d2 < R * R ? t * t : 0;
}

/* Composite Simpson over the whole segment in arc length, n intervals:
 * independent of the closed form's clipping logic. */
static double quad_integral(struct vec3 p, struct vec3 a, struct vec3 b, double R, int n,
			    struct vec3 *grad)
{
	double l = v3_dist(a, b), h = l / n, s = 0;
	struct vec3 g = v3(0, 0, 0);

	for (int i = 0; i <= n; i++) {
		double wgt = (i == 0 || i == n) ? 1 : (i & 1) ? 4 : 2;
		struct vec3 x = v3_lerp(a, b, (double)i / n), d = v3_sub(p, x);
		double d2 = v3_len2(d);

		s += wgt * kernel_f(d2, R);
		if (d2 < R * R) /* d/dp (1 - d^2/R^2)^2 = -4 (1 - d^2/R^2) d / R^2 */
			g = v3_madd(g, d, wgt * -4 * (1 - d2 / (R * R)) / (R * R));
	}
	*grad = v3_scale(g, h / 3);
	return s * h / 3;
}

/* Gradient integrand at arc fraction t: d/dp of (1 - d^2/R^2)^2. */
static struct vec3 grad_f(struct vec3 p, struct vec3 a, struct vec3 b, double R, double t)
{
	struct vec3 d = v3_sub(p, v3_lerp(a, b, t));
	double d2 = v3_len2(d);
	return d2 < R * R ? v3_scale(d, -4 * (1 - d2 / (R * R)) / (R * R)) : v3(0, 0, 0);
}

/* Adaptive Simpson on [t0, t1] (fractions), vector-valued: the gradient
 * integrand has kinks where the support boundary crosses the segment, so
 * fixed-step Simpson only reaches O(h^2) there. */
static struct vec3 asimpson(struct vec3 p, struct vec3 a, struct vec3 b, double R, double t0,
			    double t1, struct vec3 f0, struct vec3 fm, struct vec3 f1,
			    struct vec3 whole, int depth)
{
	double tm = 0.5 * (t0 + t1), h = t1 - t0;
	struct vec3 fl = grad_f(p, a, b, R, 0.5 * (t0 + tm)), fr = grad_f(p, a, b, R, 0.5 * (tm + t1));
	struct vec3 left = v3_scale(v3_add(v3_add(f0, v3_scale(fl, 4)), fm), h / 12);
	struct vec3 right = v3_scale(v3_add(v3_add(fm, v3_scale(fr, 4)), f1), h / 12);
	struct vec3 sum = v3_add(left, right);

	if (depth > 40 || v3_dist(sum, whole) < 1e-14)
		return v3_add(sum, v3_scale(v3_sub(sum, whole), 1.0 / 15));
	return v3_add(asimpson(p, a, b, R, t0, tm, f0, fl, fm, left, depth + 1),
		      asimpson(p, a, b, R, tm, t1, fm, fr, f1, right, depth + 1));
}

static struct vec3 quad_gradient(struct vec3 p, struct vec3 a, struct vec3 b, double R)
{
	struct vec3 acc = v3(0, 0, 0);
	int n = 64; /* coarse panels so the recursion cannot miss a short bump */

	for (int i = 0; i < n; i++) {
		double t0 = (double)i / n, t1 = (double)(i + 1) / n, tm = 0.5 * (t0 + t1);
		struct vec3 f0 = grad_f(p, a, b, R, t0), fm = grad_f(p, a, b, R, tm);
		struct vec3 f1 = grad_f(p, a, b, R, t1);
		struct vec3 whole = v3_scale(v3_add(v3_add(f0, v3_scale(fm, 4)), f1), (t1 - t0) / 6);
		acc = v3_add(acc, asimpson(p, a, b, R, t0, t1, f0, fm, f1, whole, 0));
	}
	return v3_scale(acc, v3_dist(a, b));
}

static void test_integral_vs_quadrature(void)
{
	unsigned long long seed = 12345;
	double worst = 0, worst_g = 0;

	for (int k = 0; k < 400; k++) {
		double R = 0.3 + 2 * rnd(&seed);
		struct vec3 a = v3(4 * rnd(&seed) - 2, 4 * rnd(&seed) - 2, 4 * rnd(&seed) - 2);
		struct vec3 b = v3_add(a, v3(6 * rnd(&seed) - 3, 6 * rnd(&seed) - 3,
					     6 * rnd(&seed) - 3));
		/* query points near the segment: around either end and the middle */
		struct vec3 base = v3_lerp(a, b, 1.4 * rnd(&seed) - 0.2);
		struct vec3 p = v3_add(base, v3((2 * rnd(&seed) - 1) * R, (2 * rnd(&seed) - 1) * R,
						(2 * rnd(&seed) - 1) * R));
		struct vec3 gq, gc;
		double iq = quad_integral(p, a, b, R, 20000, &gq);
		double ic = lattice_kernel_gradient(p, a, b, R, &gc);

		gq = quad_gradient(p, a, b, R);

		CHECK_NEAR(lattice_kernel_integral(p, a, b, R), ic, 1e-15);
		worst = fmax(worst, fabs(iq - ic));
		worst_g = fmax(worst_g, v3_dist(gq, gc));
	}
	fprintf(stderr, "integral max |closed - quadrature| = %.3g, gradient %.3g\n", worst,
		worst_g);
	CHECK_NUM(worst, <=, 1e-9);
	CHECK_NUM(worst_g, <=, 1e-9);
}

static void test_degenerate_and_support(void)
{
	struct vec3 g;

	/* zero-length strut and points beyond the support contribute nothing */
	CHECK_NUM(lattice_kernel_integral(v3(0, 0, 0), v3(1, 1, 1), v3(1, 1, 1), 1), ==, 0);
	CHECK_NUM(lattice_kernel_integral(v3(0, 0, 2), v3(-5, 0, 0), v3(5, 0, 0), 1.5), ==, 0);
	CHECK_NUM(lattice_kernel_gradient(v3(0, 0, 2), v3(-5, 0, 0), v3(5, 0, 0), 1.5, &g), ==, 0);
	CHECK_NUM(v3_len(g), ==, 0);
	/* beyond the end cap along the axis */
	CHECK_NUM(lattice_kernel_integral(v3(6.6, 0, 0), v3(-5, 0, 0), v3(5, 0, 0), 1.5), ==, 0);
	/* symmetric in the segment's direction */
	CHECK_NEAR(lattice_kernel_integral(v3(0.3, 0.2, 0.1), v3(-1, 0, 0), v3(2, 0, 0), 1),
		   lattice_kernel_integral(v3(0.3, 0.2, 0.1), v3(2, 0, 0), v3(-1, 0, 0), 1), 1e-15);
}

static void test_line_and_radius_map(void)
{
	double R = 1.2, C = 0.7;

	/* a long strut's mid cross-section equals the infinite-line integral */
	for (double rho = 0; rho < R; rho += 0.1)
		CHECK_NEAR(lattice_kernel_integral(v3(0, rho, 0), v3(-10, 0, 0), v3(10, 0, 0), R),
			   lattice_kernel_line(rho, R), 1e-12);
	/* weight <-> radius round trip and the isovalue crossing */
	for (double r = 0.05; r < R * 0.95; r += 0.05) {
		double w = lattice_weight_for_radius(r, C, R);
		CHECK_NEAR(lattice_radius_for_weight(w, C, R), r, 1e-12);
		CHECK_NEAR(w * lattice_kernel_line(r, R), C, 1e-12);
		CHECK(w * lattice_kernel_line(r * 0.999, R) > C);
		CHECK(w * lattice_kernel_line(r * 1.001, R) < C);
	}
	CHECK_NUM(lattice_radius_for_weight(15 * C / (16 * R) * 0.99, C, R), ==, 0);
	CHECK(isinf(lattice_weight_for_radius(R, C, R)));
}

static double seg_dist(struct vec3 p, struct vec3 a, struct vec3 b)
{
	struct vec3 u = v3_sub(b, a);
	double t = fmin(1, fmax(0, v3_dot(v3_sub(p, a), u) / v3_len2(u)));
	return v3_dist(p, v3_madd(a, u, t));
}

/* Gradient of the distance-field union min(d1, d2) by central differences. */
static struct vec3 dist_union_grad(struct vec3 p, struct vec3 a, struct vec3 n, struct vec3 b)
{
	double e = 1e-9, f[6];

	for (int ax = 0; ax < 3; ax++) {
		struct vec3 d = v3(ax == 0 ? e : 0, ax == 1 ? e : 0, ax == 2 ? e : 0);
		struct vec3 pp = v3_add(p, d), pm = v3_sub(p, d);
		f[2 * ax] = fmin(seg_dist(pp, a, n), seg_dist(pp, n, b));
		f[2 * ax + 1] = fmin(seg_dist(pm, a, n), seg_dist(pm, n, b));
	}
	return v3((f[0] - f[1]) / (2 * e), (f[2] - f[3]) / (2 * e), (f[4] - f[5]) / (2 * e));
}

static struct vec3 conv_grad(struct vec3 p, struct vec3 a, struct vec3 n, struct vec3 b, double R)
{
	struct vec3 ga, gb;

	lattice_kernel_gradient(p, a, n, R, &ga);
	lattice_kernel_gradient(p, n, b, R, &gb);
	return v3_add(ga, gb);
}

/* Two struts meeting at a node.  Along a path through the node's
 * neighbourhood, find where the closest strut switches (d1 = d2): there a
 * distance-field union has a crease (its gradient jumps), while the
 * convolution field's gradient stays continuous. */
static void test_blend_is_c1(void)
{
	double R = 1.0, lo = -0.8, hi = 0.8, dt = 1e-6;
	struct vec3 n = v3(0, 0, 0), a = v3(-3, 0, 0), b = v3(2, 2.5, 0);
	struct vec3 pl, pr;
	double jc, jd;

	/* bisection on d1 - d2 along p(t) = (t, 0.35, 0.2) */
	CHECK(seg_dist(v3(lo, 0.35, 0.2), a, n) < seg_dist(v3(lo, 0.35, 0.2), n, b));
	CHECK(seg_dist(v3(hi, 0.35, 0.2), a, n) > seg_dist(v3(hi, 0.35, 0.2), n, b));
	for (int k = 0; k < 60; k++) {
		double m = 0.5 * (lo + hi);
		struct vec3 p = v3(m, 0.35, 0.2);
		if (seg_dist(p, a, n) < seg_dist(p, n, b))
			lo = m;
		else
			hi = m;
	}
	pl = v3(lo - dt, 0.35, 0.2);
	pr = v3(lo + dt, 0.35, 0.2);
	jc = v3_dist(conv_grad(pl, a, n, b, R), conv_grad(pr, a, n, b, R)) / (2 * dt);
	jd = v3_dist(dist_union_grad(pl, a, n, b), dist_union_grad(pr, a, n, b)) / (2 * dt);
	fprintf(stderr, "blend at the switch t=%.6f: |dgrad|/|dp| convolution %.3g, distance union %.3g\n",
		lo, jc, jd);
	CHECK_NUM(jc, <, 50);  /* Lipschitz gradient: no crease */
	CHECK_NUM(jd, >, 1e4); /* the same probe sees the distance field's crease */
	/* and the convolution gradient is not degenerate there */
	CHECK_NUM(v3_len(conv_grad(pl, a, n, b, R)), >, 0.1);
}

int main(void)
{
	RUN(test_integral_vs_quadrature);
	RUN(test_degenerate_and_support);
	RUN(test_line_and_radius_map);
	RUN(test_blend_is_c1);
	return harness_report();
}
