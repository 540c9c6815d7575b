/* layers.h - closed surfaces of layer stacks: the boundary of a stack of
 * binary pixel masks (layer k's pixels extruded over its slab), stepped at
 * the pixel and the layer, with vertices split where pixels touch only
 * along an edge or at a corner so every edge lies in exactly two faces.
 * Used by the hollow engine's mesh output (its void stack); design and
 * figures: docs/mesh.md "Layer stacks".
 */
#ifndef INFILLD_MESH_LAYERS_H
#define INFILLD_MESH_LAYERS_H

#include <stddef.h>
#include <stdint.h>

struct err;
struct mesh;

/* The stack's frame.  Lattice point (I, J) (pixel corners, 0 <= I <= nx,
 * 0 <= J <= ny) sits at mm (o[0] + m[0][0] I + m[0][1] J, o[1] + m[1][0] I
 * + m[1][1] J); pixel (i, j) is the cell between lattice points (i, j) and
 * (i + 1, j + 1).  m must be invertible; a mirroring m (det < 0) is
 * allowed (faces are turned to stay outward).  Layer k fills the slab
 * z0_mm + [k, k + 1] layer_mm. */
struct mesh_layers_grid {
	int nx, ny, nz;  /* pixels per row, rows, layers; each 1..65535 */
	double o[2];     /* mm */
	double m[2][2];  /* mm per lattice step */
	double z0_mm, layer_mm;
	double nudge_mm; /* split vertices move this far into their own side
			    (0: MESH_LAYERS_NUDGE_MM) so copies stay apart in
			    float32 files */
};

#define MESH_LAYERS_NUDGE_MM 2e-4

/* Mask source: fill mask[j * nx + i] (nx * ny bytes, nonzero = inside) for
 * layer k; called once per layer in increasing k.  0 or a negative
 * err_code (passed on). */
struct mesh_layers_src {
	int (*layer)(void *ctx, int k, uint8_t *mask, struct err *e);
	void *ctx;
};

/* The boundary of the union of the inside voxels, outward (CCW seen from
 * outside), as a new welded mesh (caller frees with mesh_free; empty when
 * no pixel is inside).  Every face is one pixel side (two triangles); a
 * lattice point carries one vertex per sheet of the surface through it
 * (inside voxels that meet only along an edge or at a corner are kept
 * apart, 6-connectivity of the inside), the copies moved nudge_mm apart.
 * Signed volume = inside voxels x voxel volume, up to the nudges (about
 * nudge x pixel^2 per split vertex).  Streams: memory is 2 masks and 2
 * lattice planes besides the output.  max_triangles caps the output
 * (ERR_LIMIT).  0, ERR_PARAM, ERR_LIMIT, ERR_NOMEM or the source's error. */
int mesh_layers_surface(const struct mesh_layers_grid *g, const struct mesh_layers_src *src,
			size_t max_triangles, struct mesh **out, struct err *e);

#endif
