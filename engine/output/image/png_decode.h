/* png_decode.h - PNG images read back as 8-bit gray rasters.
 *
 * libpng's simplified API converts any PNG (gray, palette, RGB(A), 16-bit)
 * to 8-bit gray (RGB by its luminance, alpha composited onto black).
 * Users: the layer verifier (engine/verify, layers from archives) and the
 * hybrid engine's muscle-fibre template images (engine/hybrid/mfs.c).
 */
#ifndef INFILLD_PNG_DECODE_H
#define INFILLD_PNG_DECODE_H

#include <stddef.h>

struct err;
struct raster;

/* Decode the PNG png[0..len) into *img (raster.h: row 0 the file's first
 * row; reallocated when absent or of another size, else overwritten;
 * caller frees with raster_free()).  Reentrant.  0, ERR_PARSE (libpng's
 * message), ERR_LIMIT (a side beyond 65535) or ERR_NOMEM; on failure *img
 * is still valid (raster_free-safe). */
int out_png_decode_gray(const void *png, size_t len, struct raster **img, struct err *e);
/* The same from the file at path; ERR_IO when it cannot be opened. */
int out_png_read_gray_file(const char *path, struct raster **img, struct err *e);
/* Width and height from the header alone.  0 or ERR_PARSE. */
int out_png_size(const void *png, size_t len, int *w, int *h, struct err *e);

#endif
