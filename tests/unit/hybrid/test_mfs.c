/* test_mfs.c - the muscle-fibre section (hybrid.h, mfs.c).
 *
 * Voronoi: hy_mfs_solid against a brute-force distance to the Voronoi
 * boundary over all sites; sites are void and nearest-neighbour midpoints
 * wall; the wall fraction against a hexagonal tiling of the measured
 * site density; walls close every cell (each void component of a
 * rendered window holds one site); extrusion along a tilted axis; solid
 * beyond the square; determinism.  Template: a PNG
 * written by engine/output/image (gray and RGBA) read back pixel for
 * pixel and tiled; thin walls thickened to the wall width, thick ones
 * untouched, across the tile's seam; bad files.
 */
#include "harness.h"

#include <math.h>
#include <time.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"
#include "engine/geom/raster.h"
#include "engine/hybrid/structure.h"
#include "engine/output/image/image.h"

static uint64_t rng = 0x853c49e6748fea9bULL;
static double uni(void)
{
	return (double)(harness_xorshift64(&rng) >> 11) / 9007199254740992.0;
}

/* Plane point (u, v) (absolute plane coordinates) lifted to 3D at height t
 * along the axis. */
static struct vec3 lift(const struct hy_mfs *f, struct vec3 axis, double u, double v, double t)
{
	struct vec3 e1, e2;

	hy_mfs_basis(f, &e1, &e2);
	return v3_add(v3_add(v3_scale(e1, u), v3_scale(e2, v)), v3_scale(v3_normalize(axis), t));
}

/* Brute force: signed margin of the wall test at plane point (u, v)
 * (relative to the square's corner): min_j bisector distance - wall / 2. */
static double brute_margin(const double *s, size_t n, double u, double v, double wall)
{
	size_t b = 0;
	double d1 = INFINITY, m = INFINITY;

	for (size_t i = 0; i < n; i++) {
		double d = hypot(s[2 * i] - u, s[2 * i + 1] - v);
		if (d < d1) {
			d1 = d;
			b = i;
		}
	}
	for (size_t i = 0; i < n; i++) {
		double dj, sep;
		if (i == b)
			continue;
		dj = hypot(s[2 * i] - u, s[2 * i + 1] - v);
		sep = hypot(s[2 * i] - s[2 * b], s[2 * i + 1] - s[2 * b + 1]);
		m = fmin(m, (dj * dj - d1 * d1) / (2 * sep));
	}
	return m - wall / 2;
}

static void test_voronoi_brute(void)
{
	struct vec3 axis = v3(0, 0, 1), origin = v3(3, -2, 7);
	const double ext = 20, cell = 2, wall = 0.3;
	struct hy_mfs *f = NULL;
	const double *s;
	size_t n, bad = 0, walls = 0;
	double ulo, vlo;
	struct err e;

	REQUIRE_OK(hy_mfs_new_voronoi(axis, origin, ext, cell, wall, 5, &f, &e), &e);
	s = hy_mfs_sites(f, &n, &ulo, &vlo);
	CHECK_NEAR(ulo, 3 - ext, 1e-12);
	CHECK_NEAR(vlo, -2 - ext, 1e-12);
	CHECK_INT(n, >, 300);
	for (int k = 0; k < 30000; k++) {
		double u = 2 * ext * uni(), v = 2 * ext * uni(), m = brute_margin(s, n, u, v, wall);
		int solid = hy_mfs_solid(f, lift(f, axis, ulo + u, vlo + v, 10 * uni() - 5));
		walls += solid;
		if (fabs(m) > 1e-9 && solid != (m < 0))
			bad++;
	}
	CHECK_EQ_INT(bad, 0);
	CHECK_INT(walls, >, 1000);
	/* sites are void; the midpoint of a site and its nearest neighbour is
	 * on their Voronoi edge: wall */
	for (size_t i = 0; i < n; i++) {
		size_t b = i;
		double d = INFINITY;
		for (size_t j = 0; j < n; j++)
			if (j != i && hypot(s[2 * j] - s[2 * i], s[2 * j + 1] - s[2 * i + 1]) < d) {
				d = hypot(s[2 * j] - s[2 * i], s[2 * j + 1] - s[2 * i + 1]);
				b = j;
			}
		CHECK(!hy_mfs_solid(f, lift(f, axis, ulo + s[2 * i], vlo + s[2 * i + 1], 0)));
		CHECK(hy_mfs_solid(f, lift(f, axis, ulo + 0.5 * (s[2 * i] + s[2 * b]),
					   vlo + 0.5 * (s[2 * i + 1] + s[2 * b + 1]), 0)));
	}
	/* beyond the square: solid */
	CHECK(hy_mfs_solid(f, lift(f, axis, ulo - 0.01, vlo + ext, 0)));
	CHECK(hy_mfs_solid(f, lift(f, axis, ulo + ext, vlo + 2 * ext + 0.01, 0)));
	CHECK(hy_mfs_solid(f, v3(NAN, 0, 0)));
	hy_mfs_free(f);
}

