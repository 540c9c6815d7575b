/* tetra.h - tetrahedral meshing with TetGen 1.5 (thin extern "C" shim).
 *
 * TetGen runs in a forked child process that sends its result back
 * through a pipe: Debian's TetGen 1.5.0 can crash (SIGSEGV) or call
 * exit() on bad input instead of throwing, and must never take the
 * worker down.  A crash, an exception or a bad result is an error
 * naming what happened.  Constrained meshing first runs TetGen's own
 * self-intersection check (-d) on the surface.  Design: docs/lattice.md
 * section 7 (the lattice engine is the main user).
 */
#ifndef INFILLD_TETRA_H
#define INFILLD_TETRA_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

struct err;
struct mesh;

struct tetra_mesh {
	double *xyz;   /* 3 * npoints coordinates (mm), owned */
	size_t npoints;
	uint32_t *tet; /* 4 * ntets point indices (positive orientation), owned */
	size_t ntets;
};

/* Release the arrays (the struct is caller storage); NULL-safe. */
void tetra_mesh_fini(struct tetra_mesh *t);

/* Delaunay tetrahedralisation of the convex hull of n points (xyz: 3n
 * doubles, mm).  Output points are the input points in order (TetGen
 * drops exact duplicates: their indices are then unused).  ERR_GEOMETRY
 * for fewer than 4 affinely independent points or a TetGen failure.
 * About 300k tets/s. */
int tetra_delaunay(const double *xyz, size_t n, struct tetra_mesh *out, struct err *e);

/* Number of pairs of intersecting faces TetGen finds in the closed
 * surface m (0 = none); ERR_GEOMETRY if the check itself failed. */
int tetra_self_intersections(const struct mesh *m, size_t *pairs, struct err *e);

struct tetra_opts {
	double radius_edge;   /* quality bound (-q), 0 = no refinement for quality */
	double max_volume;    /* mm^3 (-a), 0 = none */
	const double *sizing; /* per input vertex target edge length (mm) (-m), or NULL */
};

/* Quality tetrahedral mesh of the interior of the closed surface m (-p),
 * after the self-intersection check (an intersecting surface is an
 * ERR_GEOMETRY naming the number of face pairs, never a crash). */
int tetra_mesh_volume(const struct mesh *m, const struct tetra_opts *o, struct tetra_mesh *out,
		      struct err *e);

#ifdef __cplusplus
}
#endif

#endif
