/* preview.c - out_layer_png(): one layer of a written output as an image,
 * by format family: resin archives hand back their stored layer PNG
 * (resin/sl1_read.c), G-code is read back and drawn
 * (gcode/gcode_preview.c).  Used by the service's layer route
 * (api/layers.c); described in docs/portal.md.
 */
#include "engine/output/output.h"

#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/output/gcode/gcode_preview.h"
#include "engine/output/resin/resin.h"

int out_layer_png(const char *path, enum out_format f, int k, struct buf *png, int *count,
		  struct err *e)
{
	switch (f) {
	case OUT_SL1:
	case OUT_SL1S:
		return sl1_read_layer(path, 1, k, png, count, e);
	case OUT_ZIP:
		return sl1_read_layer(path, 0, k, png, count, e);
	case OUT_GCODE:
		return gcode_preview_layer(path, k, png, count, e);
	default:
		return ERR_SET(e, ERR_UNSUPPORTED, "a %s output is a mesh and has no layers",
			       out_format_name(f));
	}
}
