/* poles.c - shifting directions and upper bounds from Voronoi poles
 * (paper 004, section 6, eq. 8-10; derivation in docs/hollow.md).
 *
 * The samples of a loop are triangulated (Delaunay, exact predicates); the
 * Voronoi cell of sample v has the circumcentres of v's triangles as its
 * corners.  The inner pole is the farthest corner that lies inside the
 * loop: for a dense sample it approximates the centre of the largest
 * empty disc touching v (the medial axis).  r = (pole - v) / |pole - v|
 * points into the void region; the ray from v along r leaves the convex
 * cell exactly at the pole, so l^U = |pole - v| (eq. 9).  Staying inside
 * its own cell keeps every shifted vertex apart from the others, which is
 * what makes the shrunk loop free of self-intersections.  The truncated
 * Laplacian pass (eq. 10) is hl_bounds_smooth(): the caller skips it for a
 * void's top loop, which must be able to collapse onto its medial axis.
 * Cost: O(n log n) triangulation plus O(n * n) point-in-loop tests for the
 * ~2n circumcentres (n = a loop's samples, a few hundred).
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/delaunay.h"
#include "engine/hollow/opt/opt_int.h"

/* Does the horizontal ray from (x, y) to +x cross the loop's edge from
 * vertex j to vertex i?  The crossing-number test's one step. */
