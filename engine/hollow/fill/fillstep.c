/* fillstep.c - the per-layer steps of the top-down fill (fill_int.h):
 * growth with receding fins, keep-apart, vertical walls, births on
 * ridges, islands.  Pixel sets on one window; the rule and why each step
 * keeps it: docs/hollow.md "Top-down fill".
 */
#include "engine/hollow/fill/fill_int.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/label.h"

void hl_win_fini(struct hl_win *s)
{
	mem_free(s->region);
	mem_free(s->void_above);
	mem_free(s->sig_above_mm);
	mem_free(s->last_void);
	mem_free(s->void_out);
	mem_free(s->sig_out_mm);
	mem_free(s->void_above_d2_mm2);
	mem_free(s->inside_mm);
	mem_free(s->core);
	mem_free(s->support_d2_mm2);
	mem_free(s->keep);
	mem_free(s->fin_steps);
	mem_free(s->fin_queue);
	mem_free(s->near_void);
	mem_free(s->near_void_d2_mm2);
	mem_free(s->bisector_d2_mm2);
	mem_free(s->bisector_side);
	mem_free(s->recent_void_d2_mm2);
	mem_free(s->not_free);
	mem_free(s->free_d2_mm2);
	mem_free(s->ridge);
	mem_free(s->off_ridge_d2_mm2);
	mem_free(s->step_mask);
	mem_free(s->step_label);
	mem_free(s->nearest_index);
	edt_scratch_fini(&s->edt);
}

int hl_win_init(struct hl_win *s, size_t np)
{
	size_t nf = np * sizeof(float), ni = np * sizeof(int32_t);

	memset(s, 0, sizeof *s);
	edt_scratch_init(&s->edt);
	s->region = mem_alloc(np);
	s->void_above = mem_alloc(np);
	s->sig_above_mm = mem_alloc(nf);
	s->last_void = mem_alloc(ni);
	s->void_out = mem_alloc(np);
	s->sig_out_mm = mem_alloc(nf);
	s->void_above_d2_mm2 = mem_alloc(nf);
	s->inside_mm = mem_alloc(nf);
	s->core = mem_alloc(np);
	s->support_d2_mm2 = mem_alloc(nf);
	s->keep = mem_alloc(np);
	s->fin_steps = mem_alloc(ni);
	s->fin_queue = mem_alloc(ni);
	s->near_void = mem_alloc(ni);
	s->near_void_d2_mm2 = mem_alloc(nf);
	s->bisector_d2_mm2 = mem_alloc(nf);
	s->bisector_side = mem_alloc(ni);
	s->recent_void_d2_mm2 = mem_alloc(nf);
	s->not_free = mem_alloc(np);
	s->free_d2_mm2 = mem_alloc(nf);
	s->ridge = mem_alloc(np);
	s->off_ridge_d2_mm2 = mem_alloc(nf);
	s->step_mask = mem_alloc(np);
	s->step_label = mem_alloc(ni);
	s->nearest_index = mem_alloc(ni);
	return s->region && s->void_above && s->sig_above_mm && s->last_void && s->void_out &&
	       s->sig_out_mm && s->void_above_d2_mm2 && s->inside_mm && s->core &&
	       s->support_d2_mm2 && s->keep && s->fin_steps && s->fin_queue && s->near_void &&
	       s->near_void_d2_mm2 && s->bisector_d2_mm2 && s->bisector_side &&
	       s->recent_void_d2_mm2 && s->not_free && s->free_d2_mm2 && s->ridge &&
	       s->off_ridge_d2_mm2 && s->step_mask && s->step_label && s->nearest_index;
}

/* Squared distance transform of seed (nonzero), or all INFINITY when
 * any == 0. */
static int dist2(struct hl_win *s, const uint8_t *seed, int any, int ww, int wh, double px,
		 double py, float *out, struct err *e)
{
	if (!any) {
		for (size_t i = 0; i < (size_t)ww * (size_t)wh; i++)
			out[i] = INFINITY;
		return 0;
	}
	return edt_sq(seed, (size_t)ww, ww, wh, px, py, out, &s->edt, e);
}


