/* kernel.h - the convolution integral of one strut and the weight <-> radius map.
 *
 * Paper 000 (Liu et al., "Memory-efficient modeling and slicing of
 * large-scale adaptive lattice structures"), eq. 5-7, re-derived in
 * docs/lattice.md section 2 (the printed eq. 7 is garbled).  Kernel
 * f(d) = (1 - d^2/R^2)^2 for d < R, else 0; a strut p1 -> p2 contributes
 * I(p) = integral over the segment (arc length, mm) of f(|p - x|), so I has
 * units of mm.  The lattice field is F(p) = sum_j w_j I_j(p) - C and the
 * solid is F > 0 (the paper prints F < 0 with the opposite sign).
 */
#ifndef INFILLD_LATTICE_KERNEL_H
#define INFILLD_LATTICE_KERNEL_H

#include "engine/geom/vec.h"

/* Closed form of the integral (mm) for the segment p1 -> p2 at p with
 * support R (mm, > 0).  Exact to rounding; 0 beyond distance R.  A
 * zero-length segment contributes 0 (it has no length to integrate). */
double lattice_kernel_integral(struct vec3 p, struct vec3 p1, struct vec3 p2, double R);

/* Integral and its gradient with respect to p (dimensionless, mm/mm).
 * Returns the integral; *grad receives the gradient (zero outside the
 * support).  The gradient is continuous everywhere (C1 field). */
double lattice_kernel_gradient(struct vec3 p, struct vec3 p1, struct vec3 p2, double R,
			       struct vec3 *grad);

/* Integral across an infinitely long strut at distance rho (mm):
 * 16 (R^2 - rho^2)^(5/2) / (15 R^4), 0 for rho >= R. */
double lattice_kernel_line(double rho, double R);

/* Weight w that makes an isolated long strut's solid (w I > C) a cylinder
 * of radius radius_mm: w = 15 C R^4 / (16 (R^2 - radius^2)^(5/2)).
 * radius_mm must lie in [0, R); returns +inf at or beyond R. */
double lattice_weight_for_radius(double radius_mm, double C, double R);

/* Inverse: realised radius (mm) of an isolated long strut of weight w:
 * sqrt(R^2 - (15 C R^4 / (16 w))^(2/5)); 0 when the weight is too small
 * to reach C even on the axis (w <= 15 C / (16 R)). */
double lattice_radius_for_weight(double w, double C, double R);

#endif