/* 4-connected void components of img (w x h, 1 = wall): labels, -1 on
 * walls.  Returns the number of components. */
static int label_voids(const uint8_t *img, int w, int h, int *lab)
{
	int nc = 0;
	int *stack = malloc((size_t)w * h * sizeof *stack);

	for (int q = 0; q < w * h; q++)
		lab[q] = img[q] ? -1 : -2;
	for (int q0 = 0; q0 < w * h; q0++) {
		int sp = 0;
		if (lab[q0] != -2)
			continue;
		lab[q0] = nc;
		stack[sp++] = q0;
		while (sp) {
			int q = stack[--sp], x = q % w, y = q / w;
			int nb[4] = {x > 0 ? q - 1 : -1, x < w - 1 ? q + 1 : -1, y > 0 ? q - w : -1,
				     y < h - 1 ? q + w : -1};
			for (int k = 0; k < 4; k++)
				if (nb[k] >= 0 && lab[nb[k]] == -2) {
					lab[nb[k]] = nc;
					stack[sp++] = nb[k];
				}
		}
		nc++;
	}
	free(stack);
	return nc;
}

static void test_voronoi_pattern(void)
{
	struct vec3 axis = v3(0, 0, 1), origin = v3(0, 0, 0);
	const double ext = 25, cell = 2, wall = 0.3, px = 0.04, win = 16;
	const int W = (int)(2 * win / px);
	struct hy_mfs *f = NULL;
	uint8_t *img = malloc((size_t)W * W);
	int *lab = malloc((size_t)W * W * sizeof *lab);
	int *sites_in = NULL, *area = NULL, *touch = NULL, nc;
	size_t n, wall_px = 0, one_site = 0, multi = 0, empty_big = 0, inner_sites = 0;
	const double *s;
	double ulo, vlo, rho, expect, frac, t0, ns;
	struct err e;

	REQUIRE(img && lab);
	REQUIRE_OK(hy_mfs_new_voronoi(axis, origin, ext, cell, wall, 11, &f, &e), &e);
	s = hy_mfs_sites(f, &n, &ulo, &vlo);
	t0 = (double)clock();
	for (int j = 0; j < W; j++)
		for (int i = 0; i < W; i++) {
			uint8_t b = (uint8_t)hy_mfs_solid(f, v3(-win + (i + 0.5) * px,
								-win + (j + 0.5) * px, 1.5));
			img[(size_t)j * W + i] = b;
			wall_px += b;
		}
	ns = ((double)clock() - t0) / CLOCKS_PER_SEC * 1e9 / ((double)W * W);
	/* wall fraction against a hexagonal tiling of the same density: cells
	 * of area 1 / rho, apothem a = sqrt(1 / (2 sqrt 3 rho)), each shrunk
	 * by wall / 2: 1 - (1 - wall / (2 a))^2 (random cells have a little
	 * more edge than hexagons) */
	rho = (double)n / (4 * ext * ext);
	expect = 1 - pow(1 - wall / (2 * sqrt(1 / (2 * sqrt(3.0) * rho))), 2);
	frac = (double)wall_px / ((double)W * W);
	CHECK_NUM(frac / expect, >, 0.97);
	CHECK_NUM(frac / expect, <, 1.15);
	/* every void component inside the window holds one site */
	nc = label_voids(img, W, W, lab);
	sites_in = calloc((size_t)nc, sizeof *sites_in);
	area = calloc((size_t)nc, sizeof *area);
	touch = calloc((size_t)nc, sizeof *touch);
	for (int q = 0; q < W * W; q++)
		if (lab[q] >= 0) {
			int x = q % W, y = q / W;
			area[lab[q]]++;
			if (x == 0 || y == 0 || x == W - 1 || y == W - 1)
				touch[lab[q]] = 1;
		}
	for (size_t k = 0; k < n; k++) {
		double x = ulo + s[2 * k], y = vlo + s[2 * k + 1];
		int i = (int)floor((x + win) / px), j = (int)floor((y + win) / px);
		if (i < 0 || j < 0 || i >= W || j >= W)
			continue;
		REQUIRE(lab[j * W + i] >= 0);
		sites_in[lab[j * W + i]]++;
		if (fabs(x) < win - 2 * cell && fabs(y) < win - 2 * cell)
			inner_sites++;
	}
	for (int c = 0; c < nc; c++) {
		if (touch[c])
			continue;
		one_site += sites_in[c] == 1;
		multi += sites_in[c] > 1;
		empty_big += sites_in[c] == 0 && area[c] > 10;
	}
	CHECK_EQ_INT(multi, 0);
	CHECK_EQ_INT(empty_big, 0);
	CHECK_NUM(one_site, >=, inner_sites);
	fprintf(stderr,
		"voronoi: %zu sites (%.3f / cell^2), wall fraction %.4f vs hexagonal %.4f (x%.3f), "
		"%zu closed cells; hy_mfs_solid %.1f ns/call\n",
		n, rho * cell * cell, frac, expect, frac / expect, one_site, ns);
	free(sites_in);
	free(area);
	free(touch);
	free(img);
	free(lab);
	hy_mfs_free(f);
}