/* Neighbour j (0..7) of pixel (x, y) in a ww x wh window, or -1. */
static const int HL_DX[8] = {1, -1, 0, 0, 1, 1, -1, -1};
static const int HL_DY[8] = {0, 0, 1, -1, 1, -1, 1, -1};

static ptrdiff_t nbr(int x, int y, int j, int ww, int wh)
{
	int xx = x + HL_DX[j], yy = y + HL_DY[j];
	if (xx < 0 || yy < 0 || xx >= ww || yy >= wh)
		return -1;
	return (ptrdiff_t)yy * ww + xx;
}

/*
 * Fins end (on s->keep, the classes above; 0 = turns void).  R pixels are
 * thin solid of layer k + 1 with nothing of layer k within dg: where two
 * fronts of one void met, a strip a pixel or two wide between them, or
 * the neck of a tongue of solid the void is wrapping round.  Kept as
 * they are, they stand to the floor: a fin whose lowest pixel can never
 * go (it would hang), cut off from the walls by the dg the fronts ate
 * beside them; a tongue cut off at its neck shrinks to its skeleton,
 * which stands to the floor the same way.  Instead they recede like
 * ceilings towards the walls.  Steps: 4- or 8-neighbours, no longer
 * than dg.
 *   - Ground: not C(k) and the pixels of E (s->core) joined to it
 *     through E.
 *     E cut off from it (a tongue's core) is not ground.
 *   - h (s->fin_steps; s->fin_queue: the pixels in order of h) = steps
 *     from the ground through T = the rest of the solid of layer k + 1
 *     in C(k) (R, the cut-off E, what turns void).
 *   - An R pixel at a local maximum of h (no neighbour higher) turns
 *     void: its neighbour one step lower stays solid and carries it
 *     within dg (it has a higher neighbour, so it is no maximum).
 *   - Every R pixel and cut-off E pixel keeps one such lower neighbour
 *     solid (a bridge), down to the ground: a tongue keeps its neck.
 * A fin hung between two walls opens in the middle and recedes one step
 * per layer towards them: an arch, gone after half its length in layers.
 * A tongue shrinks by dd per layer (E), then recedes to its neck and the
 * neck to the wall.  Pixels no path reaches (a pillar on a floor) stay as
 * they were.  Every solid pixel of layer k + 1 over void still has solid
 * of layer k within dg: the rule holds on the pixels.  O(pixels).
 */
static void recede_fins(struct hl_win *s, int ww, int wh, const struct hl_geo *g)
{
	size_t np = (size_t)ww * (size_t)wh, nq = 0, head = 0;
	int nn = g->px * g->px + g->py * g->py <= g->dg * g->dg ? 8 : 4, anyr = 0;

	if (g->px > g->dg || g->py > g->dg)
		return; /* no neighbour within dg: nothing can carry a step */
	for (size_t i = 0; i < np; i++)
		anyr |= s->keep[i] == HL_KEEP_R;
	if (!anyr)
		return;
	/* ground: h = 0 */
	for (size_t i = 0; i < np; i++) {
		s->fin_steps[i] = s->region[i] ? -1 : 0;
		if (!s->region[i])
			s->fin_queue[nq++] = (int32_t)i;
	}
	while (head < nq) {
		size_t i = (size_t)s->fin_queue[head++];
		int x = (int)(i % (size_t)ww), y = (int)(i / (size_t)ww);
		for (int j = 0; j < nn; j++) {
			ptrdiff_t n = nbr(x, y, j, ww, wh);
			if (n >= 0 && s->fin_steps[n] < 0 && s->core[n]) {
				s->fin_steps[n] = 0;
				s->fin_queue[nq++] = (int32_t)n;
			}
		}
	}
	/* h >= 1 through T and the cut-off E, nearest the ground first */
	nq = head = 0;
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			if (s->fin_steps[i] >= 0 || !s->region[i] || s->void_above[i])
				continue;
			for (int j = 0; j < nn; j++) {
				ptrdiff_t n = nbr(x, y, j, ww, wh);
				if (n >= 0 && s->fin_steps[n] == 0) {
					s->fin_steps[i] = 1;
					s->fin_queue[nq++] = (int32_t)i;
					break;
				}
			}
		}
	while (head < nq) {
		size_t i = (size_t)s->fin_queue[head++];
		int x = (int)(i % (size_t)ww), y = (int)(i / (size_t)ww);
		for (int j = 0; j < nn; j++) {
			ptrdiff_t n = nbr(x, y, j, ww, wh);
			if (n < 0 || s->fin_steps[n] >= 0 || !s->region[n] || s->void_above[n])
				continue;
			s->fin_steps[n] = s->fin_steps[i] + 1;
			s->fin_queue[nq++] = (int32_t)n;
		}
	}
	/* highest first: drop maxima, tie everything kept to the ground */
	while (nq > 0) {
		size_t i = (size_t)s->fin_queue[--nq];
		int x = (int)(i % (size_t)ww), y = (int)(i / (size_t)ww), top = 1;
		ptrdiff_t low = -1;
		if (!s->keep[i])
			continue;
		for (int j = 0; j < nn; j++) {
			ptrdiff_t n = nbr(x, y, j, ww, wh);
			if (n < 0)
				continue;
			if (s->fin_steps[n] > s->fin_steps[i])
				top = 0;
			if (low < 0 && s->fin_steps[n] == s->fin_steps[i] - 1)
				low = n;
		}
		if (low < 0)
			continue;
		if (s->keep[i] == HL_KEEP_R && top)
			s->keep[i] = 0;
		if (!s->keep[low])
			s->keep[low] = HL_KEEP_BRIDGE;
	}
}

