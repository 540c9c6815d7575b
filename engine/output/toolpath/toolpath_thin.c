/* toolpath_thin.c - centrelines with local bead widths for material
 * narrower than a line width: thin walls and the gaps perimeters leave
 * (tp_thin() in toolpath_int.h; docs/gcode.md, "thin walls").
 *
 * A piece P (a thin strip, ring or blob of the region) is shrunk by d, a
 * little under half the narrowest printable width: what survives is a
 * sliver hugging P's medial axis wherever P is at least 2d wide.  A
 * sliver around an open strip is cut at its two ends (where its outline
 * turns back: strip_ends()) into two sides; points sampled along one side are paired
 * with their nearest points on the other, and the midpoints of the pairs
 * form the centreline, their distance plus 2d the local width (the two
 * walls of a strip run side by side, so this pairs each wall point with
 * the one across).  A
 * sliver with a hole (a ring-shaped wall) keeps its outer loop, closed,
 * and each vertex moves to the middle of the chord through it that joins
 * the nearest wall point to the opposite wall, the chord's length being
 * the width there.
 */
#include "engine/output/toolpath/toolpath_int.h"
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

/* Append the polyline b (closed: a loop; b->w[k] the width of segment k)
 * as paths whose beads lie inside the pieces indexed in ix: segment k of
 * width w must start inside, cross no outline and keep w/2 from every
 * outline.  A segment nearer than that is narrowed to twice its
 * clearance (in WIDTH_STEP_NM steps); one that would become narrower than
 * min_w is left out, splitting the line.  Runs shorter than min_w / 2 are
 * dropped.  This check, not the centring heuristics, is what the
 * containment guarantee rests on (docs/gcode.md). */
static int emit_valid(struct tp_index *ix, struct thin_buf *b, int closed, enum tp_role role,
		      int64_t min_w, struct tp_plan *items, struct err *e, int *added)
{
	size_t n = b->n, nseg = closed ? n : n - 1, bad = SIZE_MAX, m = 0;
	struct pt2 *rp;
	int64_t *rw;
	double len = 0;
	int rc = 0;

	if (n < 2)
		return 0;
	for (size_t k = 0; k < nseg; k++) {
		struct pt2 a = b->pts[k], c = b->pts[(k + 1) % n];
		int64_t w = b->w[k];
		double cl;
		if (!tp_index_inside(ix, a) || tp_index_crosses(ix, a, c)) {
			w = -1;
		} else {
			cl = tp_index_seg_clearance(ix, a, c, 0.5 * (double)w);
			if (cl < 0.5 * (double)w) {
				w = (int64_t)(2 * cl);
				w -= w % WIDTH_STEP_NM;
			}
			if (w < min_w)
				w = -1;
		}
		b->w[k] = w;
		if (w < 0 && bad == SIZE_MAX)
			bad = k;
	}
	if (bad == SIZE_MAX) {
		for (size_t k = 0; k < nseg; k++)
			len += tp_dist_nm(b->pts[k], b->pts[(k + 1) % n]);
		if (len < (double)min_w / 2 || (closed && n < 3))
			return 0;
		*added = 1;
		return tp_plan_add(items, role, closed, -1, b->w[0], b->pts, n, b->w, e);
	}
	rp = mem_alloc((n + 1) * sizeof *rp);
	rw = mem_alloc((n + 1) * sizeof *rw);
	if (!rp || !rw) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
		goto out;
	}
	/* Runs of good segments; a loop is walked from its first bad one. */
	for (size_t t = 0, k0 = closed ? bad + 1 : 0; !rc && t <= nseg; t++) {
		size_t k = (k0 + t) % (closed ? nseg : nseg + 1);
		int good = t < nseg && (closed || k < nseg) && b->w[k] >= 0;
		if (good) {
			if (m == 0)
				rp[m++] = b->pts[k];
			rw[m - 1] = b->w[k];
			rp[m++] = b->pts[(k + 1) % n];
			len += tp_dist_nm(rp[m - 2], rp[m - 1]);
			continue;
		}
		if (m >= 2 && len >= (double)min_w / 2) {
			*added = 1;
			rc = tp_plan_add(items, role, 0, -1, rw[0], rp, m, rw, e);
		}
		m = 0;
		len = 0;
	}
out:
	mem_free(rp);
	mem_free(rw);
	return rc;
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

/* One side of a sliver: a polyline (a closed side repeats its first
 * point at the end). */
struct side {
	const struct pt2 *p;
	size_t n;
};

/* Centreline of a sliver from its side l and the opposite sides r[0..nr)
 * (a strip: l and r run from the same end to the other; a ring: l is the
 * outer loop, closed, and r its holes), d = the shrink distance.  Samples
 * every STRIP_STEP_NM along l pair with their nearest point on r: the
 * midpoint is the centre, the distance plus 2d the width. */
