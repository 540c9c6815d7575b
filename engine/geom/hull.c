/* hull.c - convex hull (monotone chain) and convex-polygon helpers (hull.h). */
#include "engine/geom/hull.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/predicates.h"

static int cmp_pt(const void *a, const void *b)
{
	const struct pt2 *p = a, *q = b;
	if (p->x != q->x)
		return p->x < q->x ? -1 : 1;
	return (p->y > q->y) - (p->y < q->y);
}

int hull_convex(const struct pt2 *p, size_t n, struct hull_pt **out, size_t *nout,
		struct err *e)
{
	struct pt2 *s = NULL, *h = NULL;
	struct hull_pt *r = NULL;
	size_t m = 0, k = 0, i;

	s = mem_alloc((n ? n : 1) * sizeof *s);
	h = mem_alloc((2 * n + 1) * sizeof *h);
	if (!s || !h)
		goto nomem;
	memcpy(s, p, n * sizeof *s);
	qsort(s, n, sizeof *s, cmp_pt);
	for (i = 0; i < n; i++) /* unique */
		if (m == 0 || s[i].x != s[m - 1].x || s[i].y != s[m - 1].y)
			s[m++] = s[i];
	if (m <= 2) {
		for (i = 0; i < m; i++)
			h[k++] = s[i];
	} else {
		/* lower chain then upper chain; pop on non-left turns (drops collinear) */
		for (i = 0; i < m; i++) {
			while (k >= 2 && geom_orient2d(h[k - 2], h[k - 1], s[i]) <= 0)
				k--;
			h[k++] = s[i];
		}
		for (size_t lo = k + 1, j = m - 1; j-- > 0;) {
			while (k >= lo && geom_orient2d(h[k - 2], h[k - 1], s[j]) <= 0)
				k--;
			h[k++] = s[j];
		}
		k--; /* last point repeats the first */
	}
	r = mem_alloc((k ? k : 1) * sizeof *r);
	if (!r)
		goto nomem;
	for (i = 0; i < k; i++) {
		r[i].x = geom_nm_to_mm(h[i].x);
		r[i].y = geom_nm_to_mm(h[i].y);
	}
	mem_free(s);
	mem_free(h);
	*out = r;
	*nout = k;
	return 0;
nomem:
	mem_free(s);
	mem_free(h);
	return ERR_SET(e, ERR_NOMEM, "convex hull of %zu points: out of memory", n);
}

double hull_area_mm2(const struct hull_pt *h, size_t n)
{
	double a = 0;

	for (size_t i = 0; i < n; i++) {
		const struct hull_pt *p = &h[i], *q = &h[(i + 1) % n];
		a += (p->x - h[0].x) * (q->y - h[0].y) - (q->x - h[0].x) * (p->y - h[0].y);
	}
	return 0.5 * a;
}

double hull_closest_mm(const struct hull_pt *h, size_t n, struct hull_pt q, struct hull_pt *c,
		       int *edge, int *vertex)
{
	double best = INFINITY;
	int inside = 1;

	*edge = -1;
	*vertex = 0;
	for (size_t i = 0; i < n; i++) {
		struct hull_pt a = h[i], b = h[(i + 1) % n];
		double dx = b.x - a.x, dy = b.y - a.y;
		double l2 = dx * dx + dy * dy;
		double t = l2 > 0 ? ((q.x - a.x) * dx + (q.y - a.y) * dy) / l2 : 0;
		int at_vertex = 0;
		size_t ei = i;
		struct hull_pt f;
		double d;

		if (dx * (q.y - a.y) - dy * (q.x - a.x) < 0)
			inside = 0;
		if (t <= 0) {
			t = 0;
			at_vertex = 1;
		} else if (t >= 1) {
			t = 1;
			at_vertex = 1;
			ei = (i + 1) % n;
		}
		f.x = a.x + t * dx;
		f.y = a.y + t * dy;
		d = hypot(q.x - f.x, q.y - f.y);
		if (d < best) {
			best = d;
			*c = f;
			*edge = (int)ei;
			*vertex = at_vertex;
		}
	}
	if (inside) {
		*c = q;
		*edge = -1;
		*vertex = 0;
		return 0;
	}
	return best;
}

double hull_signed_distance_mm(const struct hull_pt *h, size_t n, struct hull_pt q)
{
	struct hull_pt c;
	int edge, vertex;
	double d = hull_closest_mm(h, n, q, &c, &edge, &vertex);
	double in = INFINITY;

	if (d > 0)
		return -d;
	for (size_t i = 0; i < n; i++) { /* inside: distance to the nearest edge line */
		struct hull_pt a = h[i], b = h[(i + 1) % n];
		double l = hypot(b.x - a.x, b.y - a.y);
		if (l > 0)
			in = fmin(in, ((b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x)) / l);
	}
	return in;
}

