/* output.c - output formats and the writer dispatch (see output.h). */
#include "engine/output/output.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/writer.h"
#include "engine/output/printer/printer.h"
#include "engine/output/toolpath/toolpath.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

struct format_desc {
	const char *name, *ext, *mime, *printer;
	int raster, mesh;
	const struct writer_ops *ops;
};

static const struct format_desc formats[OUT_FORMAT_COUNT] = {
	[OUT_SL1] = {"sl1", ".sl1", "application/vnd.prusa.sl1", "sl1", 1, 0, &sl1_writer_ops},
	[OUT_SL1S] = {"sl1s", ".sl1s", "application/vnd.prusa.sl1s", "sl1s", 1, 0, &sl1_writer_ops},
	[OUT_ZIP] = {"zip", ".zip", "application/zip", "sl1", 1, 0, &zip_writer_ops},
	[OUT_GCODE] = {"gcode", ".gcode", "text/x.gcode", "generic-fdm", 0, 0, &gcode_writer_ops},
	[OUT_STL] = {"stl", ".stl", "model/stl", NULL, 0, 1, &out_mesh_writer_ops},
	[OUT_OBJ] = {"obj", ".obj", "model/obj", NULL, 0, 1, &out_mesh_writer_ops},
};

int out_format_parse(const char *name, enum out_format *f, struct err *e)
{
	for (int i = 0; i < OUT_FORMAT_COUNT; i++) {
		if (name && strcmp(name, formats[i].name) == 0) {
			*f = (enum out_format)i;
			return 0;
		}
	}
	return ERR_FIELD(e, "format", "unknown format '%s' (known: sl1, sl1s, zip, gcode, stl, obj)",
			 name ? name : "");
}

int out_format_from_path(const char *path, enum out_format *f, struct err *e)
{
	const char *dot = path ? strrchr(path, '.') : NULL;

	for (int i = 0; dot && i < OUT_FORMAT_COUNT; i++) {
		if (strcasecmp(dot, formats[i].ext) == 0) {
			*f = (enum out_format)i;
			return 0;
		}
	}
	return ERR_FIELD(e, "format",
			 "cannot tell the format from '%s': use --format or an extension "
			 ".sl1, .sl1s, .zip, .gcode, .stl or .obj",
			 path ? path : "");
}

const char *out_format_name(enum out_format f)
{
	return f < OUT_FORMAT_COUNT ? formats[f].name : "?";
}
const char *out_format_mime(enum out_format f)
{
	return f < OUT_FORMAT_COUNT ? formats[f].mime : "application/octet-stream";
}
const char *out_format_extension(enum out_format f)
{
	return f < OUT_FORMAT_COUNT ? formats[f].ext : "";
}
int out_format_is_raster(enum out_format f)
{
	return f < OUT_FORMAT_COUNT && formats[f].raster;
}
int out_format_is_mesh(enum out_format f)
{
	return f < OUT_FORMAT_COUNT && formats[f].mesh;
}
const char *out_format_default_printer(enum out_format f)
{
	return f < OUT_FORMAT_COUNT ? formats[f].printer : NULL;
}
int out_check_layers(enum out_format f, const struct printer *p, double layer_mm,
		     struct err *e)
{
	if (f != OUT_GCODE || p->kind != PRINTER_FDM)
		return 0;
	return tp_config_check(&p->fdm, layer_mm, e);
}

struct out_writer {
	const struct writer_ops *ops;
	void *state;
};

int out_open(const struct out_info *info, struct sink *s, struct out_writer **out,
	     struct err *e)
{
	struct out_writer *w;
	int rc;

	if (info->format >= OUT_FORMAT_COUNT || !formats[info->format].ops)
		return ERR_SET(e, ERR_UNSUPPORTED, "unknown output format %d", (int)info->format);
	w = mem_calloc(1, sizeof *w);
	if (!w)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the %s writer",
			       out_format_name(info->format));
	w->ops = formats[info->format].ops;
	rc = w->ops->open(info, s, &w->state, e);
	if (rc) {
		mem_free(w);
		return rc;
	}
	*out = w;
	return 0;
}

int out_wants_raster(const struct out_writer *w)
{
	return w->ops->wants_raster;
}

int out_wants_region(const struct out_writer *w)
{
	return w->ops->wants_region;
}

int out_raster_get(struct out_writer *w, struct raster **r, struct err *e)
{
	if (!w->ops->raster_get)
		return ERR_SET(e, ERR_INTERNAL, "the %s writer takes no rasters", w->ops->name);
	return w->ops->raster_get(w->state, r, e);
}

const struct raster_map *out_raster_map(const struct out_writer *w)
{
	return w->ops->raster_map ? w->ops->raster_map(w->state) : NULL;
}

int out_layer(struct out_writer *w, struct layer *ly, struct err *e)
{
	return w->ops->layer(w->state, ly, e);
}

int out_mesh(struct out_writer *w, const struct mesh *m, struct err *e)
{
	if (!w->ops->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the %s writer takes layers, not a mesh",
			       w->ops->name);
	return w->ops->mesh(w->state, m, e);
}

int out_close(struct out_writer *w, struct metrics *m, struct err *e)
{
	return w->ops->close(w->state, m, e);
}

void out_free(struct out_writer *w)
{
	if (!w)
		return;
	if (w->ops->free_state)
		w->ops->free_state(w->state);
	mem_free(w);
}

/* Length of name without a trailing mesh-file extension. */
static size_t stem_length(const char *name)
{
	static const char *const ext[] = {".stl", ".obj", ".off", ".ply", ".3mf", ".amf"};
	size_t n = strlen(name);

	for (size_t i = 0; i < sizeof ext / sizeof ext[0]; i++) {
		size_t k = strlen(ext[i]);
		if (n > k && strcasecmp(name + n - k, ext[i]) == 0)
			return n - k;
	}
	return n;
}

/* First case-insensitive occurrence of "thumbnail" in s, or NULL. */
static char *find_thumbnail(char *s)
{
	for (; *s; s++)
		if (strncasecmp(s, "thumbnail", 9) == 0)
			return s;
	return NULL;
}

/* Stems longer than this are cut before the "thumbnail" rewrite; the
 * result keeps only OUT_JOB_DIR_MAX of them anyway. */
#define JOB_STEM_MAX 255

void out_job_dir(const char *job_name, char *out)
{
	static const char thumb[] = "thumbnail/";
	const char *p = job_name ? job_name : "";
	char s[JOB_STEM_MAX + 1];
	size_t n = 0, len = stem_length(p);
	char *hit;

	for (size_t i = 0; i < len && n < JOB_STEM_MAX; i++) {
		unsigned char c = (unsigned char)p[i];
		s[n++] = (isalnum(c) && c < 0x80) || c == '-' || c == '_' ? (char)c : '_';
	}
	s[n] = '\0';
	/* each rewrite shortens s by 4, so the loop ends; it repeats because
	 * dropping "nail" can join a new "thumbnail" ("thumbnailnail") */
	while ((hit = find_thumbnail(s)) != NULL) {
		memmove(hit + 5, hit + 9, strlen(hit + 9) + 1);
		n -= 4;
	}
	if (n > OUT_JOB_DIR_MAX)
		n = OUT_JOB_DIR_MAX;
	s[n] = '\0';
	if (n == 0)
		snprintf(out, OUT_JOB_DIR_MAX + 1, "infilld");
	else if (strncmp(thumb, s, n) == 0)
		snprintf(out, OUT_JOB_DIR_MAX + 1, "job_%s", s);
	else
		memcpy(out, s, n + 1);
}
