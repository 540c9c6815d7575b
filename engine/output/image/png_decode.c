/* png_decode.c - PNG to 8-bit gray through libpng's simplified API
 * (image.h). */
#include "engine/output/image/image.h"
#include "engine/core/err.h"
#include "engine/geom/raster.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <string.h>

/* Size check, (re)allocation and the pixel read of a begun image. */
static int finish_gray(png_image *pi, struct raster **img, struct err *e)
{
	pi->format = PNG_FORMAT_GRAY;
	if (pi->width < 1 || pi->height < 1 || pi->width > 65535 || pi->height > 65535) {
		int rc = ERR_SET(e, ERR_LIMIT, "PNG is %ux%u pixels (sides 1..65535)",
				 (unsigned)pi->width, (unsigned)pi->height);
		png_image_free(pi);
		return rc;
	}
	if (!*img || (*img)->w != (int)pi->width || (*img)->h != (int)pi->height) {
		raster_free(*img);
		*img = raster_new((int)pi->width, (int)pi->height);
		if (!*img) {
			png_image_free(pi);
			return ERR_SET(e, ERR_NOMEM, "out of memory for a %ux%u image",
				       (unsigned)pi->width, (unsigned)pi->height);
		}
	}
	if (!png_image_finish_read(pi, NULL, (*img)->px, (png_int_32)(*img)->stride, NULL)) {
		int rc = ERR_SET(e, ERR_PARSE, "%s", pi->message);
		png_image_free(pi);
		return rc;
	}
	return 0;
}

int out_png_decode_gray(const void *png, size_t len, struct raster **img, struct err *e)
{
	png_image pi;

	memset(&pi, 0, sizeof pi);
	pi.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&pi, png, len))
		return ERR_SET(e, ERR_PARSE, "%s", pi.message);
	return finish_gray(&pi, img, e);
}

int out_png_read_gray_file(const char *path, struct raster **img, struct err *e)
{
	png_image pi;
	FILE *f = fopen(path, "rb");
	int rc;

	if (!f)
		return ERR_SET(e, ERR_IO, "%s: %s", path, strerror(errno));
	memset(&pi, 0, sizeof pi);
	pi.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_stdio(&pi, f)) {
		rc = ERR_SET(e, ERR_PARSE, "%s: %s", path, pi.message);
		fclose(f);
		return rc;
	}
	rc = finish_gray(&pi, img, e);
	if (rc)
		err_prefix(e, "%s", path);
	fclose(f);
	return rc;
}

int out_png_size(const void *png, size_t len, int *w, int *h, struct err *e)
{
	png_image pi;

	memset(&pi, 0, sizeof pi);
	pi.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&pi, png, len))
		return ERR_SET(e, ERR_PARSE, "%s", pi.message);
	*w = (int)pi.width;
	*h = (int)pi.height;
	png_image_free(&pi);
	return 0;
}