static void test_voronoi_axis_and_seed(void)
{
	struct vec3 axis = v3(1, 2, -0.5), origin = v3(10, 5, 2), e1, e2;
	struct hy_mfs *f = NULL, *g = NULL, *h = NULL;
	size_t same = 0, diff = 0;
	struct err e;

	REQUIRE_OK(hy_mfs_new_voronoi(axis, origin, 15, 1.5, 0.25, 9, &f, &e), &e);
	REQUIRE_OK(hy_mfs_new_voronoi(axis, origin, 15, 1.5, 0.25, 9, &g, &e), &e);
	REQUIRE_OK(hy_mfs_new_voronoi(axis, origin, 15, 1.5, 0.25, 10, &h, &e), &e);
	hy_mfs_basis(f, &e1, &e2);
	CHECK_NEAR(v3_len(e1), 1, 1e-12);
	CHECK_NEAR(v3_len(e2), 1, 1e-12);
	CHECK_NEAR(v3_dot(e1, e2), 0, 1e-12);
	CHECK_NEAR(v3_dot(e1, axis), 0, 1e-12);
	CHECK_NEAR(v3_dot(e2, axis), 0, 1e-12);
	for (int k = 0; k < 20000; k++) {
		double dx = 20 * uni() - 10, dy = 20 * uni() - 10, dz = 20 * uni() - 10;
		struct vec3 p = v3_add(origin, v3(dx, dy, dz));
		int a = hy_mfs_solid(f, p);
		/* extruded: constant along the axis */
		CHECK_EQ_INT(hy_mfs_solid(f, v3_madd(p, axis, 3 * uni() - 1.5)), a);
		CHECK_EQ_INT(hy_mfs_solid(g, p), a);
		same += hy_mfs_solid(h, p) == a;
		diff += hy_mfs_solid(h, p) != a;
	}
	CHECK_INT(diff, >, 1000); /* another seed, another pattern */
	hy_mfs_free(f);
	hy_mfs_free(g);
	hy_mfs_free(h);
	{
		/* axis z: the plane is x, y */
		REQUIRE_OK(hy_mfs_new_voronoi(v3(0, 0, 2), origin, 5, 1, 0.1, 1, &f, &e), &e);
		hy_mfs_basis(f, &e1, &e2);
		CHECK(e1.x == 1 && e1.y == 0 && e1.z == 0);
		CHECK(e2.x == 0 && e2.y == 1 && e2.z == 0);
		hy_mfs_free(f);
	}
	f = NULL;
	CHECK_EQ_INT(hy_mfs_new_voronoi(v3(0, 0, 0), origin, 5, 1, 0.1, 1, &f, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_mfs_new_voronoi(axis, origin, 5, 0, 0.1, 1, &f, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_mfs_new_voronoi(axis, origin, 5, 1, 1, 1, &f, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_mfs_new_voronoi(axis, origin, 0, 1, 0.1, 1, &f, &e), ERR_PARAM);
	CHECK_EQ_INT(hy_mfs_new_voronoi(axis, origin, 1e6, 0.01, 0.001, 1, &f, &e), ERR_LIMIT);
	CHECK(f == NULL);
	for (long k = 1; k < 12; k++) {
		int rc;
		mem_fail_after(k);
		rc = hy_mfs_new_voronoi(axis, origin, 10, 1, 0.1, 1, &f, &e);
		mem_fail_after(-1);
		CHECK(rc == 0 || rc == ERR_NOMEM);
		hy_mfs_free(rc == 0 ? f : NULL);
		f = NULL;
	}
	hy_mfs_free(NULL);
}

/* Write r as a PNG file at path (gray, or RGBA white/black when rgba). */
static int write_png(const struct raster *r, int rgba, const char *path)
{
	struct buf b;
	struct err e;
	FILE *fp;
	int rc;

	buf_init(&b);
	if (rgba) {
		uint8_t *px = malloc((size_t)r->w * r->h * 4);
		for (int y = 0; y < r->h; y++)
			for (int x = 0; x < r->w; x++) {
				uint8_t v = r->px[(size_t)y * r->stride + x];
				uint8_t *o = px + 4 * ((size_t)y * r->w + x);
				o[0] = o[1] = o[2] = v;
				o[3] = 255;
			}
		rc = out_png_rgba(px, r->w, r->h, &b, &e);
		free(px);
	} else {
		rc = out_png_gray(r, NULL, NULL, &b, NULL, &e);
	}
	if (rc == 0) {
		fp = fopen(path, "wb");
		rc = fp && fwrite(b.data, 1, b.len, fp) == b.len ? 0 : -1;
		if (fp)
			fclose(fp);
	}
	buf_fini(&b);
	return rc;
}

static void tmp_path(char *buf, size_t n, const char *tag)
{
	snprintf(buf, n, "/tmp/test_mfs_%ld_%s.png", (long)getpid(), tag);
}

/* Material at the centre of template pixel (i, row) of tile (ti, tj). */
static int tpx(const struct hy_mfs *f, struct vec3 axis, struct vec3 origin, double pitch,
	       int tw, int th, int i, int row, int ti, int tj)
{
	struct vec3 e1, e2;
	double u = (i + 0.5 + (double)ti * tw) * pitch, v = (th - 1 - row + 0.5 + (double)tj * th) *
							       pitch;

	hy_mfs_basis(f, &e1, &e2);
	return hy_mfs_solid(f, v3_add(origin, v3_add(v3_add(v3_scale(e1, u), v3_scale(e2, v)),
						      v3_scale(axis, 0.7))));
}

static void test_template_roundtrip(void)
{
	struct raster *r = raster_new(37, 23);
	struct vec3 axis = v3(0.3, -0.2, 0.9), origin = v3(-4, 6, 1);
	char path[256];
	struct err e;

	REQUIRE(r);
	axis = v3_normalize(axis);
	for (int y = 0; y < r->h; y++)
		for (int x = 0; x < r->w; x++)
			r->px[(size_t)y * r->stride + x] = (uint8_t)(uni() < 0.6 ? 200 + 55 * uni()
										  : 100 * uni());
	r->px[0] = 128; /* > 127: material */
	r->px[1] = 127; /* void */
	for (int rgba = 0; rgba < 2; rgba++) {
		struct hy_mfs *f = NULL;
		size_t bad = 0, n;
		double ulo, vlo;
		tmp_path(path, sizeof path, rgba ? "rgba" : "gray");
		REQUIRE(write_png(r, rgba, path) == 0);
		REQUIRE_OK(hy_mfs_new_template(axis, origin, path, 0.25, 0, &f, &e), &e);
		CHECK(hy_mfs_sites(f, &n, &ulo, &vlo) == NULL && n == 0);
		for (int tile = 0; tile < 3; tile++)
			for (int y = 0; y < r->h; y++)
				for (int x = 0; x < r->w; x++) {
					int want = r->px[(size_t)y * r->stride + x] > 127;
					int ti = tile == 0 ? 0 : tile == 1 ? 3 : -2;
					int tj = tile == 0 ? 0 : tile == 1 ? -1 : 5;
					int got = tpx(f, axis, origin, 0.25, r->w, r->h, x, y,
						      ti, tj);
					bad += got != want;
				}
		CHECK_EQ_INT(bad, 0);
		hy_mfs_free(f);
		unlink(path);
	}
	raster_free(r);
}

static void test_template_thicken(void)
{
	enum { TW = 60, TH = 40 };
	struct raster *r = raster_new(TW, TH);
	struct vec3 axis = v3(0, 0, 1), origin = v3(0, 0, 0);
	struct hy_mfs *f = NULL;
	char path[256];
	int col[TW];
	struct err e;

	REQUIRE(r);
	/* 1-px lines at columns 0 (the seam) and 10, a 2-px line at 20-21, a
	 * 12-px band at 35-46 */
	for (int y = 0; y < TH; y++)
		for (int x = 0; x < TW; x++)
			r->px[(size_t)y * r->stride + x] =
				(x == 0 || x == 10 || x == 20 || x == 21 || (x >= 35 && x <= 46))
					? 255
					: 0;
	tmp_path(path, sizeof path, "thick");
	REQUIRE(write_png(r, 0, path) == 0);
	/* wall 0.5 mm at 0.1 mm pixels: the 1-px lines become 5 px */
	REQUIRE_OK(hy_mfs_new_template(axis, origin, path, 0.1, 0.5, &f, &e), &e);
	for (int x = 0; x < TW; x++)
		col[x] = tpx(f, axis, origin, 0.1, TW, TH, x, TH / 2, 0, 0);
	for (int x = 0; x < TW; x++) {
		int want = (x >= 58 || x <= 2) || (x >= 8 && x <= 12) || (x >= 18 && x <= 23) ||
			   (x >= 35 && x <= 46);
		CHECK_EQ_INT(col[x], want);
	}
	/* every row alike */
	for (int y = 0; y < TH; y++)
		for (int x = 0; x < TW; x++)
			CHECK_EQ_INT(tpx(f, axis, origin, 0.1, TW, TH, x, y, 1, 1), col[x]);
	hy_mfs_free(f);
	f = NULL;
	/* a wall no wider than a pixel changes nothing */
	REQUIRE_OK(hy_mfs_new_template(axis, origin, path, 0.1, 0.1, &f, &e), &e);
	for (int x = 0; x < TW; x++)
		CHECK_EQ_INT(tpx(f, axis, origin, 0.1, TW, TH, x, 3, 0, 0),
			     r->px[(size_t)3 * r->stride + x] > 127);
	hy_mfs_free(f);
	f = NULL;
	/* bad inputs */
	CHECK_EQ_INT(hy_mfs_new_template(axis, origin, "/nonexistent/x.png", 0.1, 0.5, &f, &e),
		     ERR_IO);
	{
		FILE *fp = fopen(path, "wb");
		REQUIRE(fp);
		fputs("not a png", fp);
		fclose(fp);
	}
	CHECK_EQ_INT(hy_mfs_new_template(axis, origin, path, 0.1, 0.5, &f, &e), ERR_PARSE);
	CHECK_EQ_INT(hy_mfs_new_template(axis, origin, path, 0, 0.5, &f, &e), ERR_PARAM);
	CHECK(f == NULL);
	unlink(path);
	raster_free(r);
}

int main(void)
{
	RUN(test_voronoi_brute);
	RUN(test_voronoi_pattern);
	RUN(test_voronoi_axis_and_seed);
	RUN(test_template_roundtrip);
	RUN(test_template_thicken);
	return harness_report();
}
