/* thumbnail.h - preview images for printer UIs (SL1 thumbnail/thumbnailWxH.png,
 * G-code "; thumbnail begin" blocks).
 *
 * Rendered in software from the placed part: a fixed three-quarter view
 * from the front-right-top (orthographic), z-buffered triangles with
 * Lambert shading in resin orange on a transparent background, 2x2
 * supersampled, the part scaled to fill the image with a margin.
 * Without a mesh (lattice-file input) a struct thumb_acc collects a
 * coarse voxel grid (at most 128 cells along the part's longest side)
 * from the layers as they are written and renders its visible voxel
 * faces in the same view at the end.
 */
#ifndef INFILLD_THUMBNAIL_H
#define INFILLD_THUMBNAIL_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

/* The parts' colour in every thumbnail (Prusa Orange), as #RRGGBB text;
 * the G-code footer's filament_colour says the same, so host UIs agree. */
#define THUMBNAIL_COLOUR_HEX "#FF8040"

struct err;
struct buf;
struct mesh;
struct layer;
struct raster;
struct raster_map;

/* Render mesh (printer frame, mm) into an RGBA PNG of w x h (1..4096)
 * appended to png (caller-owned buffer).  O(triangles + w h).
 * 0, ERR_NOMEM or ERR_INTERNAL. */
int thumbnail_png_from_mesh(const struct mesh *m, int w, int h, struct buf *png, struct err *e);

/* Layer-based fallback. */
struct thumb_acc;
/* part_bbox: printer frame, mm (non-empty).  Caller frees with
 * thumb_acc_free(). */
int thumb_acc_new(struct box3 part_bbox, struct thumb_acc **out, struct err *e);

/* Whether a layer spanning [z_lo_mm, z_hi_mm) reaches any cell of the
 * grid (layers thinner than a cell are sampled: the one containing a
 * cell row's centre height stands for it). */
int thumb_acc_wants(const struct thumb_acc *t, double z_lo_mm, double z_hi_mm);
/* Bytes of a per-layer cell mask. */
size_t thumb_acc_mask_bytes(const struct thumb_acc *t);
/* Reduce a layer to a cell mask (mask: thumb_acc_mask_bytes bytes): from
 * its region when it has one, else from raster r (pixels >= 128 count
 * as material) through map.  Reads t only, so worker threads may reduce
 * different layers at once.  0 or ERR_NOMEM. */
int thumb_acc_reduce(const struct thumb_acc *t, const struct layer *ly, const struct raster *r,
		     const struct raster_map *map, uint8_t *mask, struct err *e);
/* Merge a reduced layer spanning [z_lo_mm, z_hi_mm) (one thread). */
void thumb_acc_merge(struct thumb_acc *t, double z_lo_mm, double z_hi_mm, const uint8_t *mask);
/* Reduce and merge ly (its raster, if any, through map) in one call. */
int thumb_acc_layer(struct thumb_acc *t, const struct layer *ly, const struct raster_map *map,
		    struct err *e);
int thumb_acc_png(const struct thumb_acc *t, int w, int h, struct buf *png, struct err *e);
void thumb_acc_free(struct thumb_acc *t);

#endif
