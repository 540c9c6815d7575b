/* toolpath_thin.c - centrelines with local bead widths for material
 * narrower than a line width: thin walls and the gaps perimeters leave
 * (tp_thin() in toolpath_int.h; docs/gcode.md, "thin walls").
 *
 * A piece P (a thin strip, ring or blob of the region) is shrunk by d, a
 * little under half the narrowest printable width: what survives is a
 * sliver hugging P's medial axis wherever P is at least 2d wide.  A
 * sliver around an open strip is cut at its two mutually farthest
 * vertices and the shorter side kept (at branches this skips a branch
 * rather than printing it twice); a sliver with a hole (a ring-shaped
 * wall) keeps its outer loop, closed.  Every vertex is then moved to the
 * middle of the chord through it that joins the nearest wall point to
 * the opposite wall, and that chord's length is the bead width there.
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

static double arc_len(const struct path *q, size_t i, size_t j)
{
	double l = 0;

	for (size_t k = i; k != j; k = (k + 1) % q->n)
		l += tp_dist_nm(q->pts[k], q->pts[(k + 1) % q->n]);
	return l;
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
	rc = clip_offset(pieces, -0.45 * (double)min_w_nm, CLIP_JOIN_MITER, 3.0, 0, &sliver, e);
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
			size_t a = farthest(o, o->pts[0]), z = farthest(o, o->pts[a]), m = 0;
			size_t from = a, to = z;
			void *arr = chain;
			if (arc_len(o, z, a) < arc_len(o, a, z)) {
				from = z;
				to = a;
			}
			if (mem_grow(&arr, &chain_cap, o->n + 1, sizeof *chain)) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory planning thin walls");
				goto out;
			}
			chain = arr;
			for (size_t k = from;; k = (k + 1) % o->n) {
				chain[m++] = o->pts[k];
				if (k == to)
					break;
			}
			rc = emit_chain(&ix, chain, m, 0, role, min_w_nm, max_w_nm, &b, items, e,
					&added);
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
