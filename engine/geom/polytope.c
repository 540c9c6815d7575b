/* polytope.c - Chebyshev centre by a dense simplex (see polytope.h).
 *
 * With x = start + y, the problem is: maximise r subject to
 * n_i . y + |n_i| r <= b_i = d_i - n_i . start (b_i > 0) and |y_j| <= box.
 * The free y_j are split as y+ - y-, so x = 0 (all slacks basic) is a
 * feasible start.  Dantzig's rule for the first pivots, then Bland's rule,
 * which prevents cycling.
 */
#include "engine/geom/polytope.h"
#include "engine/core/mem.h"

#include <math.h>

#define MAX_CONSTRAINTS 512
#define NV 7 /* y1+ y1- y2+ y2- y3+ y3- r */

int geom_chebyshev_center(const struct vec3 *n, const double *d, size_t m, struct vec3 start,
			  double box_mm, struct vec3 *center, double *radius)
{
	size_t rows = m + 6, cols = NV + rows + 1; /* vars, slacks, rhs */
	double *T;
	size_t *basis;
	int rc = -1;

	if (m == 0 || m > MAX_CONSTRAINTS || !(box_mm > 0))
		return -1;
	T = mem_calloc((rows + 1) * cols, sizeof *T);
	basis = mem_alloc(rows * sizeof *basis);
	if (!T || !basis)
		goto out;
#define A(i, j) T[(i) * cols + (j)]
	for (size_t i = 0; i < m; i++) {
		double nn = v3_len(n[i]), b = d[i] - v3_dot(n[i], start);
		if (!(b > 0) || !(nn > 0))
			goto out;
		A(i, 0) = n[i].x;
		A(i, 1) = -n[i].x;
		A(i, 2) = n[i].y;
		A(i, 3) = -n[i].y;
		A(i, 4) = n[i].z;
		A(i, 5) = -n[i].z;
		A(i, 6) = nn;
		A(i, cols - 1) = b;
	}
	for (size_t j = 0; j < 6; j++) { /* y+_k <= box, y-_k <= box */
		A(m + j, j) = 1;
		A(m + j, cols - 1) = box_mm;
	}
	for (size_t i = 0; i < rows; i++) {
		A(i, NV + i) = 1;
		basis[i] = NV + i;
	}
	/* objective row: reduced costs of maximising r */
	A(rows, 6) = 1;
	for (int it = 0; it < 2000; it++) {
		size_t enter = cols, leave = rows;
		double best = INFINITY;

		if (it < 64) {
			/* Dantzig: the largest reduced cost (few pivots) */
			double best_c = 1e-12;
			for (size_t j = 0; j + 1 < cols; j++)
				if (A(rows, j) > best_c) {
					best_c = A(rows, j);
					enter = j;
				}
		} else {
			/* then Bland's lowest index, which cannot cycle */
			for (size_t j = 0; j + 1 < cols; j++)
				if (A(rows, j) > 1e-12) {
					enter = j;
					break;
				}
		}
		if (enter == cols) {
			double y[NV] = {0};
			for (size_t i = 0; i < rows; i++)
				if (basis[i] < NV)
					y[basis[i]] = A(i, cols - 1);
			*center = v3(start.x + y[0] - y[1], start.y + y[2] - y[3], start.z + y[4] - y[5]);
			*radius = y[6];
			rc = 0;
			goto out;
		}
		for (size_t i = 0; i < rows; i++)
			if (A(i, enter) > 1e-12) {
				double ratio = A(i, cols - 1) / A(i, enter);
				if (ratio < best - 1e-15 ||
				    (ratio <= best + 1e-15 && leave < rows && basis[i] < basis[leave])) {
					best = ratio;
					leave = i;
				}
			}
		if (leave == rows)
			goto out; /* unbounded: cannot happen with the box */
		{
			double pv = A(leave, enter);
			for (size_t j = 0; j < cols; j++)
				A(leave, j) /= pv;
			for (size_t i = 0; i <= rows; i++) {
				double f = A(i, enter);
				if (i == leave || f == 0)
					continue;
				for (size_t j = 0; j < cols; j++)
					A(i, j) -= f * A(leave, j);
			}
			basis[leave] = enter;
		}
	}
#undef A
out:
	mem_free(T);
	mem_free(basis);
	return rc;
}
