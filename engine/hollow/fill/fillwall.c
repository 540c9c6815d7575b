/* fillwall.c - leaning walls between the top-down fill's voids
 * (`lean_walls`, on by default; fill_int.h, docs/hollow.md "Top-down
 * fill"): keep-apart that moves the wall between two voids towards the
 * smaller one by dd per layer, the pruning of the pixels such a moving
 * wall would leave behind, and the voids' convex corners grown square
 * (`mitre_corners`).
 */
#include "engine/hollow/fill/fill_int.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/label.h"

/*
 * Keep the voids apart, leaning (on s->void_out, given V(k + 1) =
 * s->void_above).  Each void pixel belongs to its nearest component l of
 * V(k + 1) (8-connected in the layer; s->near_void), at distance d1
 * (s->near_void_d2_mm2 = d1^2):
 *   - d1 >= wall + dg: a new cell, >= wall + dg from every component; kept;
 *   - dg < d1 < wall + dg: neither growth nor a cell: solid;
 *   - d1 <= dg: growth of l, kept at >= half - dd from the bisector pixels
 *     (where the nearest component changes) on the side of the larger
 *     component (pixel count in layer k + 1), >= half + dd on the
 *     smaller's.
 * So the bisector between two voids moves by dd per layer towards the
 * smaller: the larger advances, the smaller recedes (a floor), and the
 * wall between them leans at the design slope over the larger (its
 * underside is the larger's ceiling) until the smaller is used up,
 * instead of standing down to a floor.  half = wall / 2 / cos(alpha -
 * margin) keeps wall_next across the leaning wall, normal to it.  Out:
 * s->bisector_side = 1 or 2 for the side of the nearest bisector pixel
 * (larger, smaller; 0 without one), s->bisector_d2_mm2 its squared
 * distance (written only where there is a bisector pixel), and
 * s->near_void_d2_mm2: all three read by hl_step_prune.  Everything
 * dropped turns solid (a subset: safe).  O(pixels + components^2).
 */
int hl_step_keep_apart_lean(struct hl_win *s, int ww, int wh, const struct hl_geo *g,
			    struct err *e)
{
	static const int nb[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
	size_t np = (size_t)ww * (size_t)wh;
	double cut = g->wall + 2 * g->dg + 2 * g->pmax;
	int32_t count = 0, *rank = NULL, *side = s->bisector_side;
	size_t *area = NULL;
	int anyb = 0, rc;

	/* step_label: the components of V(k + 1), then the bisector marks */
	rc = hl_step_near_voids(s, ww, wh, g, &count, e);
	if (rc)
		return rc;
	rank = mem_alloc(((size_t)count + 1) * sizeof *rank);
	area = mem_calloc((size_t)count + 1, sizeof *area);
	if (!rank || !area) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill walls)");
		goto out;
	}
	for (size_t i = 0; i < np; i++)
		area[s->step_label[i]]++;
	/* rank 0 = the largest (ties: the lower label); the components of one
	 * layer's window are few */
	for (int32_t l = 1; l <= count; l++) {
		rank[l] = 0;
		for (int32_t m = 1; m <= count; m++)
			rank[l] += area[m] > area[l] || (area[m] == area[l] && m < l);
	}
	/* bisector pixels, written over the labels in s->step_label (no longer
	 * needed: area and rank are counted, s->near_void holds each pixel's
	 * component): 1 where every other side ranks below, 2 where some
	 * other side ranks above */
	for (int y = 0; y < wh; y++)
		for (int x = 0; x < ww; x++) {
			size_t i = (size_t)y * (size_t)ww + (size_t)x;
			int32_t l = s->near_void[i], f = 0;
			if (l && s->near_void_d2_mm2[i] <= cut * cut)
				for (int q = 0; q < 4; q++) {
					int xn = x + nb[q][0], yn = y + nb[q][1];
					int32_t m;
					if (xn < 0 || yn < 0 || xn >= ww || yn >= wh)
						continue;
					m = s->near_void[(size_t)yn * (size_t)ww + (size_t)xn];
					if (m && m != l)
						f = rank[m] < rank[l] ? 2 : (f ? f : 1);
				}
			s->step_label[i] = f;
			anyb |= f != 0;
		}
	if (anyb)
		rc = hl_grid_nearest(s->step_label, ww, wh, g->px, g->py, s->bisector_d2_mm2, side,
				     s->step_mask, s->nearest_index, &s->edt, e);
	else
		memset(side, 0, np * sizeof *side);
	if (rc)
		goto out;
	for (size_t i = 0; i < np; i++) {
		double d1, h;
		if (!s->void_out[i])
			continue;
		d1 = sqrt(s->near_void_d2_mm2[i]);
		if (d1 >= g->wall + g->dg)
			continue;
		if (d1 <= g->dg) {
			if (!anyb)
				continue;
			h = side[i] == 2 ? g->half + g->dd : g->half - g->dd;
			if (s->bisector_d2_mm2[i] >= h * h)
				continue;
		}
		s->void_out[i] = 0;
		s->sig_out_mm[i] = INFINITY; /* solid: reached from V(k) only, at dd per layer */
	}
