/* gcode_preview.h - internal: a PNG drawing of one layer of a written
 * G-code file, its moves coloured by role (the layer preview of
 * out_layer_png(), engine/output/preview.c).  Not included outside
 * engine/output/.  Colours and limits: docs/portal.md.
 */
#ifndef INFILLD_GCODE_PREVIEW_H
#define INFILLD_GCODE_PREVIEW_H

#include "engine/core/sink.h"

struct err;

#define GCODE_PREVIEW_PX 1024       /* longer side of the drawing */
#define GCODE_PREVIEW_SEGS (1u << 20) /* moves of one layer drawn at most */

/* Append to png an RGBA PNG of layer k (0 = the first ";LAYER_CHANGE"
 * block) of the G-code file at path, and set *count to the number of
 * layers in the file.  The view is the top view (+x right, +y up) of the
 * extrusions of all layers, so every layer of a file is drawn at the same
 * scale and place; extrusions are drawn as beads of their ";WIDTH:" in
 * the colour of their ";TYPE:" role, travels as thin grey lines.  Reads
 * absolute XY (G90/G91 honoured), relative or absolute E (M83/M82, G92).
 * 0, ERR_NOTFOUND (no layer k; *count set), ERR_IO, ERR_LIMIT (layer k
 * has more than GCODE_PREVIEW_SEGS moves), ERR_NOMEM.  Streams the file
 * once; memory is layer k's moves and the image. */
int gcode_preview_layer(const char *path, int k, struct buf *png, int *count, struct err *e);

#endif
