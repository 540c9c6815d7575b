/* toolpath_thin.c - centrelines with local bead widths for material
 * narrower than a line width: thin walls and the gaps perimeters leave
 * (tp_thin() in toolpath_int.h; docs/gcode.md, "thin walls").
 *
 * A piece P (a thin strip, ring or blob of the region) is shrunk by d, a
 * little under half the narrowest printable width: what survives is a
 * sliver hugging P's medial axis wherever P is at least 2d wide.  A
 * sliver around an open strip is cut at its two mutually farthest
 * vertices into two sides; points sampled along one side are paired
 * with their nearest points on the other, and the midpoints of the pairs
 * form the centreline, their distance plus 2d the local width (the two
 * walls of a strip run side by side, so this pairs each wall point with
 * the one across).  A
 * sliver with a hole (a ring-shaped wall) keeps its outer loop, closed,
 * and each vertex moves to the middle of the chord through it that joins
 * the nearest wall point to the opposite wall, the chord's length being
 * the width there.
 */
#include "engine/output/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"

#include <math.h>
#include <string.h>

/* Bead widths are rounded down to this step so ;WIDTH: changes rarely. */
#define WIDTH_STEP_NM 5000
/* Centred vertices closer than this to the previous one are merged. */
#define MIN_STEP_NM 20000
/* Pieces shrink by this fraction of the narrowest printable width: parts
 * at least 90% of it wide survive. */
#define SHRINK 0.45
/* Spacing of the samples along a strip's sides. */
#define STRIP_STEP_NM 200000

struct thin_buf {
	struct pt2 *pts;
	int64_t *w;
	size_t n, cap_p, cap_w;
};

static int push(struct thin_buf *b, struct pt2 p, int64_t w)
{
	void *a = b->pts;

	if (mem_grow(&a, &b->cap_p, b->n + 1, sizeof *b->pts))
		return ERR_NOMEM;
	b->pts = a;
	a = b->w;
	if (mem_grow(&a, &b->cap_w, b->n + 1, sizeof *b->w))
		return ERR_NOMEM;
	b->w = a;
	b->pts[b->n] = p;
	b->w[b->n] = w;
	b->n++;
	return 0;
}

static int path_contains(const struct path *p, struct pt2 q)
{
	struct paths one = {(struct path *)p, 1, 1};

	return paths_winding(&one, q) != 0;
}

static int bbox_contains(const struct path *p, struct pt2 q)
{
	struct paths one = {(struct path *)p, 1, 1};
	struct pt2 lo, hi;

	return paths_bbox(&one, &lo, &hi) && q.x >= lo.x && q.x <= hi.x && q.y >= lo.y &&
	       q.y <= hi.y;
}

/* Centre p between the walls: *c and the local width *w_nm. */
static void centre(struct tp_index *ix, struct pt2 p, int64_t max_w, struct pt2 *c,
		   int64_t *w_nm)
{
	struct pt2 q1, q2, far;
	double r, ux, uy;

	*c = p;
	if (!tp_index_nearest(ix, p, 2 * max_w, &q1)) {
		*w_nm = max_w;
		return;
	}
	r = tp_dist_nm(p, q1);
	*w_nm = (int64_t)(2 * r);
	if (r < 1)
		return;
	ux = (double)(p.x - q1.x) / r;
	uy = (double)(p.y - q1.y) / r;
	far.x = q1.x + (int64_t)llround(ux * 1.5 * (double)max_w);
	far.y = q1.y + (int64_t)llround(uy * 1.5 * (double)max_w);
	/* The chord must reach past p: meetings before it are the wall q1 sits
	 * on (at a vertex, its two edges). */
	if (tp_index_first_hit(ix, q1, far, (int64_t)r, &q2)) {
		struct pt2 m = {q1.x + (q2.x - q1.x) / 2, q1.y + (q2.y - q1.y) / 2};
		struct pt2 q3;
		double wc = tp_dist_nm(q1, q2), rm;
		/* Keep the narrower of the chord and twice the clearance at the
		 * new centre (another wall may be closer than the chord ends). */
		rm = tp_index_nearest(ix, m, 2 * max_w, &q3) ? tp_dist_nm(m, q3) : wc / 2;
		*c = m;
		*w_nm = (int64_t)(wc < 2 * rm ? wc : 2 * rm);
	}
}

