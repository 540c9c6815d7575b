/* poisson.h - Poisson-disk point sets: no two points closer than r_mm.
 *
 * Accepted points live in the shared hash grid (engine/geom/pointgrid.h,
 * the one the lattice engine's graded 3D sampler in tetbuild.c is built
 * on).  The 2D sampler here throws darts square by square (Ebeida et al.'s
 * maximal Poisson-disk sampling): squares of r / sqrt 2 (a square holds at
 * most one point and one point covers it), each given a few darts in a
 * seeded random order; squares still uncovered are split in four, covered
 * quarters dropped, and darts thrown again, for a few levels.  The result
 * is near-maximal: the farthest point of the region from every sample
 * measures 0.996 r in a rectangle and 1.05 r near a curved region
 * boundary; about 0.73 points per r^2 (tests/unit/geom/test_poisson.c).
 * Deterministic for a seed (engine/core/rng.h, one thread).  Users: the
 * hybrid engine's muscle-fibre sections and extended support columns
 * (paper 003).
 */
#ifndef INFILLD_GEOM_POISSON_H
#define INFILLD_GEOM_POISSON_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Points (x, y) in the rectangle [x0, x1] x [y0, y1] (mm) where inside(ctx,
 * x, y) != 0 (inside NULL = the whole rectangle), pairwise at least r_mm
 * apart, and near-maximal (every point of the region within about r_mm
 * of a sample; slivers along the region's boundary may be left a little
 * farther).  inside is called from this thread only, some 20 times per
 * (r / sqrt 2)-square of the rectangle (darts and probe points).  *xy: 2 *
 * *n doubles (x, y pairs), caller frees (mem_free() or free()); *n may be
 * 0.  max_points caps the output (ERR_LIMIT beyond).  Time O(area / r^2).
 * 0, ERR_PARAM (r_mm not > 0, empty or non-finite rectangle), ERR_LIMIT
 * (max_points, or more than 2^24 squares), ERR_NOMEM. */
int poisson2_sample(double x0, double y0, double x1, double y1, double r_mm,
		    int (*inside)(void *ctx, double x, double y), void *ctx, uint64_t seed,
		    size_t max_points, double **xy, size_t *n, struct err *e);

#endif
