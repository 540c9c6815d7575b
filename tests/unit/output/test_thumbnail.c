/* test_thumbnail.c - software-rendered previews, decoded with libpng.
 *
 * Invariants of the view rather than golden images: transparent
 * background, an opaque part filling the frame inside the margin, three
 * differently lit visible faces of a cube in resin orange, +x to the
 * right and +z up on screen, and the layer-based voxel rendering of a
 * box matching the mesh rendering's silhouette.
 */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"
#include "engine/geom/raster.h"
#include "engine/mesh/mesh.h"
#include "engine/output/image/image.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"
#include "harness.h"

#include <png.h>

/* Boxes as a triangle soup (outward, CCW seen from outside). */
struct soup {
	struct vec3 v[8 * 4];
	uint32_t t[36 * 4];
	struct mesh m;
};

static void add_box(struct soup *s, struct vec3 lo, struct vec3 hi)
{
	static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
					{2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
	uint32_t base = (uint32_t)s->m.nv;

	for (int k = 0; k < 8; k++)
		s->v[base + (uint32_t)k] = v3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y,
					      k & 4 ? hi.z : lo.z);
	for (int f = 0; f < 6; f++) {
		const int *q = faces[f];
		uint32_t *t = s->t + 3 * s->m.nt;
		t[0] = base + (uint32_t)q[0];
		t[1] = base + (uint32_t)q[1];
		t[2] = base + (uint32_t)q[2];
		t[3] = base + (uint32_t)q[0];
		t[4] = base + (uint32_t)q[2];
		t[5] = base + (uint32_t)q[3];
		s->m.nt += 2;
	}
	s->m.nv += 8;
}

static void soup_init(struct soup *s)
{
	memset(s, 0, sizeof *s);
	s->m.v = s->v;
	s->m.tri = s->t;
}

/* Decode an RGBA PNG into a malloc'ed buffer; NULL on failure. */
static uint8_t *decode(const struct buf *png, int w, int h)
{
	png_image img;
	uint8_t *px;

	memset(&img, 0, sizeof img);
	img.version = PNG_IMAGE_VERSION;
	if (!png_image_begin_read_from_memory(&img, png->data, png->len))
		return NULL;
	if ((int)img.width != w || (int)img.height != h || img.format != PNG_FORMAT_RGBA)
		return NULL;
	px = malloc((size_t)w * (size_t)h * 4);
	if (!png_image_finish_read(&img, NULL, px, 0, NULL)) {
		free(px);
		return NULL;
	}
	return px;
}

struct sil {
	int x0, y0, x1, y1; /* box of alpha > 0 */
	double cx, cy;      /* centroid of opaque pixels */
	long opaque;
};

static struct sil silhouette(const uint8_t *px, int w, int h)
{
	struct sil s = {w, h, -1, -1, 0, 0, 0};

	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			const uint8_t *p = px + 4 * ((size_t)y * (size_t)w + (size_t)x);
			if (p[3] == 0)
				continue;
			s.x0 = x < s.x0 ? x : s.x0;
			s.x1 = x > s.x1 ? x : s.x1;
			s.y0 = y < s.y0 ? y : s.y0;
			s.y1 = y > s.y1 ? y : s.y1;
			if (p[3] == 255) {
				s.cx += x;
				s.cy += y;
				s.opaque++;
			}
		}
	if (s.opaque) {
		s.cx /= (double)s.opaque;
		s.cy /= (double)s.opaque;
	}
	return s;
}

static void test_cube(void)
{
	struct soup s;
	struct buf png;
	struct err e;
	uint8_t *px;
	struct sil sil;
	const uint8_t *top, *left, *right;
	int w = 400, h = 400;

	soup_init(&s);
	add_box(&s, v3(50, 20, 0), v3(70, 40, 20));
	buf_init(&png);
	REQUIRE_OK(thumbnail_png_from_mesh(&s.m, w, h, &png, &e), &e);
	px = decode(&png, w, h);
	REQUIRE(px);
	sil = silhouette(px, w, h);
	/* transparent corners, opaque centre, the frame filled within the
	 * 6% margin along the limiting direction */
	CHECK_EQ_INT(px[3], 0);
	CHECK_EQ_INT(px[4 * ((size_t)h * w - 1) + 3], 0);
	CHECK_EQ_INT(px[4 * ((size_t)(h / 2) * w + w / 2) + 3], 255);
	CHECK(sil.x0 >= 0.05 * w && sil.x1 <= 0.95 * w && sil.y0 >= 0.05 * h && sil.y1 <= 0.95 * h);
	CHECK((sil.x1 - sil.x0) >= 0.85 * w || (sil.y1 - sil.y0) >= 0.85 * h);
	CHECK_NEAR(sil.cx, w / 2.0, 0.05 * w);
	/* three faces: the top (above the centre), the front-left (-y) and
	 * the front-right (+x) faces, lit differently, all orange */
	top = px + 4 * ((size_t)(sil.y0 + (h / 2 - sil.y0) / 3) * w + w / 2);
	left = px + 4 * ((size_t)(h / 2 + (sil.y1 - h / 2) / 2) * w + (w / 2 + sil.x0) / 2);
	right = px + 4 * ((size_t)(h / 2 + (sil.y1 - h / 2) / 2) * w + (w / 2 + sil.x1) / 2);
	CHECK_EQ_INT(top[3], 255);
	CHECK_EQ_INT(left[3], 255);
	CHECK_EQ_INT(right[3], 255);
	CHECK(top[0] != left[0] || top[1] != left[1]);
	CHECK(top[0] != right[0] || top[1] != right[1]);
	CHECK(left[0] != right[0] || left[1] != right[1]);
	CHECK(top[0] > top[1] && top[1] > top[2]);
	CHECK(left[0] > left[1] && left[1] > left[2]);
	free(px);
	buf_fini(&png);
}

