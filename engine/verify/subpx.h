/* subpx.h - a layer's solid at sub-pixel accuracy, read from its
 * anti-aliased image, and the overhang distance between two layers
 * (verify.c's overhang test; docs/verify.md "Sub-pixel overhangs").
 *
 * Model of one layer.  A pixel of gray 255 is its whole square, a pixel
 * of gray 0 is empty, and a pixel of gray g in between is the part of
 * its square on the solid side of one straight edge: the edge's normal
 * is the gray gradient there (3 x 3 isotropic Sobel weights 1, sqrt 2,
 * 1), and its offset from the centre is the one at which the cut-off
 * part's area is g / 255 of the square (exact for a straight edge; the
 * inverse of the area of a square cut by a line).  Where that edge misses
 * a neighbour's coverage, two edges fitted to the 5 x 5 neighbourhood
 * when they explain it (corner.h): the square in both half-planes (a
 * convex corner) or in either (a concave one).  A grey pixel with no
 * gradient (a speck alone) is a centred square of that area.  Pixels
 * beyond the crop are empty.  This is the reading of Gustavson and
 * Strand's anti-aliased distance transform (2011), kept as regions so
 * that distances are between sets, not between pixel centres.
 *
 * Units: positions in image pixels (pixel (x, y) is the square
 * [x - 1/2, x + 1/2] x [y - 1/2, y + 1/2] around its centre (x, y): the
 * half-pixel shift of raster.h does not matter to distances); distances
 * in mm with the two pitches.
 *
 * Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_SUBPX_H
#define INFILLD_VERIFY_SUBPX_H

#include <stddef.h>
#include <stdint.h>

#include "engine/verify/corner.h"

/* The corner fits made on one layer's crop, so that a grey pixel is
 * fitted once however often it is measured (corner.h: a fit costs some
 * thousands of clipped squares).  Threads may measure pixels of one crop
 * at once (a fit is a function of the pixel's 7 x 7 neighbourhood alone:
 * two threads that fit one pixel at once store the same fit, the second
 * copy unused); sizing and reset are for one thread. */
struct verify_subpx_fits {
	_Atomic int32_t *at; /* per crop pixel: index in fit, -1 not fitted yet */
	size_t at_cap;
	struct verify_subpx_fit {
		size_t px;                /* crop pixel */
		struct verify_corner k;   /* k.n == 0: no corner */
	} *fit;
	_Atomic size_t n; /* slots taken (may pass cap: those fits were not kept) */
	size_t cap;       /* cap >= the crop's grey pixels */
};

/* A crop of one layer: gray[(y - y0) * w + (x - x0)] for image pixel
 * (x, y) inside it (borrowed). */
struct verify_subpx_img {
	const uint8_t *gray;
	int x0, y0, w, h;
	double px_mm, py_mm; /* pitch along x (columns) and y (rows) */
	int one_edge;        /* 1: one straight edge in every grey pixel, no
			      * corners (the model's comparison in tests) */
	struct verify_subpx_fits *fits; /* this layer's fits (borrowed, filled
					 * as pixels are measured); NULL:
					 * fitted on every call */
	struct verify_fit_memo *memo;   /* fits by neighbourhood (borrowed,
					 * corner.h); NULL: none */
};

/* Size f for a crop of `pixels` pixels, `grey` of them grey (0 < gray <
 * 255), after verify_subpx_fits_reset: 0 or ERR_NOMEM (f then unusable
 * until a successful call; freed by verify_subpx_fits_fini). */
int verify_subpx_fits_size(struct verify_subpx_fits *f, size_t pixels, size_t grey);
/* Forget the fits (before the crop holds another layer): O(fits). */
void verify_subpx_fits_reset(struct verify_subpx_fits *f);
void verify_subpx_fits_fini(struct verify_subpx_fits *f);

/* A convex polygon of at most 6 vertices in mm, image-pixel origin,
 * wound consistently; n == 0 when empty. */
struct verify_subpx_poly {
	int n;
	double x[8], y[8];
};

