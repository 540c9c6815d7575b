/* fragments.h - beads the print layers split off the optimised voids
 * (fragments.c; docs/hollow.md "Fragments").
 */
#ifndef INFILLD_HOLLOW_FRAGMENTS_H
#define INFILLD_HOLLOW_FRAGMENTS_H

#include <stddef.h>

#include "engine/hollow/topdown.h"

struct mesh;
struct err;
struct raster_map;

/* The 3D components under min_mm3 of the optimised voids' pixels in the
 * print layers of out (the part's surface, then from vertex void_v0 and
 * triangle void_t0 on the void surfaces), each layer k (mid-plane
 * (k + 1/2) layer_mm) rasterised through map with antialias as the layer
 * pass does and read solid at >= threshold (the verifier's).  f (zeroed
 * or finished) gets them as runs: f->voids components, f->volume_mm3
 * their volume; empty without voids.  0, ERR_NOMEM, ERR_LIMIT or a slicer
 * error (f left empty). */
int hl_fragments_find(const struct mesh *out, size_t void_v0, size_t void_t0,
		      const struct raster_map *map, int antialias, int threshold, double layer_mm,
		      double min_mm3, struct hl_fill *f, struct err *e);

#endif
