/* thumbnail.h - preview images for printer UIs (SL1 thumbnail/thumbnailWxH.png,
 * G-code "; thumbnail begin" blocks).
 *
 * Rendered in software from the placed part: a fixed three-quarter view
 * from the front-right-top, z-buffered triangles with Lambert shading on
 * a transparent background, the part scaled to fill the image with a
 * margin.  Without a mesh (lattice-file input) a struct thumb_acc
 * collects a depth map from the layers as they are written and renders
 * the same view from it at the end.
 */
#ifndef INFILLD_THUMBNAIL_H
#define INFILLD_THUMBNAIL_H

#include "engine/geom/vec.h"

struct err;
struct buf;
struct mesh;
struct layer;
struct raster_map;

/* Render mesh (printer frame, mm) into an RGBA PNG of w x h appended to
 * png (caller-owned buffer).  0, ERR_NOMEM or ERR_INTERNAL. */
int thumbnail_png_from_mesh(const struct mesh *m, int w, int h, struct buf *png, struct err *e);

/* Layer-based fallback. */
struct thumb_acc;
int thumb_acc_new(struct box3 part_bbox, struct thumb_acc **out, struct err *e);
/* Add one layer's region (or raster through map when region is empty). */
int thumb_acc_layer(struct thumb_acc *t, const struct layer *ly, const struct raster_map *map,
		    struct err *e);
int thumb_acc_png(const struct thumb_acc *t, int w, int h, struct buf *png, struct err *e);
void thumb_acc_free(struct thumb_acc *t);

#endif
