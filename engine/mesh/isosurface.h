/* isosurface.h - closed 2-manifold surfaces of sampled solids.
 *
 * Marching tetrahedra on a regular grid: every cube of 8 samples is split
 * into 6 tetrahedra around its main diagonal (the same split in every
 * cube, so neighbouring cubes agree on their shared faces), and the
 * surface is the level set {f = iso} of the piecewise-linear interpolant.
 * That level set of a continuous PL function at a value no sample takes
 * is a closed 2-manifold with no self-intersection; samples equal to iso
 * are treated as inside and crossing points are kept off the samples, so
 * the guarantee holds for every input.  Used by the hybrid engine's mesh
 * output (its voxel solid) and meant for every engine that designs on
 * voxels or layers.
 */
#ifndef INFILLD_MESH_ISOSURFACE_H
#define INFILLD_MESH_ISOSURFACE_H

#include <stddef.h>

#include "engine/geom/vec.h"

struct err;
struct mesh;

/* field[(k * ny + j) * nx + i] is the sample at lo + (i sx, j sy, k sz)
 * (mm); inside is f >= iso (NaN is outside); samples beyond the grid count
 * as outside, so the surface closes (an edge from an inside sample to one
 * beyond the grid crosses at its midpoint, half a step out).  *out: a new
 * welded mesh (shared vertices, every edge in exactly two triangles, CCW
 * seen from outside; empty when no sample is inside), caller frees
 * (mesh_free).  Memory besides the output: about 42 bytes per sample of
 * one (nx + 2) x (ny + 2) plane, whatever nz.  max_triangles caps the
 * output (ERR_LIMIT).  0, ERR_PARAM (sizes, steps, NaN iso), ERR_LIMIT,
 * ERR_NOMEM. */
int mesh_isosurface(const float *field, int nx, int ny, int nz, struct vec3 lo_mm,
		    struct vec3 step_mm, float iso, size_t max_triangles, struct mesh **out,
		    struct err *e);

#endif
