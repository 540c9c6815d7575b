/* capsule.h - exact horizontal sections of capsules (a segment swept by a
 * ball; a ball when both ends coincide), and the union of many rendered
 * into a layer image.
 *
 * A plane z = const meets a capsule in a convex set; along one pixel row
 * (the line through the row's pixel centres, in the printer frame through
 * a raster_map) that set is one interval of the row parameter, found by
 * solving the quadratics of the cylinder and of the two end balls.  The
 * lattice engine's streaming slicer (paper 000) and the hybrid engine's
 * ball-and-stick lattice (paper 003) both use this one routine
 * (struct capsule_rows).  The quadratics are derived in capsule.c.
 */
#ifndef INFILLD_GEOM_CAPSULE_H
#define INFILLD_GEOM_CAPSULE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;
struct raster_map;

struct capsule {
	struct vec3 a, b; /* segment ends, mm (a == b: a ball) */
	double r_mm;      /* radius */
};

/* The row line P(u) = o + u s (mm; s the printer-frame step of one pixel
 * along the row, o the point of u = 0) at height z meets the capsule
 * where u is in (lo, hi).  Returns 1 with the interval, 0 when it misses
 * (also when r_mm is not > 0).  s = 0: the interval is (-inf, inf) when o
 * is inside, else a miss. */
int capsule_row_interval(const struct capsule *c, struct vec3 o, struct vec3 s, double *lo,
			 double *hi);

/* One capsule prepared for many rows sharing the step s: the axis form
 * (end a, unit axis t, length l_mm >= 0; l_mm = 0 is a ball and t is then
 * unused) and the row-independent terms.  Caller storage, no free.  The
 * lattice slicer fills it from its float struts so its images do not
 * depend on how a capsule was stored. */
struct capsule_rows {
	struct vec3 a, t;
	double l_mm, r_mm, r2_mm2;
	struct vec3 s;  /* pixel step along the row, mm */
	double s2;      /* |s|^2 */
	double hs;      /* s . t: axial advance per pixel */
	double acyl;    /* |s|^2 - (s . t)^2: the cylinder quadratic's u^2 term */
};

void capsule_rows_init(struct capsule_rows *cr, struct vec3 a, struct vec3 t, double l_mm,
		       double r_mm, struct vec3 s);
/* capsule_row_interval for the prepared capsule and row origin o. */
int capsule_rows_interval(const struct capsule_rows *cr, struct vec3 o, double *lo, double *hi);
/* The pixels i in [umin, umax] whose centre u = i + 0.5 lies in the row's
 * closed interval [lo, hi] (a centre exactly on the surface counts):
 * 1 with the run [*i0, *i1], 0 when none. */
int capsule_rows_run(const struct capsule_rows *cr, struct vec3 o, int umin, int umax, int *i0,
		     int *i1);
/* Inclusive pixel rectangle (raster.h convention, clipped to w x h) that
 * holds every pixel centre of the section by plane z_mm: the segment
 * clipped to the slab |z' - z| <= r, its xy box grown by r, mapped by m.
 * 1 with the rectangle, 0 when it is empty. */
int capsule_rows_rect(const struct capsule_rows *cr, double z_mm, const struct raster_map *m,
		      int w, int h, int *u0, int *u1, int *v0, int *v1);

/* Binary image (w x h, one byte per pixel, stride w) of the union of the
 * capsules' sections by plane z_mm: img[j * w + i] = 1 where pixel
 * (i, j)'s centre is inside some capsule (closed), else left as it was
 * (callers clear first).  Capsules that do not reach z are skipped
 * cheaply; the work is the sum of the sections' pixel areas plus n (use a
 * capsule_zindex to drop the n).  Capsules with r_mm not > 0 or
 * non-finite ends are skipped.  Parallel over bands of rows (parfor),
 * threads >= 1.  0, ERR_PARAM (singular map, w or h < 1) or ERR_NOMEM. */
int capsule_union_raster(const struct capsule *caps, size_t n, double z_mm,
			 const struct raster_map *map, int w, int h, uint8_t *img, int threads,
			 struct err *e);

/* Capsules binned by z extent (slabs of equal height, each listing the
 * capsules whose extent [min z - r, max z + r] overlaps it) so a layer
 * reads only the capsules near its plane: for a stack of layers the cost
 * is the sections' areas plus the slab lists' lengths, not n per layer.
 * caps is borrowed (must outlive the index and stay unchanged).  slab_mm
 * <= 0: the mean capsule extent.  Caller frees with capsule_zindex_free().
 * 0, ERR_LIMIT (more than 2^31 slab entries) or ERR_NOMEM. */
struct capsule_zindex;

int capsule_zindex_new(const struct capsule *caps, size_t n, double slab_mm,
		       struct capsule_zindex **out, struct err *e);
void capsule_zindex_free(struct capsule_zindex *ix);
/* capsule_union_raster over the indexed capsules.  Thread-safe for
 * concurrent calls on one index. */
int capsule_zindex_raster(const struct capsule_zindex *ix, double z_mm,
			  const struct raster_map *map, int w, int h, uint8_t *img, int threads,
			  struct err *e);

#endif