/* Centre the chain pts[0..n) (closed: a loop) and append it as a path. */
static int emit_chain(struct tp_index *ix, const struct pt2 *pts, size_t n, int closed,
		      enum tp_role role, int64_t min_w, int64_t max_w, struct thin_buf *b,
		      struct tp_plan *items, struct err *e, int *added)
{
	double len = 0;

	b->n = 0;
	for (size_t i = 0; i < n; i++) {
		struct pt2 c;
		int64_t w;
		centre(ix, pts[i], max_w, &c, &w);
		if (w > max_w)
			w = max_w;
		if (w < min_w)
			w = min_w;
		w -= w % WIDTH_STEP_NM;
		if (b->n && tp_dist_nm(c, b->pts[b->n - 1]) < MIN_STEP_NM) {
			if (w < b->w[b->n - 1])
				b->w[b->n - 1] = w;
			continue;
		}
		if (b->n)
			len += tp_dist_nm(c, b->pts[b->n - 1]);
		if (push(b, c, w))
			return ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
	}
	if (closed && b->n > 2 && tp_dist_nm(b->pts[0], b->pts[b->n - 1]) < MIN_STEP_NM)
		b->n--;
	if (b->n < 2 || (closed && b->n < 3) || len < (double)min_w / 2)
		return 0;
	/* Segment k takes the narrower of its two end widths. */
	for (size_t k = 0; k < b->n; k++) {
		int64_t w2 = closed || k + 1 < b->n ? b->w[(k + 1) % b->n] : b->w[k];
		if (w2 < b->w[k])
			b->w[k] = w2;
	}
	*added = 1;
	return tp_plan_add(items, role, closed, -1, b->w[0], b->pts, b->n, b->w, e);
}

/* Samples along a polyline at increasing arc lengths. */
struct walker {
	const struct pt2 *p;
	size_t n, i;  /* current segment p[i] -> p[i + 1] */
	double at;    /* arc length at p[i] */
};

static void walk_at(struct walker *wk, double s, double *x, double *y)
{
	while (wk->i + 1 < wk->n - 1 && wk->at + tp_dist_nm(wk->p[wk->i], wk->p[wk->i + 1]) < s) {
		wk->at += tp_dist_nm(wk->p[wk->i], wk->p[wk->i + 1]);
		wk->i++;
	}
	{
		struct pt2 a = wk->p[wk->i], b = wk->p[wk->i + 1 < wk->n ? wk->i + 1 : wk->i];
		double l = tp_dist_nm(a, b), t = l > 0 ? (s - wk->at) / l : 0;
		if (t < 0)
			t = 0;
		if (t > 1)
			t = 1;
		*x = (double)a.x + t * (double)(b.x - a.x);
		*y = (double)a.y + t * (double)(b.y - a.y);
	}
}

/* Nearest point to (x, y) on polyline p. O(n). */
static void nearest_on(const struct pt2 *p, size_t n, double x, double y, double *qx, double *qy)
{
	double best = INFINITY;

	*qx = (double)p[0].x;
	*qy = (double)p[0].y;
	for (size_t i = 0; i + 1 < n || (n == 1 && i == 0); i++) {
		struct pt2 a = p[i], b = p[i + 1 < n ? i + 1 : i];
		double dx = (double)(b.x - a.x), dy = (double)(b.y - a.y), l2 = dx * dx + dy * dy;
		double t = l2 > 0 ? ((x - (double)a.x) * dx + (y - (double)a.y) * dy) / l2 : 0, px, py, d;
		if (t < 0)
			t = 0;
		if (t > 1)
			t = 1;
		px = (double)a.x + t * dx;
		py = (double)a.y + t * dy;
		d = (px - x) * (px - x) + (py - y) * (py - y);
		if (d < best) {
			best = d;
			*qx = px;
			*qy = py;
		}
		if (n == 1)
			break;
	}
}

