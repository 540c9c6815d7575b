/* png_encode.h - internal: PNG encoders for layer images and thumbnails.
 *
 * Layer images (8-bit gray, filter "none") are mostly long runs of one
 * value, so out_png_gray() compresses them with its own run-length
 * deflate coder (matches at distance 1, dynamic Huffman codes: the
 * scheme of zlib's Z_RLE strategy) that walks runs 8 bytes at a time
 * instead of bytes, and measures the image (coverage, dirty box) in the
 * same pass.  libpng writes the container (signature, IHDR, chunk CRCs).
 * Thumbnails go through libpng and zlib unchanged.  Not included outside
 * engine/output/.  Design and figures: docs/formats.md.
 */
#ifndef INFILLD_PNG_ENCODE_H
#define INFILLD_PNG_ENCODE_H

#include <stdint.h>

#include "engine/core/sink.h"
#include "engine/geom/raster.h"

struct err;

/* A pixel rectangle, bounds inclusive; empty when x0 > x1 or y0 > y1. */
struct out_px_rect {
	int x0, y0, x1, y1;
};

/* What out_png_gray() measured. */
struct out_png_stats {
	uint64_t sum;          /* sum of pixel values (coverage * 255) */
	struct out_px_rect nz; /* bounding box of the nonzero pixels (empty if none) */
};

/* Working memory of out_png_gray() kept between calls by a caller that
 * encodes many images on one thread: zero-initialise; release with
 * out_png_scratch_fini().  About 128 KiB plus one compressed image. */
#define OUT_PNG_TOKENS 32768 /* deflate tokens per block */

struct out_png_scratch {
	uint32_t *tok;  /* OUT_PNG_TOKENS deflate tokens, NULL = allocated on use */
	struct buf idat; /* the zlib stream before it goes into its chunk */
};

void out_png_scratch_fini(struct out_png_scratch *s);

/* Append a PNG of r (8-bit gray, no interlace, filter 0 on every row) to
 * png.  content, if not NULL, promises that every pixel outside it is 0
 * (those rows and columns are not read).  scratch: reused working memory,
 * or NULL to allocate and free it here.  stats may be NULL.  O(runs +
 * pixels / 32) time.  0 or ERR_NOMEM / ERR_INTERNAL; on failure png->len
 * is unchanged. */
int out_png_gray(const struct raster *r, const struct out_px_rect *content,
		 struct out_png_scratch *scratch, struct buf *png, struct out_png_stats *stats,
		 struct err *e);

/* Append a PNG of an RGBA image (w * h * 4 bytes, rows top first, not
 * premultiplied) to png, through libpng/zlib.  0, ERR_NOMEM or
 * ERR_INTERNAL. */
int out_png_rgba(const uint8_t *rgba, int w, int h, struct buf *png, struct err *e);

#endif
