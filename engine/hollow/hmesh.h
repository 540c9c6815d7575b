/* hmesh.h - the hollow engine's mesh output (hmesh.c): the part's own
 * surface plus the closed surfaces of every void the layer output carves
 * (docs/hollow.md "Mesh output").
 */
#ifndef INFILLD_HOLLOW_HMESH_H
#define INFILLD_HOLLOW_HMESH_H

#include <stddef.h>

#include "engine/hollow/fill/fill.h"

struct hl_repair;
struct mesh;
struct err;

/* What the layers print, as one closed mesh.  res: the part (its first
 * part_nv vertices and part_nt triangles) followed by the optimised voids'
 * surfaces; fill: the top-down fill's void pixels, frag: beads painted
 * solid, mend: pixels carved (repair.h, carve 1: drawn by
 * hl_layer_draw_stepped; a mending of grey images does not belong here);
 * any may be empty, mend NULL; all on the pixels of fill->map, or of map
 * when fill has no grid.  layer_mm: print layers, layer k = slab
 * [k, k + 1] layer_mm.  Layer k's void is what hl_layer_draw_stepped and
 * the carving draw: the pixels whose centres the part covers and res does not
 * (the optimised voids), less frag's, plus fill's, then mend's set (void
 * where its gray is under VERIFY_THRESHOLD).  Its surface
 * (engine/mesh/layers.h: stepped at the pixel and the layer, closed, every
 * edge in two faces) is appended turned inward to the part's surface.
 * *out: a new mesh, caller frees; *void_triangles its share.  0,
 * ERR_NOMEM, ERR_LIMIT or a slicer error. */
int hl_mesh_build(const struct mesh *res, size_t part_nv, size_t part_nt,
		  const struct hl_fill *fill, const struct hl_fill *frag,
		  const struct hl_repair *mend, const struct raster_map *map, double layer_mm,
		  struct mesh **out, size_t *void_triangles, struct err *e);

#endif
