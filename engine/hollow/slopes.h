/* slopes.h - the optimised voids' slopes checked on their polygons.
 *
 * The support rule is S(k+1) inside S(k) dilated by a disc of radius
 * r = layer tan(alpha): where a void narrows upwards, solid may advance at
 * most r a layer in every direction, round at convex corners.  The
 * verifier (engine/verify) reads it from the anti-aliased layer images,
 * one or two straight edges per grey pixel; this check reads it from the
 * polygons the images are drawn from, so that a pixel model's error and
 * a geometric excess can be told apart.  For each print layer k holding
 * optimised voids V(k) = part(k) \ result(k):
 *
 *   excess(k) = (V(k) eroded by D_r)  intersected with  result(k + 1),
 *
 * the solid of layer k + 1 over layer k's voids farther than r from layer
 * k's solid (a flat ceiling: all of V(k) but an r-wide rim; a convex
 * corner of solid grown mitred instead of round: r^2 (1 - pi/4) at a
 * right angle, 0.0005 mm2 a layer at r = 0.05 mm).  Erosion is Clipper's round
 * offset, whose chords lie inside the true arcs by up to 0.1 um
 * (slopes.c): the check reads at most that band more than the exact
 * rule, never less.  Only the optimised voids are
 * checked (the fill is exact on its pixels, docs/hollow.md).
 */
#ifndef INFILLD_HOLLOW_SLOPES_H
#define INFILLD_HOLLOW_SLOPES_H

#include <stddef.h>

struct mesh;
struct err;

struct hl_slopes {
	double excess_mm2;    /* sum of area(excess(k)) over layers above HL_SLOPES_MIN_MM2 */
	double worst_mm2;     /* the largest layer's */
	int worst_layer;      /* its k + 1 (the layer holding the solid), -1: none */
	int layers_over;      /* layers whose excess passes HL_SLOPES_MIN_MM2 */
	int layers_checked;   /* layers holding optimised voids */
};

/* Pieces under this area in a layer are boolean rounding (mm2): a pixel
 * of the SL1 printers is 0.0022 mm2. */
#define HL_SLOPES_MIN_MM2 1e-6

/* Check the result mesh res (its first part_nv / part_nt vertices and
 * triangles the part, the optimised voids' surfaces after them) at print
 * layers of layer_mm (layer k centred at (k + 1/2) layer_mm) against
 * reach_mm = layer_mm tan(alpha).  No void: all zero.  0, ERR_PARAM
 * (reach_mm <= 0 with voids), ERR_NOMEM or an error of the slicer or of
 * Clipper. */
int hl_slopes_check(const struct mesh *res, size_t part_nv, size_t part_nt, double layer_mm,
		    double reach_mm, struct hl_slopes *out, struct err *e);

#endif
