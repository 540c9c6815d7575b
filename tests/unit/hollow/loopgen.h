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

/* Loop through the nc corners c (mm, counter-clockwise, not repeated),
 * every side cut into steps of at most s (mm); the corners are vertices. */
static inline void corner_loop(struct hl_loop *L, const double (*c)[2], int nc, double s, double z,
			       int slice)
{
	size_t n = 0, cap = 0;
	double a = 0;

	memset(L, 0, sizeof *L);
	for (int e = 0; e < nc; e++) {
		const double *p = c[e], *q = c[(e + 1) % nc];
		cap += (size_t)ceil(hypot(q[0] - p[0], q[1] - p[1]) / s);
		a += p[0] * q[1] - q[0] * p[1];
	}
	L->xy = mem_alloc(2 * cap * sizeof *L->xy);
	if (!L->xy)
		return;
	for (int e = 0; e < nc; e++) {
		const double *p = c[e], *q = c[(e + 1) % nc];
		int k = (int)ceil(hypot(q[0] - p[0], q[1] - p[1]) / s);
		for (int i = 0; i < k; i++) {
			double t = (double)i / k;
			L->xy[2 * n] = p[0] + t * (q[0] - p[0]);
			L->xy[2 * n + 1] = p[1] + t * (q[1] - p[1]);
			n++;
		}
	}
	L->n = n;
	L->z_mm = z;
	L->slice = slice;
	L->area_mm2 = 0.5 * a;
}

/* Loop around the rectangle [x0, x1] x [y0, y1] (mm), counter-clockwise
 * from (x0, y0), every side cut into steps of at most s (mm). */
static inline void rect_loop(struct hl_loop *L, double x0, double y0, double x1, double y1,
			     double s, double z, int slice)
{
	const double c[4][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};

	corner_loop(L, c, 4, s, z, slice);
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

/* Twice the signed area of the triangle a b c (> 0: counter-clockwise). */
static inline double loop_orient(const double *a, const double *b, const double *c)
{
	return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* Do the closed segments ab and cd cross or touch? */
static inline int seg_meet(const double *a, const double *b, const double *c, const double *d)
{
	double o1 = loop_orient(a, b, c), o2 = loop_orient(a, b, d), o3 = loop_orient(c, d, a),
	       o4 = loop_orient(c, d, b);

	if (o1 * o2 < 0 && o3 * o4 < 0)
		return 1; /* proper crossing */
	/* collinear touching */
	for (int k = 0; k < 4; k++) {
		const double *p = k == 0 ? c : k == 1 ? d : k == 2 ? a : b;
		const double *s0 = k < 2 ? a : c, *s1 = k < 2 ? b : d;
		double o = k == 0 ? o1 : k == 1 ? o2 : k == 2 ? o3 : o4;
		if (o == 0 && p[0] >= fmin(s0[0], s1[0]) && p[0] <= fmax(s0[0], s1[0]) &&
		    p[1] >= fmin(s0[1], s1[1]) && p[1] <= fmax(s0[1], s1[1]))
			return 1;
	}
	return 0;
}

/* Is the closed polygon xy simple (no two non-adjacent edges meet)? */
static inline int is_simple(const double *xy, size_t n)
{
	for (size_t i = 0; i < n; i++)
		for (size_t j = i + 1; j < n; j++) {
			size_t i1 = (i + 1) % n, j1 = (j + 1) % n;
			if (j == i1 || i == j1)
				continue;
			if (seg_meet(xy + 2 * i, xy + 2 * i1, xy + 2 * j, xy + 2 * j1))
				return 0;
		}
	return 1;
}

#endif
