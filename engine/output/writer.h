/* writer.h - internal: the per-format writer table behind output.h.
 *
 * output.c dispatches struct out_writer calls to one of these; each
 * format lives in its own files (sl1.c for sl1/sl1s/zip, gcode_write.c
 * for G-code, mesh_out.c for stl/obj).  Layer writers implement layer();
 * mesh writers implement mesh() and refuse layers.  Not included outside
 * engine/output/.
 */
#ifndef INFILLD_WRITER_H
#define INFILLD_WRITER_H

#include "engine/output/output.h"

struct writer_ops {
	const char *name;
	int wants_raster, wants_region;
	/* Start writing to s (borrowed).  *state freed by free_state. */
	int (*open)(const struct out_info *info, struct sink *s, void **state, struct err *e);
	/* Raster writers: zeroed image for the next layer (see output.h). */
	int (*raster_get)(void *state, struct raster **r, struct err *e);
	const struct raster_map *(*raster_map)(const void *state);
	/* Take ownership of ly's region and raster (layers arrive in order). */
	int (*layer)(void *state, struct layer *ly, struct err *e);
	/* Mesh writers: the result mesh m (borrowed for the call), once. */
	int (*mesh)(void *state, const struct mesh *m, struct err *e);
	int (*close)(void *state, struct metrics *m, struct err *e);
	void (*free_state)(void *state);
};

extern const struct writer_ops sl1_writer_ops;   /* OUT_SL1, OUT_SL1S (printerModel from profile) */
extern const struct writer_ops zip_writer_ops;   /* OUT_ZIP: 1.png ... N.png */
extern const struct writer_ops gcode_writer_ops; /* OUT_GCODE */
extern const struct writer_ops out_mesh_writer_ops;  /* OUT_STL (binary), OUT_OBJ */

#endif
