/* poisson.h - Poisson-disk point sets: no two points closer than r_mm.
 *
 * The hash grid of accepted points (cells of r / sqrt(dim), so a cell
 * holds at most one point and a test reads a fixed neighbourhood) is the
 * one the lattice engine's graded 3D sampler (paper 000, tetbuild.c) is
 * built on; the 2D sampler here draws darts cell by cell until every cell
 * has failed `tries` times (a near-maximal sample), deterministic for a
 * seed.  Users: the lattice engine, the hybrid engine's muscle-fibre
 * sections and extended support columns (paper 003).
 */
#ifndef INFILLD_GEOM_POISSON_H
#define INFILLD_GEOM_POISSON_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Points (x, y) in the rectangle [x0, x1] x [y0, y1] (mm) where inside(ctx,
 * x, y) != 0 (inside NULL = the whole rectangle), pairwise at least r_mm
 * apart.  *xy: 2 * *n doubles, caller frees (free()).  max_points caps the
 * output (ERR_LIMIT beyond).  0, ERR_PARAM (r_mm not > 0, empty
 * rectangle), ERR_LIMIT, ERR_NOMEM. */
int poisson2_sample(double x0, double y0, double x1, double y1, double r_mm,
		    int (*inside)(void *ctx, double x, double y), void *ctx, uint64_t seed,
		    size_t max_points, double **xy, size_t *n, struct err *e);

#endif
