/* image.h - the images of engine/output/image/: PNG decoding (layer
 * archives read back), PNG encoding of layer images and thumbnails, and
 * the part's thumbnail renderer; one section per file below. */
#ifndef INFILLD_OUTPUT_IMAGE_H
#define INFILLD_OUTPUT_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/core/sink.h"
#include "engine/geom/raster.h"
#include "engine/geom/vec.h"

/* ---- png_decode.c: PNG images read back as 8-bit gray rasters.
 *
 * libpng's simplified API converts any PNG (gray, palette, RGB(A), 16-bit)
 * to 8-bit gray (RGB by its luminance, alpha composited onto black).
 * Users: the layer verifier (engine/verify, layers from archives) and the
 * hybrid engine's muscle-fibre template images (engine/hybrid/mfs.c).
 */
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

/* ---- png_encode.c: PNG encoders for layer images and thumbnails.
 *
 * Layer images (8-bit gray, filter "none") are mostly long runs of one
 * value, so out_png_gray() compresses them with its own run-length
 * deflate coder (matches at distance 1, dynamic Huffman codes: the
 * scheme of zlib's Z_RLE strategy) that walks runs 8 bytes at a time
 * instead of bytes, and measures the image (coverage, dirty box) in the
 * same pass.  libpng writes the container (signature, IHDR, chunk CRCs).
 * Thumbnails go through libpng and zlib unchanged.  Design and figures:
 * docs/formats.md.
 */

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

/* ---- thumbnail.c: preview images for printer UIs (SL1 thumbnail/thumbnailWxH.png,
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
/* The parts' colour in every thumbnail (Prusa Orange), as #RRGGBB text;
 * the G-code footer's filament_colour says the same, so host UIs agree. */
#define THUMBNAIL_COLOUR_HEX "#FF8040"

struct buf;
struct mesh;
struct layer;
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