/* Render m at w x h and measure its silhouette; 0 on success. */
static int render_silhouette(const struct mesh *m, int w, int h, struct sil *out)
{
	struct buf png;
	struct err e;
	uint8_t *px = NULL;

	buf_init(&png);
	if (thumbnail_png_from_mesh(m, w, h, &png, &e) == 0)
		px = decode(&png, w, h);
	buf_fini(&png);
	if (!px)
		return -1;
	*out = silhouette(px, w, h);
	free(px);
	return 0;
}

/* +x is to the right on screen, +z is up: two scenes with the same
 * bounding box (tiny markers), one cube at opposite corners. */
static void test_view_direction(void)
{
	struct soup a, b;
	struct sil sa, sb;
	int w = 300, h = 200;

	soup_init(&a);
	add_box(&a, v3(0, 0, 0), v3(10, 10, 10));
	add_box(&a, v3(39.9, 0, 0), v3(40, 0.1, 0.1));
	soup_init(&b);
	add_box(&b, v3(30, 0, 0), v3(40, 10, 10));
	add_box(&b, v3(0, 0, 0), v3(0.1, 0.1, 0.1));
	REQUIRE(render_silhouette(&a.m, w, h, &sa) == 0);
	REQUIRE(render_silhouette(&b.m, w, h, &sb) == 0);
	CHECK(sb.cx > sa.cx + 0.2 * w);

	soup_init(&a);
	add_box(&a, v3(0, 0, 0), v3(10, 10, 10));
	add_box(&a, v3(0, 0, 39.9), v3(0.1, 0.1, 40));
	soup_init(&b);
	add_box(&b, v3(0, 0, 30), v3(10, 10, 40));
	add_box(&b, v3(0, 0, 0), v3(0.1, 0.1, 0.1));
	REQUIRE(render_silhouette(&a.m, w, h, &sa) == 0);
	REQUIRE(render_silhouette(&b.m, w, h, &sb) == 0);
	CHECK(sb.cy < sa.cy - 0.2 * h);
}

/* The same box from 200 layers through the voxel accumulator: its
 * silhouette agrees with the mesh rendering's. */
static void test_layers_match_mesh(void)
{
	struct box3 box = {{50, 20, 0}, {70, 40, 10}};
	struct raster_map map = {{{10, 0}, {0, 10}}, {0, 0}}; /* 0.1 mm pixels */
	struct thumb_acc *acc;
	struct raster *r = raster_new(1000, 600);
	struct soup s;
	struct buf png;
	struct err e;
	uint8_t *pm, *pl;
	long both = 0, either = 0;
	int w = 800, h = 480, merged = 0;

	REQUIRE(r);
	for (int y = 200; y < 400; y++)
		memset(r->px + (size_t)y * r->stride + 500, 255, 200);
	REQUIRE_OK(thumb_acc_new(box, &acc, &e), &e);
	for (int k = 0; k < 200; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		ly.index = k;
		ly.height_mm = 0.05;
		ly.z_top_mm = (k + 1) * 0.05;
		ly.z_mm = ly.z_top_mm - 0.025;
		ly.raster = r;
		merged += thumb_acc_wants(acc, ly.z_top_mm - 0.05, ly.z_top_mm);
		REQUIRE_OK(thumb_acc_layer(acc, &ly, &map, &e), &e);
	}
	/* 20 mm / 128 cells: 64 cell rows over 10 mm, one layer each */
	CHECK_EQ_INT(merged, 64);
	buf_init(&png);
	REQUIRE_OK(thumb_acc_png(acc, w, h, &png, &e), &e);
	pl = decode(&png, w, h);
	REQUIRE(pl);
	soup_init(&s);
	add_box(&s, box.lo, box.hi);
	buf_reset(&png);
	REQUIRE_OK(thumbnail_png_from_mesh(&s.m, w, h, &png, &e), &e);
	pm = decode(&png, w, h);
	REQUIRE(pm);
	for (size_t i = 0; i < (size_t)w * h; i++) {
		int a = pm[4 * i + 3] > 127, b = pl[4 * i + 3] > 127;
		both += a && b;
		either += a || b;
	}
	CHECK(either > 0.2 * w * h);
	CHECK((double)both / (double)either > 0.97);
	free(pm);
	free(pl);
	buf_fini(&png);
	thumb_acc_free(acc);
	raster_free(r);
}

