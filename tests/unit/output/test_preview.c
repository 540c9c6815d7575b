/* test_preview.c - out_layer_png(): resin archives give back the stored
 * layer PNG byte for byte (SL1 "<jobDir>NNNNN.png" names, also with a
 * jobDir ending in digits; zip "N.png" from 1; thumbnails and other
 * entries are not layers), and a G-code layer is drawn with its beads in
 * their role's colour at the documented view (bounds of every layer's
 * extrusions, 8 px margin, longer side 1024 px), honouring G91, M82 and
 * G92; out-of-range layers, mesh formats and missing files fail.
 */
#include <png.h>

#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/output/output.h"
#include "engine/output/resin/resin.h"
#include "harness.h"
#include "sl1_fixture.h"

static int write_zip(const char *path, const char *const *names, int n)
{
	struct out_zip *z = NULL;
	struct sink s;
	struct err e;
	int fd, rc;

	if (fixture_open_file(path, &s, &fd))
		return -1;
	err_clear(&e);
	rc = out_zip_new(&s, 1700000000, &z, &e);
	for (int i = 0; !rc && i < n; i++) /* each entry's bytes are its own name */
		rc = out_zip_add(z, names[i], names[i], strlen(names[i]), &e);
	if (!rc)
		rc = out_zip_close(z, &e);
	out_zip_free(z);
	close(fd);
	return rc;
}

static void check_layer(const char *path, enum out_format f, int k, const char *want, int count)
{
	struct buf png;
	struct err e;
	int n = -1;

	buf_init(&png);
	err_clear(&e);
	CHECK_EQ_INT(out_layer_png(path, f, k, &png, &n, &e), 0);
	CHECK_EQ_INT(n, count);
	CHECK_EQ_INT(png.len, strlen(want));
	CHECK(png.len == strlen(want) && memcmp(png.data, want, png.len) == 0);
	buf_fini(&png);
}

