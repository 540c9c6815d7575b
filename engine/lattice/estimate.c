/* estimate.c - Appendix I of paper 000: tetrahedron edge length for a target
 * density.
 *
 * A regular tetrahedron of edge L (volume sqrt(2)/12 L^3) holds, of its six
 * struts (radius r), the cylinder parts between the node spheres
 * (length L - 2 sqrt(3) r, each a fraction acos(1/3)/(2 pi) inside) and of
 * its four node spheres (radius 2 r) the solid-angle fraction
 * (3 acos(1/3) - pi)/(4 pi).  Density rho = 6 sqrt(2) [3 a r^2 L +
 * (32 a - 6 sqrt(3) a - 32 pi/3) r^3] / L^3 with a = acos(1/3), i.e. the
 * cubic L^3 + p L + q = 0 with p = -18 sqrt(2) a r^2 / rho and
 * q = -((192 sqrt(2) - 36 sqrt(6)) a - 64 sqrt(2) pi) r^3 / rho
 * (docs/lattice.md 4.1 has the full derivation).
 */
#include "engine/lattice/gen.h"

#include <math.h>

double lattice_density_estimate(double L, double r)
{
	double a = acos(1.0 / 3.0);

	return 6 * sqrt(2.0) *
	       (3 * a * r * r * L + (32 * a - 6 * sqrt(3.0) * a - 32 * M_PI / 3) * r * r * r) /
	       (L * L * L);
}

double lattice_spacing_for_density(double rho, double r)
{
	double a = acos(1.0 / 3.0), p, q, L, disc;

	if (!(rho > 0))
		rho = 1e-6;
	if (rho > 1)
		rho = 1;
	p = -18 * sqrt(2.0) * a * r * r / rho;
	q = -((192 * sqrt(2.0) - 36 * sqrt(6.0)) * a - 64 * sqrt(2.0) * M_PI) * r * r * r / rho;
	disc = q * q / 4 + p * p * p / 27;
	if (disc < 0) {
		/* three real roots; the largest is the physical one (the others
		 * are shorter than the 2 sqrt(3) r the node spheres occupy) */
		double m = 2 * sqrt(-p / 3);
		double phi = acos(fmax(-1, fmin(1, 3 * q / (p * m))));
		L = m * cos(phi / 3);
	} else {
		double s = sqrt(disc);
		L = cbrt(-q / 2 + s) + cbrt(-q / 2 - s);
	}
	return fmax(L, 4 * r);
}