/* A pixel's solid region: the union of `parts` convex polygons (0: empty;
 * 2 only where the solid is concave, around a corner of void).  corner:
 * by the two-edge model (corner.h); has_tip: (tip_x, tip_y), mm, is
 * where its two edges meet, inside the pixel (a point of the region's
 * boundary that is a vertex of no part when the solid is the union). */
struct verify_subpx_region {
	int parts, corner, has_tip;
	struct verify_subpx_poly part[2];
	double tip_x, tip_y;
};

/* Gray of image pixel (x, y), 0 beyond the crop. */
int verify_subpx_gray(const struct verify_subpx_img *im, int x, int y);

/* Region of image pixel (x, y) by the model above. */
void verify_subpx_region(const struct verify_subpx_img *im, int x, int y,
			 struct verify_subpx_region *out);

/* The one straight edge of grey pixel (x, y): the half-plane n.u <= d
 * (pixel units, origin at the pixel's centre, n the unit normal from
 * solid to void) whose part of the square has the pixel's coverage.
 * Returns 0 (outputs untouched) for gray 0 or 255 or no gradient. */
int verify_subpx_line(const struct verify_subpx_img *im, int x, int y, double *nx, double *ny,
		      double *d);

/* Clip polygon (ux, uy)[*n] (pixel units, at most 8 vertices in and out:
 * a square and up to 4 half-planes) to n.u <= d (Sutherland-Hodgman). */
void verify_subpx_clip(double *ux, double *uy, int *n, double nx, double ny, double d);

/* Largest distance (mm) from a point of pixel (x, y)'s square to its
 * region: 0 for gray 255, at most half the pixel diagonal. */
double verify_subpx_gap_mm(const struct verify_subpx_img *im, int x, int y);

/* Distance (mm) from point (x_mm, y_mm) to polygon p (0 inside). */
double verify_subpx_poly_dist(const struct verify_subpx_poly *p, double x_mm, double y_mm);

/* Distance (mm) from point (x_mm, y_mm) to region r (0 inside). */
double verify_subpx_region_dist(const struct verify_subpx_region *r, double x_mm, double y_mm);

/* Largest distance (mm) from a point of the region of pixel (x, y) of
 * layer `above` to the solid of layer `below` (the union of its pixels'
 * regions), looking at the pixels of `below` within win_px (Chebyshev)
 * of (x, y); INFINITY when none of them is solid (or the region is
 * empty: then -INFINITY).  Evaluated at the region's vertices, its
 * corner's tip and the points of a 5 x 5 grid over the square
 * (quarter-pixel steps) that lie in it: exact where the farthest point
 * is a vertex (a slope's edge), within an eighth of a pixel's diagonal
 * on a ridge (where two walls below are equally near).  Two readings of
 * `above` need its neighbourhood: a pixel in a small hole that closes (a
 * roof's last hole, whose shape its few grey pixels do not give) is
 * read as `below`'s solid grown evenly to the hole's void area, where
 * that gives the hole's pixels their coverage; else a valley pixel (a
 * void thinner than the pixel) as the square less a disc of the void's
 * area (docs/verify.md).  The caller sizes win_px to cover every pixel
 * of `below` that can be nearest (verify.c). */
double verify_subpx_far_mm(const struct verify_subpx_img *below,
			   const struct verify_subpx_img *above, int x, int y, int win_px);

/* The reading of verify_subpx_far_mm for pixel (x, y) of above (gray
 * its gray) where it matters, given u_mm, an upper bound on it (the
 * caller skips the pixel when that is within its slope), and any_mm, the
 * centre distance to the nearest pixel of below with any solid: a lower
 * bound (any_mm less half a pixel diagonal, a whole one for a pixel
 * under half solid) when that is beyond reach_mm already, else the
 * measurement on the window those two bounds give.  verify.c's overhang
 * test and verify_far_pixels (pair.c) share it. */
double verify_subpx_far_bounded_mm(const struct verify_subpx_img *below,
				   const struct verify_subpx_img *above, int x, int y, int gray,
				   double u_mm, double any_mm, double reach_mm);

#endif
