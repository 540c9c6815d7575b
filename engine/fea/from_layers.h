/* from_layers.h - the voxel model of a printed layer stack (resin images),
 * so a written archive can be analysed under the same load case as the
 * mesh it came from (`infilld fea ARCHIVE`, docs/fea_cli.md).
 *
 * A voxel's density is the material volume inside it over its volume
 * (h_mm^3): every pixel contributes value / 255 times the part of its
 * footprint (pixel rectangle in mm, through the stack's raster_map) and
 * of its layer's height that falls inside the voxel, so pixels and layers
 * straddling voxel faces are split exactly.  Two passes over the images:
 * fea_layers_box() (the part's extent from its lit pixels), then an
 * accumulator over a grid of that extent padded by one voxel, fed slab
 * by slab so that slabs can be filled in parallel.
 */
#ifndef INFILLD_FEA_FROM_LAYERS_H
#define INFILLD_FEA_FROM_LAYERS_H

#include <stddef.h>

#include "engine/fea/fea.h"
#include "engine/geom/raster.h"
#include "engine/geom/vec.h"

/* Voxels holding less material than this fraction are left out (rho 0):
 * a faint anti-aliased pixel would add unknowns and no stiffness. */
#define FEA_LAYERS_MIN_FRACTION FEA_RHO_MIN

struct fea_layers_geom {
	struct raster_map map; /* printer mm -> pixel; its axes must be the
				  printer's (90-degree turns and mirrors) */
	int width, height;     /* pixels of every layer */
	double layer_mm;       /* layer k spans z = [k, k+1) * layer_mm */
};

/* 0 when geo's map is usable (axis-aligned, non-singular) and layer_mm
 * > 0, else ERR_PARSE / ERR_UNSUPPORTED saying why. */
int fea_layers_check(const struct fea_layers_geom *geo, struct err *e);

/* Extend *box (printer frame, mm; start from box3_empty()) by the pixel
 * rectangles of layer k's lit pixels (value > 0) between z = k and k + 1
 * layers.  O(w * h). */
void fea_layers_box(const struct fea_layers_geom *geo, int k, const struct raster *img,
		    struct box3 *box);

struct fea_layers;

/* An accumulator for the grid of edge h_mm over part (non-empty box,
 * from fea_layers_box), padded by one voxel on every side.  ERR_LIMIT
 * (field fea_voxel_mm) when the grid has more than max_elements voxels,
 * ERR_NOMEM.  Caller frees with fea_layers_free(). */
int fea_layers_new(const struct fea_layers_geom *geo, const struct box3 *part, double h_mm,
		   size_t max_elements, struct fea_layers **out, struct err *e);
/* Voxel layers (slabs along z) of the grid, and the layers [*k0, *k1)
 * that reach slab iz. */
int fea_layers_slabs(const struct fea_layers *acc);
void fea_layers_slab_range(const struct fea_layers *acc, int iz, int *k0, int *k1);
/* Add what layer k holds inside voxel slab iz (iz < 0: in every slab);
 * each (layer, slab) once, in any order.  Calls for distinct slabs may
 * run on several threads at once (each writes only its slab).
 * O(lit pixels in the grid's footprint) after a scan of the footprint. */
int fea_layers_add(struct fea_layers *acc, int k, int iz, const struct raster *img,
		   struct err *e);
/* The model: g's rho (allocated here, freed by fea_grid_fini), size,
 * lo_mm, h_mm, and part_lo/hi_mm = part.  The accumulator keeps nothing
 * of g.  ERR_NOMEM, or ERR_GEOMETRY when no voxel holds material. */
int fea_layers_finish(struct fea_layers *acc, struct fea_grid *g, struct err *e);
void fea_layers_free(struct fea_layers *acc);

#endif
