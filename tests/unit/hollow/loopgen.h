/* loopgen.h - synthetic loops for the optimiser's unit tests (header-only,
 * static inline; included by tests/unit/hollow/test_opt_*.c, not a test
 * itself).  Frame: printer frame, mm; loops counter-clockwise, the void
 * on their left (engine/hollow/opt/opt_int.h).
 */
#ifndef INFILLD_TEST_LOOPGEN_H
#define INFILLD_TEST_LOOPGEN_H

#include <math.h>
#include <string.h>

#include "engine/core/mem.h"
#include "engine/hollow/opt/opt_int.h"

/* Loop around the rectangle [x0, x1] x [y0, y1] (mm), counter-clockwise
 * from (x0, y0), every side cut into steps of at most s (mm). */
static inline void rect_loop(struct hl_loop *L, double x0, double y0, double x1, double y1,
			     double s, double z, int slice)
{
	double c[5][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}, {x0, y0}};
	size_t n = 0, cap = 0;

	memset(L, 0, sizeof *L);
	for (int e = 0; e < 4; e++)
		cap += (size_t)ceil(hypot(c[e + 1][0] - c[e][0], c[e + 1][1] - c[e][1]) / s);
	L->xy = mem_alloc(2 * cap * sizeof *L->xy);
	if (!L->xy)
		return;
	for (int e = 0; e < 4; e++) {
		int k = (int)ceil(hypot(c[e + 1][0] - c[e][0], c[e + 1][1] - c[e][1]) / s);
		for (int i = 0; i < k; i++) {
			double t = (double)i / k;
			L->xy[2 * n] = c[e][0] + t * (c[e + 1][0] - c[e][0]);
			L->xy[2 * n + 1] = c[e][1] + t * (c[e + 1][1] - c[e][1]);
			n++;
		}
	}
	L->n = n;
	L->z_mm = z;
	L->slice = slice;
	L->area_mm2 = (x1 - x0) * (y1 - y0);
}
/* Crossing-number point-in-polygon (any orientation). */
static inline int point_in(const double *xy, size_t n, double x, double y)
{
	int in = 0;

	for (size_t i = 0, j = n - 1; i < n; j = i++) {
		double xi = xy[2 * i], yi = xy[2 * i + 1], xj = xy[2 * j], yj = xy[2 * j + 1];
		if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi)
			in = !in;
	}
	return in;
}

#endif
