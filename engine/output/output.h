/* output.h - what printers consume: SL1/SL1S archives, PNG-stack zips,
 * G-code, and meshes.
 *
 * A writer receives layers in order 0..N-1 and streams its format to a
 * sink; memory is bounded by a few layers in flight, never by the layer
 * count (formatting in resin/sl1.c, gcode/gcode_write.c; toolpath planning
 * in toolpath/).  Writers may encode layers on worker threads (pipeline.h)
 * but write to the sink only from the caller's thread.
 */
#ifndef INFILLD_OUTPUT_H
#define INFILLD_OUTPUT_H

#include <stddef.h>
#include <time.h>

#include "engine/geom/raster.h"
#include "engine/geom/vec.h"
#include "engine/slice/layer.h"

struct err;
struct sink;
struct mesh;
struct metrics;
struct printer;

enum out_format { OUT_SL1, OUT_SL1S, OUT_ZIP, OUT_GCODE, OUT_STL, OUT_OBJ, OUT_FORMAT_COUNT };

/* "sl1" -> OUT_SL1 ...; ERR_PARAM (field "format") if unknown. */
int out_format_parse(const char *name, enum out_format *f, struct err *e);
/* From the output file's extension (.sl1 .sl1s .zip .gcode .stl .obj). */
int out_format_from_path(const char *path, enum out_format *f, struct err *e);
const char *out_format_name(enum out_format f);
const char *out_format_mime(enum out_format f);      /* Content-Type */
const char *out_format_extension(enum out_format f); /* ".sl1" */
int out_format_is_raster(enum out_format f);         /* sl1, sl1s, zip */
int out_format_is_mesh(enum out_format f);           /* stl, obj */
/* Profile used when the job names none: sl1, sl1s, sl1 (zip), generic-fdm. */
const char *out_format_default_printer(enum out_format f);
/* Can format f write layers of layer_mm (mm) for printer p, before any
 * work is done for them?  G-code: p's nozzle and line width must allow
 * that height (tp_config_check); other formats: 0.  0 or ERR_PARAM. */
int out_check_layers(enum out_format f, const struct printer *p, double layer_mm,
		     struct err *e);

/* Longest name out_job_dir() writes (without the NUL). */
#define OUT_JOB_DIR_MAX 40

/* The file-name-safe form of a job name (an uploaded mesh's name, a CLI
 * input's base name), used as the SL1 jobDir and so as every layer's
 * name prefix; other code naming files after a job may call it too.
 * A mesh-file extension (.stl .obj .off .ply .3mf .amf, any case) is
 * dropped; ASCII letters, digits, '-' and '_' are kept and anything else
 * (path separators, spaces, dots, bytes >= 0x80) becomes '_'; every
 * "thumbnail" in any case becomes "thumb" (keeping the case of the five
 * letters), repeated until none is left, because PrusaSlicer's SL1
 * importer skips every entry whose lower-cased name contains "thumbnail";
 * then at most OUT_JOB_DIR_MAX characters are kept; empty (or NULL) ->
 * "infilld"; a prefix of "thumbnail/" (the firmware takes every PNG whose
 * name starts with jobDir as a layer) gets a "job_" prefix.
 * out: OUT_JOB_DIR_MAX + 1 bytes, always NUL-terminated.  Pure. */
void out_job_dir(const char *job_name, char *out);

struct out_info {
	enum out_format format;
	const struct printer *printer; /* borrowed for the writer's life */
	int layer_count;
	double layer_mm;
	struct box3 part_bbox;         /* printer frame, mm */
	const struct mesh *mesh;       /* placed part for thumbnails; NULL = render
					  thumbnails from the layers */
	const char *job_name;          /* base name: jobDir, G-code comments */
	const char *engine_name;
	int threads;                   /* encoder threads, >= 1 */
	time_t created;                /* timestamp written into the output */
	const char *scratch_dir;       /* where a writer may put unlinked temporary
					  files (G-code body spool); NULL = /tmp */
};

struct out_writer;

/* Start a writer on sink s (borrowed).  Caller frees with out_free(). */
int out_open(const struct out_info *info, struct sink *s, struct out_writer **w,
	     struct err *e);

/* What the writer needs from each layer. */
int out_wants_raster(const struct out_writer *w);
int out_wants_region(const struct out_writer *w);

/* A zeroed raster of the printer's image size for the next layer (may
 * block until an in-flight layer frees one).  Ownership passes to the
 * caller, and back to the writer with out_layer(). */
int out_raster_get(struct out_writer *w, struct raster **r, struct err *e);
/* The pixel map of those rasters (printer mm -> pixels). */
const struct raster_map *out_raster_map(const struct out_writer *w);

/* Hand over layer ly (next in order).  The writer takes ownership of
 * ly->region and ly->raster (ly is left empty) and rasterises region
 * itself when the output wants pixels and !ly->raster_ready. */
int out_layer(struct out_writer *w, struct layer *ly, struct err *e);

/* Mesh formats (stl, obj; out_format_is_mesh): hand over the one result
 * mesh m (borrowed for the call, printer frame, mm) instead of layers.
 * Layer writers refuse it (ERR_INTERNAL), as mesh writers refuse layers. */
int out_mesh(struct out_writer *w, const struct mesh *m, struct err *e);

/* Flush everything, write trailers/manifests, and record the output's
 * figures in m: "material_volume_mm3" and a "<format>" object
 * (sl1: used_material_ml, print_time_s; gcode: filament_mm, print_time_s...;
 * stl/obj: result_mesh.triangles, result_mesh.watertight). */
int out_close(struct out_writer *w, struct metrics *m, struct err *e);
void out_free(struct out_writer *w);

struct buf;
/* Layer k (from 0) of the output file at path, written in format f, as a
 * PNG appended to png (the service's layer preview, docs/portal.md), and
 * the number of layers the file holds in *count.  Resin formats (sl1,
 * sl1s, zip) give the archive's own layer image, byte for byte; gcode
 * draws layer k's moves coloured by role (gcode/gcode_preview.h).
 * 0; ERR_NOTFOUND when the file has no layer k (*count set);
 * ERR_UNSUPPORTED for mesh formats (they have no layers); ERR_IO,
 * ERR_PARSE, ERR_LIMIT, ERR_NOMEM.  png->len is unchanged on failure. */
int out_layer_png(const char *path, enum out_format f, int k, struct buf *png, int *count,
		  struct err *e);

#endif
