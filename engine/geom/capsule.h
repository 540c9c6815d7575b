/* capsule.h - exact horizontal sections of capsules (a segment swept by a
 * ball; a ball when both ends coincide), and the union of many rendered
 * into a layer image.
 *
 * A plane z = const meets a capsule in a convex set; along one pixel row
 * (the line through the row's pixel centres, in the printer frame through
 * a raster_map) that set is one interval of the row parameter, found by
 * solving the quadratics of the cylinder and of the two end balls.  The
 * lattice engine's streaming slicer (paper 000) and the hybrid engine's
 * ball-and-stick lattice (paper 003) both use this one routine.
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
 * where u is in (lo, hi).  Returns 1 with the interval, 0 when it misses. */
int capsule_row_interval(const struct capsule *c, struct vec3 o, struct vec3 s, double *lo,
			 double *hi);

/* Binary image (w x h, one byte per pixel, stride w) of the union of the
 * capsules' sections by plane z_mm: img[j * w + i] = 1 where pixel
 * (i, j)'s centre is inside some capsule, else left as it was (callers
 * clear first).  Capsules that do not reach z are skipped cheaply; the
 * work is the sum of the sections' pixel areas plus n.  threads >= 1.
 * 0 or ERR_NOMEM. */
int capsule_union_raster(const struct capsule *caps, size_t n, double z_mm,
			 const struct raster_map *map, int w, int h, uint8_t *img, int threads,
			 struct err *e);

#endif
