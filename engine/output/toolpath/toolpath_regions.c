/* toolpath_regions.c - what a layer's material becomes: perimeter loops,
 * thin walls and gap fill, skins and sparse infill areas, and the skirt
 * (tp_regions() in toolpath_int.h; docs/gcode.md, "perimeters" and
 * "skins").
 *
 * Offsets follow Slic3r/PrusaSlicer: the external loop's centreline lies
 * w/2 inside the outline (its bead edge touches it), each further loop
 * one bead spacing s = w - h (1 - pi/4) further in, and the fill area
 * starts s/2 inside the innermost loop.  Inward offsets use mitred joins
 * (limit 3): the offset of a region by -d keeps every point at least d
 * from its outline whatever the join, and mitres keep corners sharp.
 */
#include "engine/output/toolpath/toolpath_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Coverage regions are grown by this much more before they are
 * subtracted: the difference of two nearly coincident outlines is a cloud
 * of slivers (and Clipper's slowest case); real gaps lose 10 um. */
#define COVER_EPS_NM 10000.0

/* Islands that an inward offset by d removes entirely: those whose
 * bounding box is at most 2d across (the offset of a shape lies inside
 * its bounding box shrunk by d).  Clipper builds the offset of a polygon
 * shrunk past its inradius from self-crossing raw edges, O(n^2) crossings
 * per polygon, so removing them first matters for layers of many small
 * islands (lattice struts).  Each hole goes with the smallest outer loop
 * around it (paths_hole_owners).  m, mark and owner: scratch of in->n
 * entries.  kept receives shallow copies (no ownership); returns the
 * number of paths dropped, or (size_t)-1 when out of memory. */
static size_t prune_vanishing(const struct paths *in, double d, struct paths *kept,
			      struct path_measure *m, unsigned char *mark, size_t *owner)
{
	size_t dropped = 0;

	paths_measure(in, m);
	if (paths_hole_owners(in, m, owner))
		return (size_t)-1;
	for (size_t i = 0; i < in->n; i++)
		mark[i] = m[i].area2_nm2 > 0 && ((double)(m[i].hi.x - m[i].lo.x) <= 2 * d ||
						 (double)(m[i].hi.y - m[i].lo.y) <= 2 * d);
	for (size_t i = 0; i < in->n; i++)
		if (owner[i] != SIZE_MAX) /* a hole: as its outer loop */
			mark[i] = mark[owner[i]];
	kept->n = 0;
	for (size_t i = 0; i < in->n; i++) {
		if (mark[i])
			dropped++;
		else
			kept->v[kept->n++] = in->v[i];
	}
	return dropped;
}

static int offset(const struct paths *in, double delta_nm, struct paths *out, struct err *e)
{
	struct paths kept;
	struct path_measure *m;
	unsigned char *mark;
	size_t *owner;
	int rc;

	if (in->n == 0) {
		paths_clear(out);
		return 0;
	}
	if (delta_nm >= 0)
		return clip_offset(in, delta_nm, CLIP_JOIN_MITER, 3.0, 0, out, e);
	kept.v = mem_alloc(in->n * sizeof *kept.v);
	m = mem_alloc(in->n * sizeof *m);
	mark = mem_alloc(in->n);
	owner = mem_alloc(in->n * sizeof *owner);
	if (!kept.v || !m || !mark || !owner ||
	    prune_vanishing(in, -delta_nm, &kept, m, mark, owner) == (size_t)-1) {
		mem_free(kept.v);
		mem_free(m);
		mem_free(mark);
		mem_free(owner);
		return ERR_SET(e, ERR_NOMEM, "out of memory offsetting a region");
	}
	kept.cap = in->n;
	if (kept.n == 0) {
		paths_clear(out);
		rc = 0;
	} else {
		rc = clip_offset(&kept, delta_nm, CLIP_JOIN_MITER, 3.0, 0, out, e);
	}
	mem_free(kept.v);
	mem_free(m);
	mem_free(mark);
	mem_free(owner);
	return rc;
}

static int add_loops(struct tp_plan *items, const struct paths *ps, int depth, int64_t w,
		     struct err *e)
{
	enum tp_role role = depth == 0 ? TP_ROLE_EXT_PERIMETER : TP_ROLE_PERIMETER;

	for (size_t i = 0; i < ps->n; i++) {
		int rc;
		if (ps->v[i].n < 3)
			continue;
		rc = tp_plan_add(items, role, 1, depth, w, ps->v[i].pts, ps->v[i].n, NULL, e);
		if (rc)
			return rc;
	}
	return 0;
}

/* Same outline, vertex for vertex (prismatic parts repeat their region). */
static int same_region(const struct paths *a, const struct paths *b)
{
	if (a == b)
		return 1;
	if (a->n != b->n)
		return 0;
	for (size_t i = 0; i < a->n; i++)
		if (a->v[i].n != b->v[i].n ||
		    memcmp(a->v[i].pts, b->v[i].pts, a->v[i].n * sizeof *a->v[i].pts) != 0)
			return 0;
	return 1;
}

int tp_exposure(const struct paths *r, const struct paths *other, struct paths *out,
		struct err *e)
{
	if (!other)
		return paths_copy(out, r) ? ERR_SET(e, ERR_NOMEM, "out of memory computing skins")
					  : 0;
	if (same_region(r, other)) {
		paths_clear(out);
		return 0;
	}
	return clip_boolean(CLIP_DIFFERENCE, r, other, CLIP_FILL_NONZERO, out, e);
}

/* Whether exposure loop q can meet fill area F (indexed in fx): an edge
 * of q crossing F's outline, q inside F, or F inside q (touching without
 * crossing counts as not meeting: no area in common).  Holes
 * are always kept: a hole whose outer loop is dropped encloses only area
 * outside F, so reading it as filled adds nothing to F's skin. */
static int meets(struct tp_index *fx, const struct paths *F, const struct path *q)
{
	struct paths one = {(struct path *)q, 1, 1};

	if (q->n < 3)
		return 0;
	if (path_area2_nm2(q) < 0)
		return 1;
	/* Without a crossing, q's outline lies wholly inside or wholly outside
	 * F: one vertex tells which. */
	for (size_t i = 0; i < q->n; i++)
		if (tp_index_crosses(fx, q->pts[i], q->pts[(i + 1) % q->n]))
			return 1;
	if (tp_index_inside(fx, q->pts[0]))
		return 1;
	for (size_t i = 0; i < F->n; i++)
		if (F->v[i].n && paths_winding(&one, F->v[i].pts[0]))
			return 1;
	return 0;
}

/* Skin of fill area F: F within some exposure of the window.  Every
 * point p of this layer k that some layer k+1..k+T misses lies in the
 * exposure top[j] of the last layer k+j (j < T) that still holds it, and
 * conversely; the same below.  A window cut short by the part's last
 * (first) layer misses nothing: that layer's exposure is all of it.
 * Exposures are mostly narrow strips along sloped walls, inside the
 * perimeters and far from F: loops that cannot meet F are left out
 * before one Clipper call against the union of the rest. */
static int skin_of(const struct tp_config *c, const struct tp_layer_in *in, const struct paths *F,
		   struct paths *skin, struct err *e)
{
	struct paths exp;
	struct tp_index fx;
	size_t total = 0;
	int rc = 0, outer = 0;

	paths_clear(skin);
	if (F->n == 0)
		return 0;
	/* A window cut short by the part's top or bottom: every point either
	 * leaves within it or lasts to that last layer, whose exposure is
	 * all of it; so all of F is skin. */
	if (in->ntop < c->top_layers || in->nbottom < c->bottom_layers)
		return paths_copy(skin, F) ? ERR_SET(e, ERR_NOMEM, "out of memory computing skins")
					   : 0;
	for (int j = 0; j < c->top_layers && j < in->ntop; j++)
		total += in->top[j]->n;
	for (int j = 0; j < c->bottom_layers && j < in->nbottom; j++)
		total += in->bottom[j]->n;
	if (total == 0)
		return 0;
	rc = tp_index_build(&fx, F, e);
	if (rc)
		return rc;
	/* a shallow concatenation: the paths stay owned by the window */
	exp.v = mem_alloc(total * sizeof *exp.v);
	if (!exp.v) {
		tp_index_fini(&fx);
		return ERR_SET(e, ERR_NOMEM, "out of memory computing skins");
	}
	exp.cap = total;
	exp.n = 0;
	for (int j = 0; j < c->top_layers + c->bottom_layers; j++) {
		const struct paths *x = j < c->top_layers
						? (j < in->ntop ? in->top[j] : NULL)
						: (j - c->top_layers < in->nbottom ? in->bottom[j - c->top_layers]
										   : NULL);
		for (size_t i = 0; x && i < x->n; i++) {
			if (!meets(&fx, F, &x->v[i]))
				continue;
			exp.v[exp.n++] = x->v[i];
			outer |= path_area2_nm2(&x->v[i]) > 0;
		}
	}
	if (outer)
		rc = clip_boolean(CLIP_INTERSECTION, F, &exp, CLIP_FILL_NONZERO, skin, e);
	mem_free(exp.v);
	tp_index_fini(&fx);
	return rc;
}

/* Keep the pieces (outer loop with its holes) of a normalised region whose
 * outer loop encloses at least min_mm2; drops slivers at sloped walls
 * that are too small to hold solid lines.  Each hole goes with the
 * smallest outer loop containing it (paths_hole_owners). */
static int drop_small(struct paths *ps, double min_mm2, struct err *e)
{
	struct path_measure *m;
	unsigned char *keep;
	size_t *owner;
	size_t k = 0;

	if (ps->n == 0)
		return 0;
	m = mem_alloc(ps->n * sizeof *m);
	keep = mem_calloc(ps->n, 1);
	owner = mem_alloc(ps->n * sizeof *owner);
	if (m)
		paths_measure(ps, m);
	if (!m || !keep || !owner || paths_hole_owners(ps, m, owner)) {
		mem_free(m);
		mem_free(keep);
		mem_free(owner);
		return ERR_SET(e, ERR_NOMEM, "out of memory computing skins");
	}
	for (size_t i = 0; i < ps->n; i++)
		keep[i] = path_measure_mm2(&m[i]) >= min_mm2;
	for (size_t i = 0; i < ps->n; i++)
		if (owner[i] != SIZE_MAX)
			keep[i] = keep[owner[i]];
	for (size_t i = 0; i < ps->n; i++) {
		if (keep[i])
			ps->v[k++] = ps->v[i];
		else
			path_fini(&ps->v[i]);
	}
	ps->n = k;
	mem_free(m);
	mem_free(keep);
	mem_free(owner);
	return 0;
}

/* Convex hull of all points of ps (monotone chain), CCW, into out. */
static int cmp_pt(const void *pa, const void *pb)
{
	const struct pt2 *a = pa, *b = pb;

	if (a->x != b->x)
		return a->x < b->x ? -1 : 1;
	return (a->y > b->y) - (a->y < b->y);
}

static __int128 cross3(struct pt2 o, struct pt2 a, struct pt2 b)
{
	return (__int128)(a.x - o.x) * (b.y - o.y) - (__int128)(a.y - o.y) * (b.x - o.x);
}

static int hull(const struct paths *ps, struct path *out, struct err *e)
{
	size_t n = paths_point_count(ps), k = 0, m = 0;
	struct pt2 *p = mem_alloc((n ? n : 1) * sizeof *p), *h;

	h = mem_alloc((2 * n + 1) * sizeof *h);
	if (!p || !h) {
		mem_free(p);
		mem_free(h);
		return ERR_SET(e, ERR_NOMEM, "out of memory planning the skirt");
	}
	for (size_t i = 0; i < ps->n; i++)
		for (size_t j = 0; j < ps->v[i].n; j++)
			p[m++] = ps->v[i].pts[j];
	qsort(p, m, sizeof *p, cmp_pt);
	for (size_t i = 0; i < m; i++) {
		while (k >= 2 && cross3(h[k - 2], h[k - 1], p[i]) <= 0)
			k--;
		h[k++] = p[i];
	}
	for (size_t i = m - 1, t = k + 1; i-- > 0;) {
		while (k >= t && cross3(h[k - 2], h[k - 1], p[i]) <= 0)
			k--;
		h[k++] = p[i];
	}
	mem_free(p);
	out->pts = h;
	out->n = k > 1 ? k - 1 : k;
	out->cap = 2 * n + 1;
	return 0;
}

/* Skirt loops around the convex hull of the first layer.  Skipped when
 * they would leave the bed. */
static int skirt(const struct tp_config *c, const struct tp_layer_in *in, struct tp_plan *items,
		 struct err *e)
{
	struct paths hp, loop;
	int64_t s = tp_spacing_nm(c->width_nm, in->height_mm);
	int rc;

	paths_init(&hp);
	paths_init(&loop);
	if (!paths_add(&hp)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory planning the skirt");
		goto out;
	}
	rc = hull(in->region, &hp.v[0], e);
	if (rc || hp.v[0].n < 3)
		goto out;
	for (int i = 0; i < c->skirt_loops; i++) {
		struct pt2 lo, hi;
		double d = (double)c->skirt_distance_nm + 0.5 * (double)c->width_nm +
			   (double)i * (double)s;
		rc = clip_offset(&hp, d, CLIP_JOIN_ROUND, 0, 5000, &loop, e);
		if (rc)
			goto out;
		if (loop.n != 1 || !paths_bbox(&loop, &lo, &hi) || lo.x < c->bed_lo.x ||
		    lo.y < c->bed_lo.y || hi.x > c->bed_hi.x || hi.y > c->bed_hi.y)
			break;
		rc = tp_plan_add(items, TP_ROLE_SKIRT, 1, -2, c->width_nm, loop.v[0].pts,
				 loop.v[0].n, NULL, e);
		if (rc)
			goto out;
	}
out:
	paths_fini(&hp);
	paths_fini(&loop);
	return rc;
}

/* Split the skin into top (exposed upwards), bridge (over air, not on
 * the bed) and plain solid areas; narrow parts become gap fill. */
static int classify_skin(const struct tp_config *c, const struct tp_layer_in *in,
			 struct paths *skin, int64_t s, struct tp_plan *items, struct tp_areas *ar,
			 struct err *e)
{
	struct paths open, narrow, rest;
	const struct paths *up = in->ntop > 0 ? in->top[0] : NULL;
	const struct paths *down = in->index > 0 && in->nbottom > 0 ? in->bottom[0] : NULL;
	int rc;

	paths_init(&open);
	paths_init(&narrow);
	paths_init(&rest);
	/* Opening by s/2: parts too narrow for a solid line go to gap fill. */
	rc = offset(skin, -0.5 * (double)s, &narrow, e);
	if (!rc)
		rc = offset(&narrow, 0.5 * (double)s + COVER_EPS_NM, &open, e);
	if (!rc)
		rc = clip_boolean(CLIP_DIFFERENCE, skin, &open, CLIP_FILL_NONZERO, &narrow, e);
	if (!rc)
		rc = tp_thin(&narrow, TP_ROLE_GAP_FILL, geom_mm_to_nm(in->height_mm), 2 * c->nozzle_nm,
			     items, e);
	if (rc || open.n == 0)
		goto out;
	if (up && up->n) {
		rc = clip_boolean(CLIP_INTERSECTION, &open, up, CLIP_FILL_NONZERO,
				  &ar->fill[TP_ROLE_TOP], e);
		if (!rc)
			rc = clip_boolean(CLIP_DIFFERENCE, &open, up, CLIP_FILL_NONZERO, &rest, e);
	} else {
		rc = paths_copy(&rest, &open) ? ERR_NOMEM : 0;
	}
	if (rc || rest.n == 0)
		goto out;
	if (down && down->n) {
		rc = clip_boolean(CLIP_INTERSECTION, &rest, down, CLIP_FILL_NONZERO,
				  &ar->fill[TP_ROLE_BRIDGE], e);
		if (!rc)
			rc = clip_boolean(CLIP_DIFFERENCE, &rest, down, CLIP_FILL_NONZERO,
					  &ar->fill[TP_ROLE_SOLID], e);
	} else {
		rc = paths_append_move(&ar->fill[TP_ROLE_SOLID], &rest);
	}
out:
	if (rc == ERR_NOMEM)
		rc = ERR_SET(e, ERR_NOMEM, "out of memory classifying skins");
	paths_fini(&open);
	paths_fini(&narrow);
	paths_fini(&rest);
	return rc;
}

int tp_regions(const struct tp_config *c, const struct tp_layer_in *in, struct tp_plan *items,
	       struct tp_areas *ar, struct err *e)
{
	struct paths prev, cur, a, b, gap, E, F, skin;
	int64_t w = c->width_nm, s = tp_spacing_nm(w, in->height_mm);
	int64_t thin_min = geom_mm_to_nm(in->height_mm);
	/* Widest single bead for thin walls and gaps: twice the nozzle. */
	int64_t thin_max = 2 * c->nozzle_nm;
	int rc;

	if (in->region->n == 0)
		return 0;
	paths_init(&prev);
	paths_init(&cur);
	paths_init(&a);
	paths_init(&b);
	paths_init(&gap);
	paths_init(&E);
	paths_init(&F);
	paths_init(&skin);
	rc = in->index == 0 && c->skirt_loops > 0 ? skirt(c, in, items, e) : 0;
	/* External loop: centreline w/2 inside, where the region is at least
	 * w + s wide: D = R eroded by w/2 (where a centreline may run),
	 * E = D eroded by s/2, the loop region C0 = E grown by s/2, clipped
	 * to D (Slic3r's offset2: parts too narrow for a loop that does not
	 * fold onto itself drop out).  The clip is needed: a mitred growth is
	 * not contained in the true (round) one.  At a convex corner of E
	 * with angle t its spike reaches (s/2) / sin(t/2) (up to 3 s/2, the
	 * mitre limit) from E; that is still w/2 from the outline when both
	 * edges at the corner are offsets of outline edges, but not at the
	 * corners of join segments and short edges that erosion leaves near
	 * notches (measured on real meshes: 0.05 mm from the outline).  What
	 * the loop's bead cannot reach, R minus E grown by w/2 + s/2, is
	 * thinner than w + s: thin walls, printed as single variable-width
	 * lines.  Inner loops need no clip: their E lies w/2 + 3s/2 inside
	 * the outline, and a spike reaches at most 3s/2 out of it. */
	if (!rc)
		rc = offset(in->region, -0.5 * (double)w, &b, e);
	if (!rc)
		rc = offset(&b, -0.5 * (double)s, &E, e);
	if (!rc)
		rc = offset(&E, 0.5 * (double)s, &a, e);
	if (!rc)
		rc = clip_boolean(CLIP_INTERSECTION, &a, &b, CLIP_FILL_NONZERO, &prev, e);
	if (!rc)
		rc = offset(&E, 0.5 * (double)(w + s) + COVER_EPS_NM, &a, e);
	if (!rc)
		rc = clip_boolean(CLIP_DIFFERENCE, in->region, &a, CLIP_FILL_NONZERO, &gap, e);
	if (!rc)
		rc = tp_thin(&gap, TP_ROLE_EXT_PERIMETER, thin_min, thin_max, items, e);
	if (!rc)
		rc = add_loops(items, &prev, 0, w, e);
	for (int k = 1; !rc && k < c->perimeters && prev.n; k++) {
		/* Loop k one spacing further in: a = the previous loop region
		 * eroded by s/2 (its bead's inner edge), E = a eroded by s, loop
		 * region C = E grown by s/2.  The parts of a narrower than 2s,
		 * a minus E grown by s, are the gaps neither bead covers. */
		rc = offset(&prev, -0.5 * (double)s, &a, e);
		if (!rc)
			rc = offset(&a, -(double)s, &E, e);
		if (!rc)
			rc = offset(&E, 0.5 * (double)s, &cur, e);
		if (!rc)
			rc = offset(&E, (double)s + COVER_EPS_NM, &b, e);
		if (!rc)
			rc = clip_boolean(CLIP_DIFFERENCE, &a, &b, CLIP_FILL_NONZERO, &gap, e);
		if (!rc)
			rc = tp_thin(&gap, TP_ROLE_GAP_FILL, thin_min, thin_max, items, e);
		if (!rc)
			rc = add_loops(items, &cur, k, w, e);
		if (!rc) {
			struct paths t = prev;
			prev = cur;
			cur = t;
		}
	}
	/* Fill area: the last E, s/2 inside the innermost loop (C = E grown
	 * by s/2, so E lies at least s/2 inside C's outline). */
	if (!rc) {
		paths_fini(&F);
		F = E;
		paths_init(&E);
	}
	if (rc || F.n == 0)
		goto out;
	if (in->fill == LAYER_FILL_SOLID) {
		if (paths_append_move(&skin, &F))
			rc = ERR_SET(e, ERR_NOMEM, "out of memory planning layer %d", in->index);
	} else {
		rc = skin_of(c, in, &F, &skin, e);
		if (!rc)
			rc = drop_small(&skin, geom_nm_to_mm(s) * geom_nm_to_mm(s), e);
		if (!rc && skin.n)
			rc = clip_boolean(CLIP_DIFFERENCE, &F, &skin, CLIP_FILL_NONZERO,
					  &ar->fill[TP_ROLE_SPARSE], e);
		else if (!rc && paths_append_move(&ar->fill[TP_ROLE_SPARSE], &F))
			rc = ERR_SET(e, ERR_NOMEM, "out of memory planning layer %d", in->index);
	}
	if (!rc && skin.n)
		rc = classify_skin(c, in, &skin, s, items, ar, e);
out:
	paths_fini(&prev);
	paths_fini(&cur);
	paths_fini(&a);
	paths_fini(&b);
	paths_fini(&gap);
	paths_fini(&E);
	paths_fini(&F);
	paths_fini(&skin);
	return rc;
}
