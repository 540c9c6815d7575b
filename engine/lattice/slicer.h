/* slicer.h - streaming plane sweep of a lattice's convolution solid.
 *
 * Paper 000 section 4: struts arrive sorted by lower z (strut.h); an
 * active list holds those whose swept sphere of radius R reaches the
 * current plane (z_low - R < z < z_high + R).  Each plane is rendered
 * directly into pixels: every active strut is culled to the rows and, per
 * row, to the exact pixel run where the plane meets its capsule of radius
 * R, so the work is the sum of the struts' cross-section areas in pixels,
 * never pixels x struts.  Rows are split into bands processed by
 * `threads` threads.  Memory: the active list, per-thread band buffers
 * and the caller's image; independent of the total strut count.
 * Design and measurements: docs/lattice.md section 6.
 */
#ifndef INFILLD_LATTICE_SLICER_H
#define INFILLD_LATTICE_SLICER_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/raster.h"
#include "engine/lattice/strut.h"

struct err;

struct lattice_slicer_opts {
	double support_mm; /* kernel support R (> every strut radius) */
	int threads;       /* >= 1 */
	int antialias;     /* 1: 8-bit coverage from the field and its gradient;
			      0: binary, pixel centre field > C */
};

struct lattice_slicer_stats {
	size_t active;        /* struts active at the last plane */
	size_t max_active;    /* largest active list so far */
	uint64_t struts_read; /* struts consumed from the source */
	uint64_t pairs;       /* (pixel, strut) kernel evaluations so far */
	size_t bytes;         /* memory held by the slicer now (excl. the image) */
};

struct lattice_slicer;

/* src is borrowed and must outlive the slicer.  Caller frees. */
int lattice_slicer_new(struct lattice_source src, const struct lattice_slicer_opts *o,
		       struct lattice_slicer **out, struct err *e);
void lattice_slicer_free(struct lattice_slicer *s);

/* Render plane z_mm (non-decreasing between calls, else ERR_PARAM) into r
 * (raster.h pixel convention, via map; pixels are overwritten, every one)
 * and, if field is non-NULL, store F/C at every pixel centre in field
 * (r->w * r->h floats, row-major): the solid is field > 1.  r may be NULL
 * when only the field is wanted (then w, h give its size).  Struts with
 * radius >= R are ERR_PARAM (they have no finite weight). */
int lattice_slicer_render(struct lattice_slicer *s, double z_mm, const struct raster_map *map,
			  struct raster *r, float *field, int w, int h, struct err *e);

void lattice_slicer_get_stats(const struct lattice_slicer *s, struct lattice_slicer_stats *st);

#endif