static int emit_paired(struct tp_index *ix, struct side l, int closed, const struct side *r,
		       size_t nr, double d, enum tp_role role, int64_t min_w, int64_t max_w,
		       struct thin_buf *b, struct tp_plan *items, struct err *e, int *added)
{
	double ll = poly_len(l.p, l.n), total = 0;
	size_t n = (size_t)ceil(ll / STRIP_STEP_NM) + (closed ? 0 : 1), k = 0;
	struct walker wl = {l.p, l.n, 0, 0};

	if (n < 2)
		n = 2;
	b->n = 0;
	for (size_t i = 0; i < n; i++) {
		double t = closed ? (double)i / (double)n : (double)i / (double)(n - 1);
		double xl, yl, xr = 0, yr = 0, best = INFINITY;
		struct pt2 c;
		int64_t w;
		walk_at(&wl, t * ll, &xl, &yl);
		for (size_t j = 0; j < nr; j++) {
			double qx, qy;
			nearest_on(r[j].p, r[j].n, xl, yl, &qx, &qy);
			if (hypot(qx - xl, qy - yl) < best) {
				best = hypot(qx - xl, qy - yl);
				xr = qx;
				yr = qy;
			}
		}
		/* A sample on a sliver tip pairs with itself: not centred, skip. */
		if (best < 1000 && n > 2)
			continue;
		c.x = (int64_t)llround(0.5 * (xl + xr));
		c.y = (int64_t)llround(0.5 * (yl + yr));
		w = (int64_t)(best + 2 * d);
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
		if (b->n && tp_dist_nm(c, b->pts[b->n - 1]) < MIN_STEP_NM && (closed || i + 1 < n)) {
			if (w < b->w[b->n - 1])
				b->w[b->n - 1] = w;
			continue;
		}
		if (b->n)
			total += tp_dist_nm(c, b->pts[b->n - 1]);
		if (push(b, c, w))
			return ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
	}
	if (closed && b->n > 2 && tp_dist_nm(b->pts[0], b->pts[b->n - 1]) < MIN_STEP_NM)
		b->n--;
	if (b->n < 2 || (closed && b->n < 3) || total < (double)min_w / 2)
		return 0;
	/* Segment widths: the narrower end; then drop vertices that neither
	 * bend the line (5 um) nor change the width. */
	for (size_t i = 0; i < b->n; i++) {
		int64_t w2 = closed || i + 1 < b->n ? b->w[(i + 1) % b->n] : b->w[i];
		if (w2 < b->w[i])
			b->w[i] = w2;
	}
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
	return emit_valid(ix, b, closed, role, min_w, items, e, added);
}

/* Point at arc length t (mod the perimeter) along closed path q, whose
 * vertex i sits at arc length at[i] (at[q->n] = perimeter). */
static struct pt2 point_at(const struct path *q, const double *at, double t)
{
	size_t lo = 0, hi = q->n;
	double per = at[q->n], f;
	struct pt2 a, b;

	t = fmod(t, per);
	if (t < 0)
		t += per;
	while (hi - lo > 1) { /* at[lo] <= t < at[hi] */
		size_t mid = (lo + hi) / 2;
		if (at[mid] <= t)
			lo = mid;
		else
			hi = mid;
	}
	a = q->pts[lo];
	b = q->pts[(lo + 1) % q->n];
	f = at[lo + 1] > at[lo] ? (t - at[lo]) / (at[lo + 1] - at[lo]) : 0;
	return (struct pt2){a.x + (int64_t)llround(f * (double)(b.x - a.x)),
			    a.y + (int64_t)llround(f * (double)(b.y - a.y))};
}

/* The two ends of the strip sliver q: where its outline turns back.  Near
 * an end, the outline points an arc length d before and after a vertex
 * lie on the two sides at the same distance from the end, so their
 * centres (centre()) coincide; elsewhere they lie d apart along the
 * centreline.  The first end is the vertex where the two centres are
 * closest, the second the same among vertices at least a quarter of the
 * perimeter away (each side of a strip is half of it).  Unlike the two
 * mutually farthest vertices, this finds the ends of bent strips (a U
 * has its far corners farther apart than its ends).  O(n log n). */