/*
 * One layer: V(k) (s->void_out) on the window from C(k) (s->region) and
 * V(k + 1) (s->void_above), sig = s->sig_above_mm = the inside distance of
 * the design's solid of layer k + 1 (mm, INFINITY where unknown); sig for
 * layer k - 1 in s->sig_out_mm.  Pixel sets throughout.  The verifier's rule:
 * every solid pixel of layer k + 1 over a void pixel of layer k lies
 * within dg of a solid pixel of layer k (centre to centre).  Voids only
 * grow here (births are hl_step_born()):
 *   E (s->core) = pixels of C(k), solid in layer k + 1, whose inside
 *       distance su (s->inside_mm) = min(dist(V(k + 1)), sig) exceeds dd: the solid the voids
 *       above cannot reach in one layer at the design slope; sig carries
 *       su down the layers, so the solid recedes by dd per layer on
 *       average even when dd is under a pixel (a sub-pixel slope, drawn
 *       as a staircase); it is carried only while dd is under
 *       HL_FILL_SIG_MAX_PX pixels (else su = dist(V(k + 1))).  sig
 *       counts only while within 2 px of dist(V(k + 1)): farther, the
 *       void it was measured from has receded (a floor, keep_apart),
 *       and sig run down to 0 would turn solid far from any void into
 *       void: ghost cells a pixel or two wide, every layer, which
 *       keep_apart then walled off (the femur's
 *       head lost most of its void to them: 21.7 % -> 41.7 % without);
 *   R = pixels of C(k), solid in layer k + 1 and not in E, farther than
 *       dg from E u not C(k) (s->support_d2_mm2; thin solid between voids, staircase
 *       corners): kept solid, so every solid pixel of layer k + 1 over a
 *       void of layer k is within dg of solid, exactly on the pixels,
 *       except where recede_fins() lets a fin recede towards the walls
 *       (the rule still holds there);
 *   V(k) = C(k) \ (E u R), then kept apart (hl_step_keep_apart);
 *       s->keep holds the class of each pixel kept (HL_KEEP_*).
 * The material outside C(k) supports but never turns void: a void does
 * not creep along a ceiling flatter than alpha (that left hair-thin fins
 * between a creeping band and the void it outran: docs/hollow.md).
 * Any subset of V(k) keeps the rule for layer k + 1 (void turned solid
 * only adds support), and layer k - 1 is built from the result.
 */