/* Clip convex polygon src (ns points) by the half-plane n.(x - o) >= d into
 * dst (room for ns + 1); returns the new count. */
static size_t clip_half(const struct hull_pt *src, size_t ns, double nx, double ny,
			double ox, double oy, double d, struct hull_pt *dst)
{
	size_t k = 0;

	for (size_t i = 0; i < ns; i++) {
		struct hull_pt a = src[i], b = src[(i + 1) % ns];
		double fa = nx * (a.x - ox) + ny * (a.y - oy) - d;
		double fb = nx * (b.x - ox) + ny * (b.y - oy) - d;
		if (fa >= 0)
			dst[k++] = a;
		if ((fa >= 0) != (fb >= 0)) {
			double t = fa / (fa - fb);
			dst[k].x = a.x + t * (b.x - a.x);
			dst[k].y = a.y + t * (b.y - a.y);
			k++;
		}
	}
	return k;
}

/* Erode into buf (two scratch arrays of 2n + 2 points); returns the count
 * and which buffer holds it. */
static size_t offset_into(const struct hull_pt *h, size_t n, double d, struct hull_pt *b0,
			  struct hull_pt *b1, struct hull_pt **res)
{
	struct hull_pt *cur = b0, *nxt = b1;
	size_t m = n;

	memcpy(cur, h, n * sizeof *h);
	for (size_t i = 0; i < n && m > 0; i++) {
		struct hull_pt a = h[i], b = h[(i + 1) % n];
		double l = hypot(b.x - a.x, b.y - a.y);
		struct hull_pt *t;
		if (l <= 0)
			continue;
		/* inward normal of a CCW edge: its left side */
		m = clip_half(cur, m, -(b.y - a.y) / l, (b.x - a.x) / l, a.x, a.y, d, nxt);
		t = cur;
		cur = nxt;
		nxt = t;
	}
	*res = cur;
	return m >= 3 ? m : 0;
}

int hull_offset_in(const struct hull_pt *h, size_t n, double d_mm, struct hull_pt **out,
		   size_t *nout, struct err *e)
{
	struct hull_pt *b0 = mem_alloc((2 * n + 2) * sizeof *b0);
	struct hull_pt *b1 = mem_alloc((2 * n + 2) * sizeof *b1);
	struct hull_pt *res, *r;
	size_t m;

	if (!b0 || !b1) {
		mem_free(b0);
		mem_free(b1);
		return ERR_SET(e, ERR_NOMEM, "offsetting a convex polygon: out of memory");
	}
	m = n >= 3 ? offset_into(h, n, d_mm, b0, b1, &res) : 0;
	r = NULL;
	if (m) {
		r = mem_alloc(m * sizeof *r);
		if (!r) {
			mem_free(b0);
			mem_free(b1);
			return ERR_SET(e, ERR_NOMEM, "offsetting a convex polygon: out of memory");
		}
		memcpy(r, res, m * sizeof *r);
	}
	mem_free(b0);
	mem_free(b1);
	*out = r;
	*nout = m;
	return 0;
}

double hull_inradius_mm(const struct hull_pt *h, size_t n, struct hull_pt *center)
{
	struct hull_pt *b0, *b1, *res;
	double lo = 0, hi = 0, cx = 0, cy = 0;

	if (n < 3)
		return 0;
	b0 = mem_alloc((2 * n + 2) * sizeof *b0);
	b1 = mem_alloc((2 * n + 2) * sizeof *b1);
	if (!b0 || !b1) {
		mem_free(b0);
		mem_free(b1);
		return 0;
	}
	for (size_t i = 0; i < n; i++) {
		hi = fmax(hi, fabs(h[i].x - h[0].x));
		hi = fmax(hi, fabs(h[i].y - h[0].y));
	}
	for (int it = 0; it < 100 && hi - lo > 1e-9 * (hi + 1e-12); it++) {
		double mid = 0.5 * (lo + hi);
		if (offset_into(h, n, mid, b0, b1, &res) > 0)
			lo = mid;
		else
			hi = mid;
	}
	{
		size_t m = offset_into(h, n, lo, b0, b1, &res);
		for (size_t i = 0; i < m; i++) {
			cx += res[i].x / (double)m;
			cy += res[i].y / (double)m;
		}
		if (m == 0) {
			cx = h[0].x;
			cy = h[0].y;
		}
	}
	if (center) {
		center->x = cx;
		center->y = cy;
	}
	mem_free(b0);
	mem_free(b1);
	return lo;
}
