/* strutgrid.h - point queries of the lattice field (internal to lattice/).
 *
 * A uniform grid over the struts' capsules (segment bounding box inflated
 * by R): each cell lists the struts whose capsule box overlaps it, so the
 * field at p needs only the struts of p's cell.  Used by density matching
 * and measurement, where millions of scattered points are evaluated
 * (slicing uses the plane sweep of slicer.c instead).
 */
#ifndef INFILLD_LATTICE_STRUTGRID_H
#define INFILLD_LATTICE_STRUTGRID_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;

struct strut_grid {
	struct vec3 lo;
	double cell;
	int n[3];
	uint32_t *start; /* ncells + 1 */
	uint32_t *item;  /* strut indices */
	const struct vec3 *node;
	const uint32_t *ab; /* 2 per strut */
	size_t nstruts;
	double R;
};

/* Index n struts (node pairs ab into node) with support R; cell edge
 * about cell_mm (raised if the grid would be too large).  node and ab are
 * borrowed.  Caller frees with strut_grid_fini(). */
int strut_grid_init(struct strut_grid *g, const struct vec3 *node, const uint32_t *ab, size_t n,
		    double R, double cell_mm, struct err *e);
void strut_grid_fini(struct strut_grid *g);

/* Struts of the cell holding p (may include struts out of reach). */
void strut_grid_cell(const struct strut_grid *g, struct vec3 p, const uint32_t **items,
		     size_t *count);

/* Growable list of (strut, integral) pairs for one set of points. */
struct strut_pairs {
	uint32_t *strut;
	float *val;     /* integral I (mm) */
	uint32_t *first; /* per point: start in strut/val (npoints + 1) */
	size_t n, cap, npts, pcap;
};
void strut_pairs_reset(struct strut_pairs *p);
void strut_pairs_fini(struct strut_pairs *p);
/* Append point p's nonzero integrals; ERR_NOMEM or 0. */
int strut_pairs_add_point(struct strut_pairs *pp, const struct strut_grid *g, struct vec3 p);

#endif