int hl_step_grow(struct hl_win *s, int ww, int wh, const struct hl_geo *g, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	int anyv = 0, rc, carry = g->dd < HL_FILL_SIG_MAX_PX * g->pmax;

	for (size_t i = 0; i < np; i++)
		anyv |= s->void_above[i];
	rc = dist2(s, s->void_above, anyv, ww, wh, g->px, g->py, s->void_above_d2_mm2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++) {
		double dv = sqrt(s->void_above_d2_mm2[i]), sig = s->sig_above_mm[i];
		double su = dv > sig + 2 * g->pmax || !carry ? dv : fmin(dv, sig);
		s->inside_mm[i] = (float)su;
		s->core[i] = s->region[i] && !s->void_above[i] && su > g->dd;
		s->step_mask[i] = s->core[i] || !s->region[i]; /* E u not C(k) */
	}
	rc = dist2(s, s->step_mask, 1, ww, wh, g->px, g->py, s->support_d2_mm2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++)
		s->keep[i] =
		    s->core[i] ? HL_KEEP_E
		    : s->region[i] && !s->void_above[i] && s->support_d2_mm2[i] > g->dg * g->dg
			? HL_KEEP_R
			: 0;
	recede_fins(s, ww, wh, g);
	for (size_t i = 0; i < np; i++) {
		int t = s->keep[i] != 0;
		s->void_out[i] = s->region[i] && !t;
		s->sig_out_mm[i] = t ? (float)fmax(0, s->inside_mm[i] - g->dd) : INFINITY;
	}
	return 0;
}

/*
 * Vertical walls (on s->void_out): a pixel void in layer k and in some
 * layer k + 2 .. k + mv (s->last_void) but solid in between would leave a horizontal wall
 * thinner than wall_next between two voids (a floor over a ceiling): it
 * stays solid, where such pixels make a patch (8-connected) of more than
 * pi (2 dg)^2 of area.  Smaller patches are the ceiling's staircase, a
 * pixel or two of the front drawn a layer late, not floors: kept solid
 * they were cut off from the ceiling below and stood to the floor as
 * pillars a pixel wide (armadillo, 50 mm: 3.3 of its 3.5 mm3 of fins,
 * docs/hollow.md).  A subset: safe.  O(pixels).
 */
int hl_step_vertical_walls(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k,
			   struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	double min_px = M_PI * 4 * g->dg * g->dg / (g->px * g->py);
	int32_t count, *area;
	int rc;

	/* step_mask: the floor pixels; step_label: their patches */
	for (size_t i = 0; i < np; i++)
		s->step_mask[i] = s->void_out[i] && !s->void_above[i] && s->last_void[i] >= k + 2 &&
				  s->last_void[i] <= k + g->mv;
	rc = label_components8(s->step_mask, ww, wh, s->step_label, &count, e);
	if (rc)
		return rc;
	area = mem_calloc((size_t)count + 1, sizeof *area);
	if (!area)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill walls)");
	for (size_t i = 0; i < np; i++)
		area[s->step_label[i]]++;
	for (size_t i = 0; i < np; i++)
		if (s->step_label[i] && area[s->step_label[i]] > min_px) {
			s->void_out[i] = 0;
			s->sig_out_mm[i] = 0;
		}
	mem_free(area);
	return 0;
}

/* out[i] = allow[i] && pixel i lies on a ridge of the distance map d2
 * (squared, mm^2): d >= dmin and, along one of the four pixel directions,
 * neither neighbour is higher by more than px / 4 while the two together
 * are lower by at least px / 2 (a strict maximum across the ridge; a
 * straight edge, where neighbours along it are equal, is not a ridge).
 * The medial axis of a region, one or two pixels wide: the diagonals of a
 * square, the centre line of a strip.  Returns whether any pixel is set. */
static int ridge(const float *d2, const uint8_t *allow, int ww, int wh, double dmin, double px,
		 uint8_t *out)
{
	static const int dir[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
	int any = 0;

	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			double d = sqrt(d2[i]);
			int c = 0;
			if (allow[i] && d >= dmin && x > 0 && y > 0 && x + 1 < ww && y + 1 < wh)
				for (int q = 0; q < 4 && !c; q++) {
					size_t a = (size_t)(y + dir[q][1]) * (size_t)ww +
						   (size_t)(x + dir[q][0]);
					size_t b = (size_t)(y - dir[q][1]) * (size_t)ww +
						   (size_t)(x - dir[q][0]);
					double da = sqrt(d2[a]), db = sqrt(d2[b]);
					c = da <= d + 0.25 * px && db <= d + 0.25 * px &&
					    (d - da) + (d - db) >= 0.5 * px;
				}
			out[i] = (uint8_t)c;
			any |= c;
		}
	return any;
}

