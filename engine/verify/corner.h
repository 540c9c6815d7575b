/* corner.h - the two-edge model of a grey pixel where two straight edges
 * of a layer's solid meet (a corner of a roof or of a void's outline),
 * which one straight edge cannot describe (subpx.h; docs/verify.md
 * "Sub-pixel overhangs").
 *
 * Units and frame: pixel units, origin at the pixel's centre, x along
 * image columns and y along rows (subpx.h's frame less the pixel's
 * position).  Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_CORNER_H
#define INFILLD_VERIFY_CORNER_H

struct verify_subpx_img;

/* Two half-planes n_k . u <= d_k (n_k unit, from solid to void).  The
 * solid is their intersection (convex: around the tip of a wedge of
 * solid) or their union (concave: around the tip of a wedge of void).
 * n == 0: no corner (the one-edge model stands), else 2. */
struct verify_corner {
	int n, convex;
	double nx[2], ny[2], d[2];
};

/* Area (pixel units, 0..1) of the unit square centred at (i, j) inside
 * the solid of k (n == 2). */
double verify_corner_area(const struct verify_corner *k, double i, double j);

/* Fit two edges to the 5 x 5 neighbourhood of grey pixel (x, y) of im
 * (0 < gray < 255): least squares on the coverage of its 25 pixels (the
 * model's exact areas; Levenberg-Marquardt from the window's two most
 * turned Sobel edges, both phases), then both offsets moved alike until
 * the pixel's own area equals its coverage.  Sets k->n = 2 when the
 * pixel holds (or borders) a corner: its one straight edge
 * (verify_subpx_line) misses a 3 x 3 neighbour's coverage by more than
 * VERIFY_CORNER_GATE, the window has at least 5 grey pixels, the fit's
 * squared error is at most VERIFY_CORNER_GAIN times the straight edge's,
 * it misses no pixel's coverage by more than VERIFY_CORNER_FIT_TOL (a
 * third edge in the window fails here) and its normals turn by at least
 * VERIFY_CORNER_MIN_TURN_DEG; else k->n = 0.  Cost: 9 closed-form areas
 * when the straight edge holds, else some thousands of clipped squares
 * (the caller keeps fits: subpx.h's verify_subpx_fits). */
void verify_corner_fit(const struct verify_subpx_img *im, int x, int y, struct verify_corner *k);

/* The fits of one check kept by neighbourhood (verify.h's struct
 * verify_fit_memo, opaque): a fit is a function of the 7 x 7 grays
 * around its pixel alone (its 5 x 5 window and their Sobel normals), and
 * the same neighbourhood recurs on the next layer of a wall, in a
 * mending's passes over one pair of layers and when the check reads what
 * was mended.  verify_corner_fit takes it from im->memo when not NULL:
 * VERIFY_FIT_MEMO_SLOTS slots, a neighbourhood hashed to one of them,
 * which holds the last fit stored there (the slots are shared by threads
 * under striped locks; its full key is compared, so a neighbourhood
 * hashed to a taken slot only replaces that slot's fit).  The same fits
 * with or without it.  The slots verify_fit_memo_new(0) makes, 112 bytes
 * each. */
#define VERIFY_FIT_MEMO_SLOTS (1u << 16)

#define VERIFY_CORNER_GATE 0.05
#define VERIFY_CORNER_GAIN 0.25
#define VERIFY_CORNER_FIT_TOL 0.03
#define VERIFY_CORNER_MIN_TURN_DEG 15.0

#endif
