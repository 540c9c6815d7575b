/* element.c - the trilinear hex8 element: stiffness K0 (2x2x2 Gauss),
 * the centre strain matrix for stresses, the isotropic material matrix,
 * and the child prolongations of the first Galerkin level (mg.c).
 * Method: docs/fea.md, "Element".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <string.h>

/* Isotropic elasticity D (6 x 6, row-major, MPa) in Voigt order
 * {xx, yy, zz, yz, xz, xy} with engineering shear strains. */
void fea_dmatrix(struct fea_material mat, double d[36])
{
	double E = mat.E_mpa, nu = mat.nu;
	double c = E / ((1 + nu) * (1 - 2 * nu));

	memset(d, 0, 36 * sizeof *d);
	for (int i = 0; i < 3; i++)
		for (int j = 0; j < 3; j++)
			d[i * 6 + j] = c * (i == j ? 1 - nu : nu);
	for (int i = 3; i < 6; i++)
		d[i * 6 + i] = c * (1 - 2 * nu) / 2;
}

/* Strain-displacement matrix B (6 x 24, row-major, 1/mm) at natural
 * coordinates (xi, eta, zeta) in [-1, 1]^3 of a cube of edge h_mm. */
static void bmatrix(double h_mm, double xi, double eta, double zeta, double b[6 * 24])
{
	memset(b, 0, 6 * 24 * sizeof *b);
	for (int n = 0; n < 8; n++) {
		double sx = (n & 1) ? 1 : -1, sy = (n & 2) ? 1 : -1, sz = (n & 4) ? 1 : -1;
		/* dN/dx = (2 / h) dN/dxi */
		double dx = sx * (1 + sy * eta) * (1 + sz * zeta) / 8 * 2 / h_mm;
		double dy = sy * (1 + sx * xi) * (1 + sz * zeta) / 8 * 2 / h_mm;
		double dz = sz * (1 + sx * xi) * (1 + sy * eta) / 8 * 2 / h_mm;
		int c = 3 * n;

		b[0 * 24 + c + 0] = dx;
		b[1 * 24 + c + 1] = dy;
		b[2 * 24 + c + 2] = dz;
		b[3 * 24 + c + 1] = dz; /* gamma_yz = du_y/dz + du_z/dy */
		b[3 * 24 + c + 2] = dy;
		b[4 * 24 + c + 0] = dz; /* gamma_xz */
		b[4 * 24 + c + 2] = dx;
		b[5 * 24 + c + 0] = dy; /* gamma_xy */
		b[5 * 24 + c + 1] = dx;
	}
}

void fea_bcentre(double h_mm, double b[6 * 24])
{
	bmatrix(h_mm, 0, 0, 0, b);
}

void fea_element_matrix(struct fea_material mat, double h_mm, double ke[24 * 24])
{
	double d[36], b[6 * 24], db[6 * 24];
	double g = 1 / sqrt(3.0), detj = h_mm * h_mm * h_mm / 8;

	fea_dmatrix(mat, d);
	memset(ke, 0, 24 * 24 * sizeof *ke);
	for (int q = 0; q < 8; q++) {
		bmatrix(h_mm, (q & 1) ? g : -g, (q & 2) ? g : -g, (q & 4) ? g : -g, b);
		for (int i = 0; i < 6; i++)
			for (int c = 0; c < 24; c++) {
				double s = 0;
				for (int k = 0; k < 6; k++)
					s += d[i * 6 + k] * b[k * 24 + c];
				db[i * 24 + c] = s;
			}
		for (int r = 0; r < 24; r++)
			for (int c = 0; c < 24; c++) {
				double s = 0;
				for (int k = 0; k < 6; k++)
					s += b[k * 24 + r] * db[k * 24 + c];
				ke[r * 24 + c] += s * detj; /* Gauss weights are 1 */
			}
	}
	/* exact symmetry (the sums above are symmetric up to rounding) */
	for (int r = 0; r < 24; r++)
		for (int c = r + 1; c < 24; c++) {
			double s = (ke[r * 24 + c] + ke[c * 24 + r]) / 2;
			ke[r * 24 + c] = ke[c * 24 + r] = s;
		}
}

/* P_c (24 x 24, row-major): the 24 unknowns of child c (c = cx + 2 cy +
 * 4 cz, the child spanning [c, c + 1] / 2 of its parent) from the 24 of
 * the parent element, by trilinear interpolation (the global
 * prolongation restricted to one fine element). */
void fea_child_prolong(int c, double p[24 * 24])
{
	memset(p, 0, 24 * 24 * sizeof *p);
	for (int l = 0; l < 8; l++) {
		/* fine node position inside the parent, in half-edges: 0, 1, 2 */
		int o[3] = {((c >> 0) & 1) + ((l >> 0) & 1), ((c >> 1) & 1) + ((l >> 1) & 1),
			    ((c >> 2) & 1) + ((l >> 2) & 1)};
		for (int L = 0; L < 8; L++) {
			double w = 1;
			for (int ax = 0; ax < 3; ax++)
				w *= ((L >> ax) & 1) ? o[ax] / 2.0 : 1 - o[ax] / 2.0;
			for (int a = 0; a < 3; a++)
				p[(3 * l + a) * 24 + 3 * L + a] = w;
		}
	}
}