static double poly_len(const struct pt2 *p, size_t n)
{
	double l = 0;

	for (size_t i = 0; i + 1 < n; i++)
		l += tp_dist_nm(p[i], p[i + 1]);
	return l;
}

/* Centreline of an open strip's sliver from its two sides l and r (both
 * running from the same end to the other), d = the shrink distance. */
static int emit_strip(struct tp_index *ix, const struct pt2 *l, size_t nl, const struct pt2 *r,
		      size_t nr, double d, enum tp_role role, int64_t min_w, int64_t max_w, struct thin_buf *b,
		      struct tp_plan *items, struct err *e, int *added)
{
	double ll = poly_len(l, nl), total = 0;
	size_t n = (size_t)ceil(ll / STRIP_STEP_NM) + 1, k = 0;
	struct walker wl = {l, nl, 0, 0};

	if (n < 2)
		n = 2;
	b->n = 0;
	for (size_t i = 0; i < n; i++) {
		double t = (double)i / (double)(n - 1), xl, yl, xr, yr;
		struct pt2 c;
		int64_t w;
		walk_at(&wl, t * ll, &xl, &yl);
		nearest_on(r, nr, xl, yl, &xr, &yr);
		/* A sample on a sliver tip pairs with itself: not centred, skip. */
		if (hypot(xl - xr, yl - yr) < 1000 && n > 2)
			continue;
		c.x = (int64_t)llround(0.5 * (xl + xr));
		c.y = (int64_t)llround(0.5 * (yl + yr));
		w = (int64_t)(hypot(xl - xr, yl - yr) + 2 * d);
		{
			/* Near a strip's ends the pair spans the end wall: the
			 * clearance at the midpoint bounds the bead there. */
			struct pt2 q;
			if (tp_index_nearest(ix, c, w, &q) && 2 * tp_dist_nm(c, q) < (double)w)
				w = (int64_t)(2 * tp_dist_nm(c, q));
		}
		if (w > max_w)
			w = max_w;
		if (w < min_w)
			w = min_w;
		w -= w % WIDTH_STEP_NM;
		if (b->n && tp_dist_nm(c, b->pts[b->n - 1]) < MIN_STEP_NM && i + 1 < n) {
			if (w < b->w[b->n - 1])
				b->w[b->n - 1] = w;
			continue;
		}
		if (b->n)
			total += tp_dist_nm(c, b->pts[b->n - 1]);
		if (push(b, c, w))
			return ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
	}
	if (b->n < 2 || total < (double)min_w / 2)
		return 0;
	/* Segment widths: the narrower end; then drop vertices that neither
	 * bend the line (5 um) nor change the width. */
	for (size_t i = 0; i + 1 < b->n; i++)
		if (b->w[i + 1] < b->w[i])
			b->w[i] = b->w[i + 1];
	for (size_t i = 0; i < b->n; i++) {
		if (k >= 1 && i + 1 < b->n && b->w[i] == b->w[k - 1]) {
			struct pt2 a = b->pts[k - 1], c = b->pts[i + 1], q = b->pts[i];
			double ab = tp_dist_nm(a, c);
			double dev = ab > 0 ? fabs((double)(c.x - a.x) * (double)(q.y - a.y) -
						   (double)(c.y - a.y) * (double)(q.x - a.x)) / ab
					    : tp_dist_nm(a, q);
			if (dev < 5000)
				continue;
		}
		b->pts[k] = b->pts[i];
		b->w[k] = b->w[i];
		k++;
	}
	b->n = k;
	*added = 1;
	return tp_plan_add(items, role, 0, -1, b->w[0], b->pts, b->n, b->w, e);
}