/* Layers given as regions (FDM jobs, engines without pixels) reduce to
 * the same grid as their rasters. */
static void test_region_layers(void)
{
	struct box3 box = {{50, 20, 0}, {70, 40, 10}};
	struct raster_map map = {{{10, 0}, {0, 10}}, {0, 0}};
	struct thumb_acc *from_region, *from_raster;
	struct raster *r = raster_new(1000, 600);
	struct pt2 sq[4] = {{geom_mm_to_nm(50), geom_mm_to_nm(20)},
			    {geom_mm_to_nm(70), geom_mm_to_nm(20)},
			    {geom_mm_to_nm(70), geom_mm_to_nm(40)},
			    {geom_mm_to_nm(50), geom_mm_to_nm(40)}};
	struct buf a, b;
	struct err e;

	REQUIRE(r);
	for (int y = 200; y < 400; y++)
		memset(r->px + (size_t)y * r->stride + 500, 255, 200);
	REQUIRE_OK(thumb_acc_new(box, &from_region, &e), &e);
	REQUIRE_OK(thumb_acc_new(box, &from_raster, &e), &e);
	for (int k = 0; k < 200; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		paths_init(&ly.region);
		ly.index = k;
		ly.height_mm = 0.05;
		ly.z_top_mm = (k + 1) * 0.05;
		REQUIRE(paths_add_pts(&ly.region, sq, 4) == 0);
		REQUIRE_OK(thumb_acc_layer(from_region, &ly, NULL, &e), &e);
		paths_fini(&ly.region);
		ly.raster = r;
		REQUIRE_OK(thumb_acc_layer(from_raster, &ly, &map, &e), &e);
	}
	buf_init(&a);
	buf_init(&b);
	REQUIRE_OK(thumb_acc_png(from_region, 200, 120, &a, &e), &e);
	REQUIRE_OK(thumb_acc_png(from_raster, 200, 120, &b, &e), &e);
	CHECK_EQ_INT(a.len, b.len);
	CHECK(a.len == b.len && memcmp(a.data, b.data, a.len) == 0);
	buf_fini(&a);
	buf_fini(&b);
	thumb_acc_free(from_region);
	thumb_acc_free(from_raster);
	raster_free(r);
}

static void test_degenerate_and_failures(void)
{
	struct soup s;
	struct buf png;
	struct err e;
	struct thumb_acc *acc;
	struct box3 empty = box3_empty();
	uint8_t *px;
	int ok = 0;

	soup_init(&s);
	buf_init(&png);
	/* no triangles: a transparent image */
	REQUIRE_OK(thumbnail_png_from_mesh(&s.m, 40, 30, &png, &e), &e);
	px = decode(&png, 40, 30);
	REQUIRE(px);
	CHECK_EQ_INT(silhouette(px, 40, 30).x1, -1);
	free(px);
	CHECK_EQ_INT(thumbnail_png_from_mesh(&s.m, 0, 30, &png, &e), ERR_INTERNAL);
	CHECK_EQ_INT(thumb_acc_new(empty, &acc, &e), ERR_INTERNAL);
	/* every allocation failing in turn */
	add_box(&s, v3(0, 0, 0), v3(1, 2, 3));
	for (long n = 1; n < 100 && !ok; n++) {
		int rc;
		buf_reset(&png);
		mem_fail_after(n);
		rc = thumbnail_png_from_mesh(&s.m, 64, 48, &png, &e);
		mem_fail_after(-1);
		if (rc == 0)
			ok = 1;
		else
			CHECK_EQ_INT(rc, ERR_NOMEM);
	}
	CHECK(ok);
	buf_fini(&png);
}

int main(void)
{
	RUN(test_cube);
	RUN(test_view_direction);
	RUN(test_layers_match_mesh);
	RUN(test_region_layers);
	RUN(test_degenerate_and_failures);
	return harness_report();
}