static int strip_ends(struct tp_index *ix, const struct path *q, int64_t max_w, size_t *a,
		      size_t *z)
{
	double *at = mem_alloc((q->n + 1) * sizeof *at), *dm, per, d, best = INFINITY;

	if (!at)
		return ERR_NOMEM;
	dm = mem_alloc(q->n * sizeof *dm);
	if (!dm) {
		mem_free(at);
		return ERR_NOMEM;
	}
	at[0] = 0;
	for (size_t i = 0; i < q->n; i++)
		at[i + 1] = at[i] + tp_dist_nm(q->pts[i], q->pts[(i + 1) % q->n]);
	per = at[q->n];
	d = per / 8 < (double)max_w ? per / 8 : (double)max_w;
	*a = *z = 0;
	for (size_t i = 0; i < q->n; i++) {
		struct pt2 c1, c2;
		int64_t w;
		centre(ix, point_at(q, at, at[i] - d), max_w, &c1, &w);
		centre(ix, point_at(q, at, at[i] + d), max_w, &c2, &w);
		dm[i] = tp_dist_nm(c1, c2);
		if (dm[i] < best) {
			best = dm[i];
			*a = i;
		}
	}
	best = INFINITY;
	for (size_t i = 0; i < q->n; i++) {
		double gap = fabs(at[i] - at[*a]);
		if (gap > per / 2)
			gap = per - gap;
		if (gap >= per / 4 && dm[i] < best) {
			best = dm[i];
			*z = i;
		}
	}
	if (*z == *a)
		*z = (*a + q->n / 2) % q->n;
	mem_free(at);
	mem_free(dm);
	return 0;
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
	size_t *owner = NULL, *pown = NULL, sides_cap = 0;
	struct path_measure *pm = NULL; /* the pieces' */
	double *holes_mm2 = NULL;       /* per outer piece: its holes' summed area (<= 0) */
	struct side *sides = NULL;
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
	owner = mem_alloc((sliver.n ? sliver.n : 1) * sizeof *owner);
	pm = mem_alloc(pieces->n * sizeof *pm);
	holes_mm2 = mem_calloc(pieces->n, sizeof *holes_mm2);
	pown = mem_alloc(pieces->n * sizeof *pown);
	if (pm)
		paths_measure(pieces, pm);
	if (!printed || !owner || !pm || !holes_mm2 || !pown ||
	    paths_hole_owners(&sliver, NULL, owner) || paths_hole_owners(pieces, pm, pown)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
		goto out;
	}
	for (size_t i = 0; i < sliver.n; i++) {
		const struct path *o = &sliver.v[i];
		int added = 0;
		size_t nh = 0, np = o->n + 1;
		if (o->n < 3 || path_area2_nm2(o) <= 0)
			continue; /* holes are handled with their outer loop */
		/* Its holes (a ring-shaped sliver): those whose smallest outer
		 * loop it is (owner[], paths_hole_owners). */
		for (size_t j = 0; j < sliver.n; j++) {
			if (owner[j] == i) {
				nh++;
				np += sliver.v[j].n + 1;
			}
		}
		{
			void *arr = chain;
			int bad = mem_grow(&arr, &chain_cap, 2 * np + 2, sizeof *chain);
			chain = arr;
			arr = sides;
			bad = bad || mem_grow(&arr, &sides_cap, nh + 1, sizeof *sides);
			sides = arr;
			if (bad) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
				goto out;
			}
		}
		if (nh) {
			/* A ring: its outer loop paired with its holes, closed. */
			struct side outer = {chain, o->n + 1};
			size_t m = 0, ns = 0;
			for (size_t k = 0; k <= o->n; k++)
				chain[m++] = o->pts[k % o->n];
			for (size_t j = 0; j < sliver.n; j++) {
				const struct path *h = &sliver.v[j];
				if (owner[j] != i)
					continue;
				sides[ns++] = (struct side){chain + m, h->n + 1};
				for (size_t k = 0; k <= h->n; k++)
					chain[m++] = h->pts[k % h->n];
			}
			rc = emit_paired(&ix, outer, 1, sides, ns, SHRINK * (double)min_w_nm, role,
					 min_w_nm, max_w_nm, &b, items, e, &added);
		} else {
			/* A strip: sides a -> z and (reversed) z -> a. */
			size_t a, z, m = 0, ml;
			if (strip_ends(&ix, o, max_w_nm, &a, &z)) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
				goto out;
			}
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
			sides[0] = (struct side){chain + ml, m - ml};
			rc = emit_paired(&ix, (struct side){chain, ml}, 0, sides, 1,
					 SHRINK * (double)min_w_nm, role, min_w_nm, max_w_nm, &b, items, e,
					 &added);
		}
		if (rc)
			goto out;
		/* Credit the piece this sliver came from. */
		for (size_t k = 0; added && k < pieces->n; k++) {
			if (pm[k].area2_nm2 > 0 && path_holds(&pieces->v[k], &pm[k], o->pts[0])) {
				if (!printed[k])
					items->thin_regions++;
				printed[k] = 1;
				break;
			}
		}
	}
	/* Unprinted pieces: their area less their holes' (each hole counted
	 * with its smallest outer loop). */
	for (size_t j = 0; j < pieces->n; j++)
		if (pown[j] != SIZE_MAX)
			holes_mm2[pown[j]] += path_measure_mm2(&pm[j]);
	for (size_t k = 0; k < pieces->n; k++) {
		double a = path_measure_mm2(&pm[k]) + holes_mm2[k];
		if (printed[k] || path_measure_mm2(&pm[k]) < noise_mm2)
			continue;
		items->thin_dropped++;
		items->thin_dropped_mm2 += a > 0 ? a : 0;
	}
out:
	mem_free(printed);
	mem_free(owner);
	mem_free(pm);
	mem_free(holes_mm2);
	mem_free(pown);
	mem_free(sides);
	mem_free(chain);
	mem_free(b.pts);
	mem_free(b.w);
	tp_index_fini(&ix);
	paths_fini(&sliver);
	return rc;
}