static void test_resin_archives(void)
{
	static const char *const sl1[] = {"config.ini", "part700001.png", "part700000.png",
					  "thumbnail/thumbnail400x400.png", "prusaslicer.ini",
					  "part700002.png"};
	static const char *const zip[] = {"manifest.json", "1.png", "2.png", "10.png", "3.png",
					  "4.png", "5.png", "6.png", "7.png", "8.png", "9.png"};
	const char *p1 = fixture_path("preview.sl1"), *p2 = fixture_path("preview.zip");
	struct buf png;
	struct err e;
	int n = -1;

	REQUIRE(write_zip(p1, sl1, 6) == 0);
	REQUIRE(write_zip(p2, zip, 11) == 0);
	check_layer(p1, OUT_SL1, 0, "part700000.png", 3);
	check_layer(p1, OUT_SL1S, 2, "part700002.png", 3);
	check_layer(p2, OUT_ZIP, 0, "1.png", 10);
	check_layer(p2, OUT_ZIP, 9, "10.png", 10);
	buf_init(&png);
	err_clear(&e);
	CHECK_EQ_INT(out_layer_png(p1, OUT_SL1, 3, &png, &n, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(n, 3);
	CHECK(strstr(e.msg, "3 layers") != NULL);
	CHECK_EQ_INT(out_layer_png(p2, OUT_ZIP, -1, &png, &n, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(out_layer_png(p1, OUT_STL, 0, &png, &n, &e), ERR_UNSUPPORTED);
	CHECK_EQ_INT(out_layer_png("/nonexistent/x.sl1", OUT_SL1, 0, &png, &n, &e), ERR_IO);
	CHECK_EQ_INT(png.len, 0);
	buf_fini(&png);
	unlink(p1);
	unlink(p2);
}

/* RGBA pixels of a PNG (libpng's simplified reader); caller frees. */
static uint8_t *decode_rgba(const struct buf *png, int *w, int *h)
{
	png_image im;
	uint8_t *px;

	memset(&im, 0, sizeof im);
	im.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&im, png->data, png->len))
		return NULL;
	im.format = PNG_FORMAT_RGBA;
	px = malloc(PNG_IMAGE_SIZE(im));
	if (!px || !png_image_finish_read(&im, NULL, px, 0, NULL)) {
		free(px);
		png_image_free(&im);
		return NULL;
	}
	*w = (int)im.width;
	*h = (int)im.height;
	return px;
}

/* The documented view of the test file: extrusions span x, y in
 * [0, 10] mm, so 1008 px per 10 mm and an 8 px margin; y up. */
static const uint8_t *pixel_at(const uint8_t *px, int w, double x_mm, double y_mm)
{
	int u = (int)(8 + x_mm * 100.8), v = (int)(8 + (10 - y_mm) * 100.8);
	return px + ((size_t)v * (size_t)w + (size_t)u) * 4;
}

static int rgb_is(const uint8_t *p, int r, int g, int b)
{
	return p[0] == r && p[1] == g && p[2] == b;
}

static void test_gcode_drawing(void)
{
	static const char text[] =
		"G90\nM83\nG1 X0 Y0 F900\n;prime line, before any layer: not drawn\n"
		"G1 X-50 Y-50 E5\n"
		";LAYER_CHANGE\n;Z:0.2\n;TYPE:External perimeter\n;WIDTH:0.5\n"
		"G0 X0 Y0\nG1 X10 Y0 E1\nG1 X10 Y10 E1\nG0 X0 Y10\n"
		";BEFORE_LAYER_CHANGE\n;LAYER_CHANGE\n;Z:0.4\nG1 E-0.8 F2100\n"
		";TYPE:Internal infill\nG1 X0 Y0 E1\n"
		"G91\nG1 X5 Y0 E1\nG90\n"       /* relative XY: to (5, 0) */
		"M82\nG92 E10\nG1 X5 Y5 E11\n"  /* absolute E: extrudes 1 */
		"G1 X5 Y8 E10.5\n";             /* E goes down: a move, not a bead */
	const char *path = fixture_path("preview.gcode");
	const uint8_t ext[3] = {0xff, 0x7d, 0x38}, infill[3] = {0xb0, 0x30, 0x29};
	struct buf png;
	struct err e;
	uint8_t *px;
	FILE *f = fopen(path, "w");
	int n = -1, w = 0, h = 0;

	REQUIRE(f != NULL);
	fputs(text, f);
	fclose(f);
	buf_init(&png);
	err_clear(&e);
	REQUIRE_OK(out_layer_png(path, OUT_GCODE, 0, &png, &n, &e), &e);
	CHECK_EQ_INT(n, 2);
	px = decode_rgba(&png, &w, &h);
	REQUIRE(px != NULL);
	CHECK_EQ_INT(w, 1024);
	CHECK_EQ_INT(h, 1024);
	CHECK(rgb_is(pixel_at(px, w, 5, 0), ext[0], ext[1], ext[2]));
	CHECK(rgb_is(pixel_at(px, w, 10, 5), ext[0], ext[1], ext[2]));
	CHECK(rgb_is(pixel_at(px, w, 5, 5), 0x20, 0x20, 0x24));   /* inside: nothing */
	CHECK(rgb_is(pixel_at(px, w, 5, 10), 0x5a, 0x5a, 0x66));  /* the travel back */
	free(px);

	buf_reset(&png);
	REQUIRE_OK(out_layer_png(path, OUT_GCODE, 1, &png, &n, &e), &e);
	px = decode_rgba(&png, &w, &h);
	REQUIRE(px != NULL);
	CHECK_EQ_INT(w, 1024); /* the same view for every layer */
	CHECK(rgb_is(pixel_at(px, w, 0, 5), infill[0], infill[1], infill[2]));
	CHECK(rgb_is(pixel_at(px, w, 2.5, 0), infill[0], infill[1], infill[2]));  /* G91 */
	CHECK(rgb_is(pixel_at(px, w, 5, 2.5), infill[0], infill[1], infill[2]));  /* M82 */
	CHECK(rgb_is(pixel_at(px, w, 5, 6.5), 0x5a, 0x5a, 0x66));  /* E down: a travel */
	CHECK(rgb_is(pixel_at(px, w, 10, 5), 0x20, 0x20, 0x24));   /* layer 0 not drawn */
	free(px);

	CHECK_EQ_INT(out_layer_png(path, OUT_GCODE, 2, &png, &n, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(n, 2);
	buf_fini(&png);
	unlink(path);
}

int main(void)
{
	RUN(test_resin_archives);
	RUN(test_gcode_drawing);
	return harness_report();
}