/*
 * New voids (on s->void_out, after keep_apart).  F = pixels of C(k) farther
 * than wall + dg from every void of layers k .. k + mv (s->last_void holds
 * each pixel's last void layer; s->recent_void_d2_mm2), or farther than
 * wall + dg + lone where their component of C(k) already holds a void (its
 * growth gets there first; without this a square's ridge and the four
 * triangles beside it became five cells instead of one groin vault;
 * s->not_free = not F).  Where F's
 * inside distance D (s->free_d2_mm2 = D^2) is >= birth, a void is born on
 * F's ridge (ridge(): its medial axis; s->ridge), the crest a groin vault's
 * ceiling collapses to.  Each born pixel lies within dg of a pixel of the
 * ridge's complement (s->off_ridge_d2_mm2), solid in layers k and k + 1
 * (pixels that do not stay solid), so the flat ceiling of the new void
 * spans at most 2 dg: the verifier's rule holds.  Below, hl_step_grow()
 * widens it by dd per layer: a ceiling at the design slope, like the
 * paper's voids.  O(pixels).
 */
int hl_step_born(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	double far = g->wall + g->dg, lone = far + g->lone;
	int32_t nc = 0;
	uint8_t *occ;
	int any = 0, anyf = 0, anyb, rc;

	/* step_mask, three times: the void of layers k .. k + mv, F, off the
	 * ridge; step_label: the components of C(k) */
	for (size_t i = 0; i < np; i++) {
		s->step_mask[i] =
		    s->void_out[i] || s->void_above[i] || s->last_void[i] <= k + g->mv;
		any |= s->step_mask[i];
	}
	rc = dist2(s, s->step_mask, any, ww, wh, g->px, g->py, s->recent_void_d2_mm2, e);
	if (rc)
		return rc;
	/* occupied components of C(k) (holding a void of layer k) take new
	 * voids only beyond lone: closer, their own voids get there first */
	rc = label_components8(s->region, ww, wh, s->step_label, &nc, e);
	if (rc)
		return rc;
	occ = mem_calloc((size_t)nc + 1, 1);
	if (!occ)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill births)");
	for (size_t i = 0; i < np; i++)
		if (s->void_out[i])
			occ[s->step_label[i]] = 1;
	for (size_t i = 0; i < np; i++) {
		double lim = occ[s->step_label[i]] ? lone : far;
		s->not_free[i] = !(s->region[i] && s->recent_void_d2_mm2[i] > lim * lim);
		anyf |= !s->not_free[i];
	}
	mem_free(occ);
	if (!anyf)
		return 0;
	rc = dist2(s, s->not_free, 1, ww, wh, g->px, g->py, s->free_d2_mm2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++)
		s->step_mask[i] = !s->not_free[i]; /* F */
	anyb = ridge(s->free_d2_mm2, s->step_mask, ww, wh, g->birth, fmin(g->px, g->py), s->ridge);
	if (!anyb)
		return 0;
	for (size_t i = 0; i < np; i++)
		s->step_mask[i] = !s->ridge[i]; /* off the ridge */
	rc = dist2(s, s->step_mask, 1, ww, wh, g->px, g->py, s->off_ridge_d2_mm2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++)
		if (s->ridge[i] && s->off_ridge_d2_mm2[i] <= g->dg * g->dg) {
			s->void_out[i] = 1;
			s->sig_out_mm[i] = INFINITY;
		}
	return 0;
}

int hl_step_near_voids(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int32_t *count,
		       struct err *e)
{
	int rc = label_components8(s->void_above, ww, wh, s->step_label, count, e);

	if (!rc)
		rc = hl_grid_nearest(s->step_label, ww, wh, g->px, g->py, s->near_void_d2_mm2,
				     s->near_void, s->step_mask, s->nearest_index, &s->edt, e);
	return rc;
}

