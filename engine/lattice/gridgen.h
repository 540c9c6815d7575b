/* gridgen.h - streaming generation of very large lattices (tens to hundreds
 * of millions of struts) straight into a binary lattice file.
 *
 * The TetGen pipeline (generate.h) holds its tetrahedra in memory; at 10^8
 * struts that is tens of GB.  This generator emits a Freudenthal (Kuhn)
 * tetrahedral grid clipped to the part, z-layer by z-layer, so nodes come
 * out sorted by z and every edge goes from a node to a later one: the
 * binary format's order falls out directly and memory is one bit per grid
 * cell plus two layers of node indices.  The grid is stretched by so_k
 * along z (the SO idea: the diagonal struts then lean less than 45 deg),
 * nodes are jittered in x and y (z stays exact, keeping the order), and
 * radii are graded from the part's centre to its rim.
 */
#ifndef INFILLD_LATTICE_GRIDGEN_H
#define INFILLD_LATTICE_GRIDGEN_H

#include <stddef.h>
#include <stdint.h>

#include "engine/lattice/gen.h"

struct lattice_grid_opts {
	double spacing_mm;  /* grid step in x and y */
	double so_k;        /* z step = so_k * spacing */
	double jitter;      /* xy jitter as a fraction of the spacing (< 0.25) */
	double r_center_mm; /* strut radius at the domain's centre */
	double r_rim_mm;    /* ... at the farthest corner of its box */
	double support_mm;  /* R; 0 = 1.5 x the largest radius */
	uint64_t seed;
};

struct lattice_grid_stats {
	uint64_t nodes, struts;
	size_t cells;          /* grid cells classified */
	double seconds_classify, seconds_write;
};

/* Choose spacing_mm so that about `struts` struts fill a part of volume
 * volume_mm3 (7 struts per interior node of the grid). */
double lattice_grid_spacing_for(double volume_mm3, double struts, double so_k);

/* Write the lattice of domain d to path (binary format).  Inside tests
 * run on d->threads threads.  Memory: cells/8 bytes + two layers of
 * indices; the file is written sequentially. */
int lattice_grid_write(const struct lattice_domain *d, const struct lattice_grid_opts *o,
		       const char *path, struct lattice_grid_stats *st, struct err *e);

#endif