/* Vertex farthest from p in path q. */
static size_t farthest(const struct path *q, struct pt2 p)
{
	size_t best = 0;
	double bd = -1;

	for (size_t i = 0; i < q->n; i++) {
		double d = tp_dist_nm(q->pts[i], p);
		if (d > bd) {
			bd = d;
			best = i;
		}
	}
	return best;
}

int tp_thin(const struct paths *pieces, enum tp_role role, int64_t min_w_nm, int64_t max_w_nm,
	    struct tp_plan *items, struct err *e)
{
	struct paths sliver;
	struct tp_index ix;
	struct thin_buf b;
	struct pt2 *chain = NULL;
	size_t chain_cap = 0;
	unsigned char *printed = NULL;
	/* Pieces below this area are offset noise (corner slivers of the
	 * mitred coverage), neither printed nor reported. */
	double noise_mm2 = 0.25 * geom_nm_to_mm(min_w_nm) * geom_nm_to_mm(min_w_nm);
	int rc;

	if (pieces->n == 0)
		return 0;
	paths_init(&sliver);
	memset(&b, 0, sizeof b);
	memset(&ix, 0, sizeof ix);
	rc = clip_offset(pieces, -SHRINK * (double)min_w_nm, CLIP_JOIN_MITER, 3.0, 0, &sliver, e);
	if (!rc)
		rc = tp_index_build(&ix, pieces, e);
	if (rc)
		goto out;
	printed = mem_calloc(pieces->n, 1);
	if (!printed) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
		goto out;
	}
	for (size_t i = 0; i < sliver.n; i++) {
		const struct path *o = &sliver.v[i];
		int ring = 0, added = 0;
		if (o->n < 3 || path_area2_nm2(o) <= 0)
			continue; /* holes are handled with their outer loop */
		for (size_t j = 0; j < sliver.n && !ring; j++)
			ring = j != i && sliver.v[j].n >= 3 && path_area2_nm2(&sliver.v[j]) < 0 &&
			       bbox_contains(o, sliver.v[j].pts[0]) &&
			       path_contains(o, sliver.v[j].pts[0]);
		if (ring) {
			rc = emit_chain(&ix, o->pts, o->n, 1, role, min_w_nm, max_w_nm, &b, items, e,
					&added);
		} else {
			/* Sides a -> z and (reversed) z -> a of the sliver. */
			size_t a = farthest(o, o->pts[0]), z = farthest(o, o->pts[a]), m = 0, ml;
			void *arr = chain;
			if (mem_grow(&arr, &chain_cap, 2 * o->n + 2, sizeof *chain)) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
				goto out;
			}
			chain = arr;
			for (size_t k = a;; k = (k + 1) % o->n) {
				chain[m++] = o->pts[k];
				if (k == z)
					break;
			}
			ml = m;
			for (size_t k = a;; k = (k + o->n - 1) % o->n) {
				chain[m++] = o->pts[k];
				if (k == z)
					break;
			}
			rc = emit_strip(&ix, chain, ml, chain + ml, m - ml, SHRINK * (double)min_w_nm, role,
					min_w_nm, max_w_nm, &b, items, e, &added);
		}
		if (rc)
			goto out;
		/* Credit the piece this sliver came from. */
		for (size_t k = 0; added && k < pieces->n; k++) {
			const struct path *pc = &pieces->v[k];
			if (pc->n >= 3 && path_area2_nm2(pc) > 0 && bbox_contains(pc, o->pts[0]) &&
			    path_contains(pc, o->pts[0])) {
				if (!printed[k])
					items->thin_regions++;
				printed[k] = 1;
				break;
			}
		}
	}
	for (size_t k = 0; k < pieces->n; k++) {
		double a = path_area_mm2(&pieces->v[k]);
		if (!printed[k] && a >= noise_mm2) {
			items->thin_dropped++;
			items->thin_dropped_mm2 += a;
		}
	}
out:
	mem_free(printed);
	mem_free(chain);
	mem_free(b.pts);
	mem_free(b.w);
	tp_index_fini(&ix);
	paths_fini(&sliver);
	return rc;
}
