/* toolpath_fill.c - rectilinear infill lines by a scanline sweep (see
 * tp_fill_lines() in toolpath_int.h).
 *
 * Frame: the region is rotated by -angle so infill lines run along +t;
 * line m lies at v = (m + 1/2) d, v measured from the printer origin, so
 * the grid is the same on every layer of equal direction (sparse lines
 * stack).  Every edge contributes one crossing per line in its v-range,
 * taken half-open [vmin, vmax) so a vertex on a line is counted once;
 * horizontal edges (in the rotated frame) contribute nothing.  Crossings
 * are sorted by (line, t) and swept with their winding directions; spans
 * of nonzero winding are the infill lines.  O(E + K log K) for K
 * crossings.
 */
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <stdlib.h>

struct xing {
	int64_t m; /* line index */
	double t;  /* position along the line, nm */
	int dir;   /* +1 edge going up in v, -1 down */
};

static int xing_cmp(const void *pa, const void *pb)
{
	const struct xing *a = pa, *b = pb;

	if (a->m != b->m)
		return a->m < b->m ? -1 : 1;
	if (a->t != b->t)
		return a->t < b->t ? -1 : 1;
	return a->dir - b->dir;
}

int tp_fill_lines(const struct paths *area, double angle_rad, int64_t spacing_nm,
		  int64_t min_len_nm, enum tp_role role, int64_t width_nm, struct tp_plan *items,
		  struct err *e)
{
	double cs = cos(angle_rad), sn = sin(angle_rad), d = (double)spacing_nm;
	struct xing *xs = NULL;
	size_t n = 0, cap = 0;
	int rc = 0;

	if (spacing_nm <= 0)
		return ERR_SET(e, ERR_INTERNAL, "infill spacing %lld nm", (long long)spacing_nm);
	for (size_t i = 0; i < area->n; i++) {
		const struct path *p = &area->v[i];
		for (size_t j = 0; p->n >= 3 && j < p->n; j++) {
			struct pt2 a = p->pts[j], b = p->pts[(j + 1) % p->n];
			double ta = (double)a.x * cs + (double)a.y * sn;
			double va = -(double)a.x * sn + (double)a.y * cs;
			double tb = (double)b.x * cs + (double)b.y * sn;
			double vb = -(double)b.x * sn + (double)b.y * cs;
			double vlo = va < vb ? va : vb, vhi = va < vb ? vb : va;
			int64_t m0, m1;
			if (va == vb)
				continue;
			/* (m + 1/2) d in [vlo, vhi) */
			m0 = (int64_t)ceil(vlo / d - 0.5);
			m1 = (int64_t)ceil(vhi / d - 0.5) - 1;
			if (m1 < m0)
				continue;
			if ((uint64_t)(m1 - m0) > 1000000u) {
				rc = ERR_SET(e, ERR_LIMIT, "infill of %lld lines across one edge",
					     (long long)(m1 - m0));
				goto out;
			}
			if (n + (size_t)(m1 - m0 + 1) > cap) {
				void *a2 = xs;
				if (mem_grow(&a2, &cap, n + (size_t)(m1 - m0 + 1), sizeof *xs)) {
					rc = ERR_SET(e, ERR_NOMEM, "out of memory filling a layer");
					goto out;
				}
				xs = a2;
			}
			for (int64_t m = m0; m <= m1; m++) {
				double v = ((double)m + 0.5) * d;
				xs[n].m = m;
				xs[n].t = ta + (v - va) * (tb - ta) / (vb - va);
				xs[n].dir = vb > va ? 1 : -1;
				n++;
			}
		}
	}
	if (n)
		qsort(xs, n, sizeof *xs, xing_cmp);
	for (size_t i = 0; i < n;) {
		size_t j = i;
		int w = 0;
		double t0 = 0;
		double v = ((double)xs[i].m + 0.5) * d;
		while (j < n && xs[j].m == xs[i].m) {
			int was = w != 0;
			w += xs[j].dir;
			if (!was && w != 0) {
				t0 = xs[j].t;
			} else if (was && w == 0 && xs[j].t - t0 >= (double)min_len_nm) {
				struct pt2 seg[2];
				seg[0].x = (int64_t)llround(t0 * cs - v * sn);
				seg[0].y = (int64_t)llround(t0 * sn + v * cs);
				seg[1].x = (int64_t)llround(xs[j].t * cs - v * sn);
				seg[1].y = (int64_t)llround(xs[j].t * sn + v * cs);
				rc = tp_plan_add(items, role, 0, -1, width_nm, seg, 2, NULL, e);
				if (rc)
					goto out;
			}
			j++;
		}
		i = j;
	}
out:
	mem_free(xs);
	return rc;
}