out:
	mem_free(rank);
	mem_free(area);
	return rc;
}

/* The 8-neighbours in order round a pixel (consecutive ones 8-adjacent). */
static const int HL_RING[8][2] = {{1, 0},  {1, 1},   {0, 1},  {-1, 1},
				 {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};

/* Is pixel (x, y) of v (1 = void, ww x wh) void?  Outside the window: no. */
static int void_at(const uint8_t *v, int ww, int wh, int x, int y)
{
	return x >= 0 && y >= 0 && x < ww && y < wh && v[(size_t)y * (size_t)ww + (size_t)x];
}

/* The solid 8-neighbours of pixel (x, y) (outside the window: solid), as
 * the number of 8-connected groups they make on the ring round it:
 * turning a pixel with at most one group void disconnects nothing. */
static int ring_groups(const uint8_t *v, int ww, int wh, int x, int y)
{
	int sol[8], groups = 0, any = 0;

	for (int q = 0; q < 8; q++) {
		sol[q] = !void_at(v, ww, wh, x + HL_RING[q][0], y + HL_RING[q][1]);
		any |= sol[q];
	}
	if (!any)
		return 0;
	/* consecutive ring pixels are 8-adjacent, and so are two edge pixels
	 * (even q) two apart: a group starts at a solid pixel whose
	 * predecessor is void, unless it is an edge pixel whose edge
	 * predecessor (q - 2) is solid */
	for (int q = 0; q < 8; q++)
		if (sol[q] && !sol[(q + 7) % 8] && !(q % 2 == 0 && sol[(q + 6) % 8]))
			groups++;
	return groups ? groups : 1;
}

/* Has pixel (x, y) of v (1 = void) a void 8-neighbour? */
static int next_to_void(const uint8_t *v, int ww, int wh, int x, int y)
{
	for (int j = 0; j < 8; j++)
		if (void_at(v, ww, wh, x + HL_RING[j][0], y + HL_RING[j][1]))
			return 1;
	return 0;
}

/* Would turning pixel (x, y) of v (1 = void; outside the window: solid)
 * void leave a solid 8-neighbour of it with 4 or more void 8-neighbours
 * (a tooth of solid pointing into the void)?  A square void's corner
 * leaves 3 at most. */
static int makes_tooth(const uint8_t *v, int ww, int wh, int x, int y)
{
	int tooth = 0;

	for (int j = 0; j < 8 && !tooth; j++) {
		int qx = x + HL_RING[j][0], qy = y + HL_RING[j][1], n = 0;
		if (qx < 0 || qy < 0 || qx >= ww || qy >= wh || void_at(v, ww, wh, qx, qy))
			continue;
		for (int t = 0; t < 8; t++) {
			int ux = qx + HL_RING[t][0], uy = qy + HL_RING[t][1];
			n += (ux == x && uy == y) || void_at(v, ww, wh, ux, uy);
		}
		tooth = n >= 4;
	}
	return tooth;
}

/*
 * Prune (on s->void_out, after keep-apart and the vertical walls; lean
 * walls only).  A pixel hl_step_grow() kept solid (R, or a bridge:
 * s->keep) because the pixel above had no solid of layer k within dg may
 * have some now: the wall band keep-apart added.  Kept anyway, it is left
 * behind by the moving wall: the next layer keeps it as R again and its
 * bridge to the wall grows, an icicle a pixel wide under the leaning wall
 * (the cow, 50 mm: fin_mm3 2.09 without this).
 * Corners (g->corners): a pixel of E, solid above, beside the void and
 * farther than dg but within sqrt 2 dg of V(k + 1) is a candidate too.
 * Growth keeps it solid because it lies farther than dd from V(k + 1),
 * but the rule asks only that the solid of layer k + 1 lie within dg of
 * layer k's: beside a void's convex corner (a concave corner of the
 * solid, held by both its faces) the pixel diagonal to the corner may
 * turn void, and the corner grows square (at SL1 pitch, 1.06 px allowed,
 * round growth bounds a void by axis-aligned edges advancing a pixel a
 * layer and diagonal ones advancing 0.71 px; mitred, the axis-aligned
 * edges also lengthen by a pixel at each end a layer, and the void tends
 * to a square with chamfered corners).  It is taken only where no solid
 * 8-neighbour of it is left with 4 or more void 8-neighbours
 * (makes_tooth): along a diagonal front every other pixel could go, and
 * the solid teeth left between them stood to the floor as pillars a pixel
 * wide (the 50 mm ball: 95 mm3 of slivers).
 * A candidate turns void, pixel by pixel on the current state, where
 *   - its solid 8-neighbours make at most one group (nothing is cut
 *     off: a cut-off pixel would stand to the floor as an island);
 *   - it lies within dg of V(k + 1) (a corner: farther than dg, so that
 *     a straight front's pixels stay as growth made them where dd and
 *     dg span several pixels, and within sqrt 2 dg, with a void
 *     8-neighbour, so that no void opens inside the solid; keep-apart
 *     would have made it solid: the one relaxation of keep-apart), far
 *     enough from the bisector to pass keep-apart's wall between voids,
 *     and is not a floor under a void of layers k + 2 .. k + mv (the
 *     vertical walls' rule);
 *   - every solid pixel of layer k + 1 within dg of it that is void
 *     below (itself included) keeps another solid pixel of layer k
 *     within dg: the rule of hl_step_grow() holds.
 * Repeated until nothing changes (icicles peel from their tips), at most
 * 32 passes.  O(candidates x (dg / pixel)^4) per pass.
 */
int hl_step_prune(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k)
{
	int rx = (int)floor(g->dg / g->px), ry = (int)floor(g->dg / g->py), changed = 1;
	double dg2 = g->dg * g->dg;

	for (int pass = 0; changed && pass < 32; pass++) {
		changed = 0;
		for (int y = 0; y < wh; y++)
			for (int x = 0; x < ww; x++) {
				size_t i = (size_t)y * (size_t)ww + (size_t)x;
				int ok = 1;
				double h, d2 = s->near_void_d2_mm2[i];
				int corner = g->corners && s->keep[i] == HL_KEEP_E;
				if (s->void_out[i] || !s->region[i] || s->void_above[i] ||
				    (s->keep[i] != HL_KEEP_R && s->keep[i] != HL_KEEP_BRIDGE && !corner))
					continue;
				/* a corner: beyond dg (a straight front's pixels stay with
				 * growth), within sqrt 2 dg (1e-12 mm^2: a pixel's
				 * diagonal at dg of exactly a pixel), beside void */
				if (corner && (d2 <= dg2 || d2 > 2 * dg2 + 1e-12 ||
					       !next_to_void(s->void_out, ww, wh, x, y)))
					continue;
				if ((!corner && d2 > dg2) ||
				    (s->last_void[i] >= k + 2 && s->last_void[i] <= k + g->mv))
					continue;
				h = s->bisector_side[i] == 2 ? g->half + g->dd : g->half - g->dd;
				if ((s->bisector_side[i] && s->bisector_d2_mm2[i] < h * h) ||
				    ring_groups(s->void_out, ww, wh, x, y) > 1)
					continue;
				/* every Q near it, solid at k + 1 and void at k once it is */
				for (int qy = y - ry; ok && qy <= y + ry; qy++)
					for (int qx = x - rx; ok && qx <= x + rx; qx++) {
						double dx = (qx - x) * g->px, dy = (qy - y) * g->py;
						int sup = 0;
						size_t q;
						if (qx < 0 || qy < 0 || qx >= ww || qy >= wh ||
						    dx * dx + dy * dy > dg2)
							continue;
						q = (size_t)qy * (size_t)ww + (size_t)qx;
						if (!s->region[q] || s->void_above[q] ||
						    (q != i && !s->void_out[q]))
							continue;
						for (int sy = qy - ry; !sup && sy <= qy + ry; sy++)
							for (int sx = qx - rx; !sup && sx <= qx + rx;
							     sx++) {
								double ex = (sx - qx) * g->px;
								double ey = (sy - qy) * g->py;
								size_t t;
								if (sx < 0 || sy < 0 || sx >= ww ||
								    sy >= wh || ex * ex + ey * ey > dg2)
									continue;
								t = (size_t)sy * (size_t)ww + (size_t)sx;
								sup = t != i && !s->void_out[t];
							}
						ok = sup;
					}
				if (ok && corner)
					ok = !makes_tooth(s->void_out, ww, wh, x, y);
				if (!ok)
					continue;
				s->void_out[i] = 1;
				s->sig_out_mm[i] = INFINITY;
				changed = 1;
			}
	}
	return 0;
}