static int edge_crosses(const double *xy, size_t i, size_t j, double x, double y)
{
	double xi = xy[2 * i], yi = xy[2 * i + 1], xj = xy[2 * j], yj = xy[2 * j + 1];

	return (yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi;
}

int hl_loop_inside(const double *xy, size_t n, double x, double y)
{
	int in = 0;

	for (size_t i = 0, j = n - 1; i < n; j = i++)
		in ^= edge_crosses(xy, i, j, x, y);
	return in;
}

/* The loop's edges by horizontal slab: inside_slabs() tests only the
 * edges whose y-range meets the query's slab, with hl_loop_inside()'s
 * edge_crosses(), so the answer is the same (an edge that does
 * not span y adds no crossing) in O(edges per slab) instead of O(n).
 * A loop of fewer than 64 vertices, or one whose edges would fill more
 * than 16 n entries (long edges), is tested whole (ns 0). */
struct slabs {
	double y0, inv_h; /* slab k: y in [y0 + k / inv_h, y0 + (k + 1) / inv_h) */
	size_t ns;
	size_t *start;    /* edges of slab k: edge[start[k] .. start[k + 1]) */
	uint32_t *edge;   /* edge i joins vertices i and i - 1 (mod n) */
};

static size_t slab_of(const struct slabs *S, double y)
{
	double k = floor((y - S->y0) * S->inv_h);

	return k < 0 ? 0 : k >= (double)S->ns ? S->ns - 1 : (size_t)k;
}

/* Build S over the loop xy (n vertices); ns 0 (whole-loop tests) when
 * small, stretched or out of memory.  Frees with slabs_fini. */
static void slabs_build(struct slabs *S, const double *xy, size_t n)
{
	double y0 = INFINITY, y1 = -INFINITY;
	size_t total = 0;

	memset(S, 0, sizeof *S);
	if (n < 64 || n > UINT32_MAX)
		return;
	for (size_t i = 0; i < n; i++) {
		y0 = fmin(y0, xy[2 * i + 1]);
		y1 = fmax(y1, xy[2 * i + 1]);
	}
	if (!(y1 > y0))
		return;
	S->ns = n / 4;
	S->y0 = y0;
	S->inv_h = (double)S->ns / (y1 - y0);
	for (size_t i = 0, j = n - 1; i < n; j = i++)
		total += slab_of(S, fmax(xy[2 * i + 1], xy[2 * j + 1])) -
			 slab_of(S, fmin(xy[2 * i + 1], xy[2 * j + 1])) + 1;
	if (total > 16 * n ||
	    !(S->start = mem_calloc(S->ns + 1, sizeof *S->start)) ||
	    !(S->edge = mem_alloc(total * sizeof *S->edge))) {
		mem_free(S->start);
		memset(S, 0, sizeof *S);
		return;
	}
	for (size_t i = 0, j = n - 1; i < n; j = i++)
		for (size_t k = slab_of(S, fmin(xy[2 * i + 1], xy[2 * j + 1]));
		     k <= slab_of(S, fmax(xy[2 * i + 1], xy[2 * j + 1])); k++)
			S->start[k + 1]++;
	for (size_t k = 0; k < S->ns; k++)
		S->start[k + 1] += S->start[k];
	{
		size_t *fill = mem_alloc((S->ns + 1) * sizeof *fill);
		if (!fill) {
			mem_free(S->start);
			mem_free(S->edge);
			memset(S, 0, sizeof *S);
			return;
		}
		memcpy(fill, S->start, (S->ns + 1) * sizeof *fill);
		for (size_t i = 0, j = n - 1; i < n; j = i++)
			for (size_t k = slab_of(S, fmin(xy[2 * i + 1], xy[2 * j + 1]));
			     k <= slab_of(S, fmax(xy[2 * i + 1], xy[2 * j + 1])); k++)
				S->edge[fill[k]++] = (uint32_t)i;
		mem_free(fill);
	}
}

static void slabs_fini(struct slabs *S)
{
	mem_free(S->start);
	mem_free(S->edge);
	memset(S, 0, sizeof *S);
}

/* hl_loop_inside(xy, n, x, y) through S. */
static int inside_slabs(const struct slabs *S, const double *xy, size_t n, double x, double y)
{
	size_t k;
	int in = 0;

	if (!S->ns)
		return hl_loop_inside(xy, n, x, y);
	if (y < S->y0 || y > S->y0 + (double)S->ns / S->inv_h)
		return 0; /* no edge spans y */
	k = slab_of(S, y);
	for (size_t q = S->start[k]; q < S->start[k + 1]; q++) {
		size_t i = S->edge[q];
		in ^= edge_crosses(xy, i, i ? i - 1 : n - 1, x, y);
	}
	return in;
}

/* Inward unit normal at vertex j from its two edges (fallback direction). */
static void bisector_in(const double *xy, size_t n, size_t j, double *rx, double *ry)
{
	size_t a = (j + n - 1) % n, b = (j + 1) % n;
	double e1x = xy[2 * j] - xy[2 * a], e1y = xy[2 * j + 1] - xy[2 * a + 1];
	double e2x = xy[2 * b] - xy[2 * j], e2y = xy[2 * b + 1] - xy[2 * j + 1];
	double l1 = hypot(e1x, e1y), l2 = hypot(e2x, e2y);
	/* left normal of a counter-clockwise edge points into the loop */
	double nx = (l1 > 0 ? -e1y / l1 : 0) + (l2 > 0 ? -e2y / l2 : 0);
	double ny = (l1 > 0 ? e1x / l1 : 0) + (l2 > 0 ? e2x / l2 : 0);
	double l = hypot(nx, ny);

	*rx = l > 0 ? nx / l : 0;
	*ry = l > 0 ? ny / l : 0;
}

int hl_poles(const double *xy, size_t n, double *dir, double *ub, struct err *e)
{
	struct delaunay dt;
	struct pt2 *pts = NULL;
	double *cc = NULL, *raw = NULL;
	signed char *cin = NULL;
	uint32_t fan[512];
	struct slabs S;
	int rc = 0;

	delaunay_init(&dt);
	slabs_build(&S, xy, n);
	pts = mem_alloc(n * sizeof *pts);
	raw = mem_alloc(n * sizeof *raw);
	if (!pts || !raw)
		goto nomem;
	for (size_t j = 0; j < n; j++) {
		pts[j].x = geom_mm_to_nm(xy[2 * j]);
		pts[j].y = geom_mm_to_nm(xy[2 * j + 1]);
	}
	rc = delaunay_build(pts, n, &dt, e);
	if (rc)
		goto out;
	cc = mem_alloc((dt.nt ? dt.nt : 1) * 2 * sizeof *cc);
	cin = mem_alloc(dt.nt ? dt.nt : 1);
	if (!cc || !cin)
		goto nomem;
	memset(cin, -1, dt.nt ? dt.nt : 1); /* -1 = not yet classified */
	for (size_t j = 0; j < n; j++) {
		int closed;
		uint32_t v = dt.dup[j];
		size_t nf = delaunay_fan(&dt, v, fan, sizeof fan / sizeof fan[0], &closed);
		double best = -1, bx = 0, by = 0;

		for (size_t k = 0; k < nf; k++) {
			uint32_t t = fan[k];
			double d;
			if (cin[t] < 0) {
				delaunay_circumcenter_mm(&dt, pts, t, &cc[2 * t], &cc[2 * t + 1]);
				cin[t] = (signed char)inside_slabs(&S, xy, n, cc[2 * t],
								   cc[2 * t + 1]);
			}
			if (!cin[t])
				continue;
			d = hypot(cc[2 * t] - xy[2 * j], cc[2 * t + 1] - xy[2 * j + 1]);
			if (d > best) {
				best = d;
				bx = cc[2 * t];
				by = cc[2 * t + 1];
			}
		}
		if (best > 0 && v == j) {
			dir[2 * j] = (bx - xy[2 * j]) / best;
			dir[2 * j + 1] = (by - xy[2 * j + 1]) / best;
			raw[j] = best;
		} else {
			/* no inner Voronoi corner (or a repeated sample): keep the
			 * vertex fixed, pointing along the inward bisector */
			bisector_in(xy, n, j, &dir[2 * j], &dir[2 * j + 1]);
			raw[j] = 0;
		}
	}
	memcpy(ub, raw, n * sizeof *ub);
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "voronoi poles of %zu samples: out of memory", n);
out:
	slabs_fini(&S);
	delaunay_fini(&dt);
	mem_free(pts);
	mem_free(cc);
	mem_free(cin);
	mem_free(raw);
	return rc;
}

void hl_bounds_smooth(double *ub, size_t n, double *tmp)
{
	/* eq. 10, one Jacobi pass: l^U_j = min(l^U_j, (l^U_{j-1} + l^U_{j+1}) / 2).
	 * Repeating it would converge to the loop's minimum bound. */
	memcpy(tmp, ub, n * sizeof *tmp);
	for (size_t j = 0; j < n; j++) {
		double avg = 0.5 * (tmp[(j + n - 1) % n] + tmp[(j + 1) % n]);
		ub[j] = tmp[j] < avg ? tmp[j] : avg;
	}
}
