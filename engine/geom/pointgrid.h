/* pointgrid.h - a uniform bucket grid of points for "is any point closer
 * than d" queries and neighbourhood walks.
 *
 * The hash grid of Poisson-disk sampling: the lattice engine's graded 3D
 * sampler (engine/lattice/tetbuild.c, cells of the smallest radius, many
 * points per cell), poisson2_sample (2D as z = 0) and the hybrid engine's
 * Voronoi sites (engine/hybrid/mfs.c).  Cells are chained lists (head /
 * next), so any cell size works; points outside the box are filed in the
 * nearest boundary cell, so queries stay correct, only slower.
 */
#ifndef INFILLD_GEOM_POINTGRID_H
#define INFILLD_GEOM_POINTGRID_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;

struct pointgrid {
	struct vec3 lo;    /* corner of cell (0, 0, 0), mm */
	double cell_mm;    /* cell edge */
	int n[3];          /* cells per axis, >= 1 */
	int32_t *head;     /* n[0] n[1] n[2] cells (x fastest): first point, -1 = none */
	int32_t *next;     /* per point: the next point of its cell, -1 = end */
	struct vec3 *pts;  /* points in insertion order, mm */
	size_t np, cap;    /* points held, allocated */
};

/* Cells of edge *cell_mm over box b: n[a] = ceil(size / cell) + 1 per axis
 * (a flat axis gets 1 cell); while the product exceeds max_cells the cell
 * grows by 1.25 (*cell_mm is updated).  b non-empty, *cell_mm > 0. */
void pointgrid_dims(struct box3 b, size_t max_cells, double *cell_mm, int n[3]);
/* Cell (ijk) of p in the grid of corner lo, edge cell, n cells per axis,
 * clamped to the grid. */
void pointgrid_cell(struct vec3 lo, double cell_mm, const int n[3], struct vec3 p, int ijk[3]);

/* An empty grid over box (non-empty) with cells of cell_mm (grown as by
 * pointgrid_dims to at most max_cells).  Release with pointgrid_fini().
 * 0 or ERR_NOMEM (g is then empty and fini-safe). */
int pointgrid_init(struct pointgrid *g, struct box3 box, double cell_mm, size_t max_cells,
		   struct err *e);
void pointgrid_fini(struct pointgrid *g);
/* Append p (index g->np before the call).  0, ERR_NOMEM or ERR_LIMIT
 * (INT32_MAX points). */
int pointgrid_insert(struct pointgrid *g, struct vec3 p, struct err *e);
/* 1 when no point q has |q - p| < d_mm (strict), else 0.  Reads the
 * (2 ceil(d / cell) + 1)^3 cells around p's cell. */
int pointgrid_far_from_all(const struct pointgrid *g, struct vec3 p, double d_mm);
/* fn(ctx, q) for every point q (index) of the cells that any point within
 * d_mm of p falls in (a superset of the points within d_mm), in a fixed
 * order; stops at the first nonzero return and returns it, else 0. */
int pointgrid_visit(const struct pointgrid *g, struct vec3 p, double d_mm,
		    int (*fn)(void *ctx, int32_t q), void *ctx);

#endif
