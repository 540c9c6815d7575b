/* kernel.c - closed-form convolution integral of a quartic kernel along a strut.
 *
 * Derivation (docs/lattice.md section 2): with t = (p2 - p1)/l, w = p - p1,
 * h = w.t, rho^2 = |w|^2 - h^2 and c = R^2 - rho^2, the squared distance
 * from p to the point at arc length s is rho^2 + y^2 with y = s - h, so
 * R^4 f = (c - y^2)^2 and the integral over y in [y0, y1] (the segment
 * clipped to the support, |y| < sqrt(c)) is G(y1) - G(y0) with
 * G(y) = c^2 y - 2/3 c y^3 + y^5/5.
 */
#include "engine/lattice/kernel.h"

#include <math.h>

/* Shared set-up of the integral: returns 0 when p is outside the support
 * (then nothing else is set). */
struct seg_frame {
	struct vec3 t;   /* unit direction */
	struct vec3 rho; /* perpendicular offset from the axis to p */
	double c, y0, y1;
};

static int seg_frame(struct vec3 p, struct vec3 p1, struct vec3 p2, double R,
		     struct seg_frame *f)
{
	struct vec3 u = v3_sub(p2, p1), w = v3_sub(p, p1);
	double l = v3_len(u), h, rho2, sc;

	if (!(l > 0.0))
		return 0;
	f->t = v3_scale(u, 1.0 / l);
	h = v3_dot(w, f->t);
	f->rho = v3_madd(w, f->t, -h);
	rho2 = v3_len2(f->rho);
	f->c = R * R - rho2;
	if (f->c <= 0.0)
		return 0;
	sc = sqrt(f->c);
	f->y0 = fmax(-h, -sc);
	f->y1 = fmin(l - h, sc);
	return f->y0 < f->y1;
}

static double prim_g(double c, double y)
{
	double y2 = y * y;
	return y * (c * c - (2.0 / 3.0) * c * y2 + 0.2 * y2 * y2);
}

double lattice_kernel_integral(struct vec3 p, struct vec3 p1, struct vec3 p2, double R)
{
	struct seg_frame f;

	if (!seg_frame(p, p1, p2, R, &f))
		return 0.0;
	return (prim_g(f.c, f.y1) - prim_g(f.c, f.y0)) / (R * R * R * R);
}

/* grad I = -(4/R^4) [rho (A(y1) - A(y0)) - t (B(y1) - B(y0))] with
 * A(y) = c y - y^3/3 (from d/dp of the integrand through c) and
 * B(y) = c y^2/2 - y^4/4 (the boundary terms at clipped segment ends,
 * (c - y^2)^2 = c^2 - 4 B(y)); limits at +-sqrt(c) add nothing since the
 * integrand vanishes there. */
double lattice_kernel_gradient(struct vec3 p, struct vec3 p1, struct vec3 p2, double R,
			       struct vec3 *grad)
{
	struct seg_frame f;
	double r4 = R * R * R * R, da, db;

	*grad = v3(0, 0, 0);
	if (!seg_frame(p, p1, p2, R, &f))
		return 0.0;
	da = (f.c * f.y1 - f.y1 * f.y1 * f.y1 / 3.0) - (f.c * f.y0 - f.y0 * f.y0 * f.y0 / 3.0);
	db = (0.5 * f.c * f.y1 * f.y1 - 0.25 * f.y1 * f.y1 * f.y1 * f.y1) -
	     (0.5 * f.c * f.y0 * f.y0 - 0.25 * f.y0 * f.y0 * f.y0 * f.y0);
	*grad = v3_scale(v3_sub(v3_scale(f.rho, da), v3_scale(f.t, db)), -4.0 / r4);
	return (prim_g(f.c, f.y1) - prim_g(f.c, f.y0)) / r4;
}

double lattice_kernel_line(double rho, double R)
{
	double c = R * R - rho * rho;

	if (c <= 0.0)
		return 0.0;
	return 16.0 * c * c * sqrt(c) / (15.0 * R * R * R * R);
}

double lattice_weight_for_radius(double radius_mm, double C, double R)
{
	double c = R * R - radius_mm * radius_mm;

	if (!(c > 0.0))
		return INFINITY;
	return 15.0 * C * R * R * R * R / (16.0 * c * c * sqrt(c));
}

double lattice_radius_for_weight(double w, double C, double R)
{
	double q, r2;

	if (!(w > 0.0))
		return 0.0;
	q = pow(15.0 * C * R * R * R * R / (16.0 * w), 0.4); /* = R^2 - radius^2 */
	r2 = R * R - q;
	return r2 > 0.0 ? sqrt(r2) : 0.0;
}