/*
 * Keep the voids apart (on s->void_out, given V(k + 1) = s->void_above):
 * without this the greedy void grows into a foam of cells split by walls
 * thinner than a pixel (docs/hollow.md).  With d1 the distance to V(k + 1)
 * (s->near_void_d2_mm2 = d1^2) and B the pixels where the nearest component
 * of V(k + 1) changes (s->near_void; its Voronoi boundaries, where within
 * reach), a void pixel stays void if
 *   - d1 >= wall + dg: a new cell, >= wall + dg from every component; or
 *   - d1 <= dg (growth of its nearest component) and it lies >= wall / 2
 *     from B (s->bisector_d2_mm2; standing walls; g->lean: fillwall.c): B
 *     holds the pixels on both sides of the bisector (each
 *     within half a pixel of it), so a void pixel's centre lies >= wall / 2
 *     + 1/2 px from the bisector and two components' pixel centres stay
 *     >= wall + 1 px apart: a wall of wall_next between their pixels'
 *     edges, as the verifier reads it (min_wall_between_mm; 0.789-0.835
 *     mm for 0.8 on the 50 mm models: the bisector is a staircase).
 * Everything else turns solid (a subset: safe).  O(pixels).
 */
int hl_step_keep_apart(struct hl_win *s, int ww, int wh, const struct hl_geo *g, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	double cut = g->wall + 2 * g->dg + 2 * g->pmax, half = 0.5 * g->wall;
	int32_t count;

	int anyb = 0, rc;

	if (g->lean)
		return hl_step_keep_apart_lean(s, ww, wh, g, e);
	/* step_mask: B */
	rc = hl_step_near_voids(s, ww, wh, g, &count, e);
	if (rc)
		return rc;
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			int32_t l = s->near_void[i];
			s->step_mask[i] = l && s->near_void_d2_mm2[i] <= cut * cut &&
					  ((x > 0 && s->near_void[i - 1] != l) ||
					   (x + 1 < ww && s->near_void[i + 1] != l) ||
					   (y > 0 && s->near_void[i - (size_t)ww] != l) ||
					   (y + 1 < wh && s->near_void[i + (size_t)ww] != l));
			anyb |= s->step_mask[i];
		}
	rc = dist2(s, s->step_mask, anyb, ww, wh, g->px, g->py, s->bisector_d2_mm2, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < np; i++) {
		double d1;
		if (!s->void_out[i])
			continue;
		d1 = sqrt(s->near_void_d2_mm2[i]);
		if (d1 >= g->wall + g->dg || (d1 <= g->dg && s->bisector_d2_mm2[i] >= half * half))
			continue;
		s->void_out[i] = 0;
		s->sig_out_mm[i] = 0;
	}
	return 0;
}

/*
 * No floating islands: a solid component of layer k + 1 (8-connected, the
 * part's material and the outside counting as solid) with nothing solid
 * under any of its pixels would print onto liquid resin.  Its pixels stay
 * solid in layer k (on s->void_out): a pillar that the next layers carry
 * down to the floor (adding solid never breaks the overhang rule).  O(pixels).
 */
int hl_step_islands(struct hl_win *s, int ww, int wh, struct err *e)
{
	size_t np = (size_t)ww * (size_t)wh;
	uint8_t *held = NULL;
	int32_t count;
	int rc;

	/* step_mask: the solid of layer k + 1; step_label: its components */
	for (size_t i = 0; i < np; i++)
		s->step_mask[i] = !s->void_above[i];
	rc = label_components8(s->step_mask, ww, wh, s->step_label, &count, e);
	if (rc)
		return rc;
	held = mem_calloc((size_t)count + 1, 1);
	if (!held)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill islands)");
	for (size_t i = 0; i < np; i++)
		if (s->step_label[i] && !s->void_out[i])
			held[s->step_label[i]] = 1;
	for (size_t i = 0; i < np; i++)
		if (s->step_label[i] && !held[s->step_label[i]]) {
			s->void_out[i] = 0;
			s->sig_out_mm[i] = 0;
		}
	mem_free(held);
	return 0;
}

