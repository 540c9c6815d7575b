/* test_topdown.c - the top-down support-free fill (engine/hollow/fill/
 * topdown.c, hl_fill_build) on boxes, every property re-measured here
 * from the fill's runs by brute force:
 *  - the wall: every void pixel centre (x, y) at a layer's mid-plane z
 *    keeps wall_mm from every face of the box;
 *  - the rule of docs/hollow.md 4.1: every pixel solid in layer k + 1 and
 *    void in layer k has a solid pixel centre of layer k within
 *    dg = layer_mm tan(alpha);
 *  - the volume: the pixel count x pixel area x layer, at most the box's
 *    interior (the box less the wall), at least 70 % of the continuous groin
 *    vault that interior admits at alpha - margin, centred on the box;
 *  - components: one void per box; min_void_mm3 between two boxes' voids
 *    keeps the larger one pixel for pixel and drops the smaller;
 *  - keep_set: no void pixel centre on the wrong side of the half-plane;
 *  - a rotated map builds nothing;
 *  - births of one layer: two voids of a layer keep wall_next between
 *    their pixels (a notched bar, two ridge pieces a pinch apart).
 * Grid: 0.05 mm pixels and 0.05 mm layers (the brief's SL1-like pitch);
 * pixel centres of image column u are at (u + 0.5 - B) PX mm (B = the
 * map's offset).  Frame: printer frame, mm, z up from the plate.
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"
#include "engine/hollow/fill/fill.h"
#include "engine/mesh/mesh.h"

#include "boxgen.h"
#include "unit/slice/meshgen.h"

#define PX 0.05
#define LAYER 0.05
#define B 10.0 /* map offset, pixels */
#define WALL 1.0
#define ALPHA_DEG 45.0
#define MARGIN_DEG 0.5

/* A part of nb boxes (lo[i], hi[i]); 0 when out of memory. */
static int boxes(struct mesh *m, const struct vec3 *lo, const struct vec3 *hi, int nb)
{
	m->v = mem_alloc((size_t)nb * 8 * sizeof *m->v);
	m->tri = mem_alloc((size_t)nb * 36 * sizeof *m->tri);
	m->nv = m->nt = 0;
	if (!m->v || !m->tri)
		return 0;
	for (int i = 0; i < nb; i++)
		add_box(m, lo[i], hi[i], 0);
	return 1;
}

static void params(struct hl_fill_params *p, double min_void_mm3)
{
	memset(p, 0, sizeof *p);
	p->wall_mm = WALL;
	p->wall_next_mm = 0.8;
	p->pixel_mm = PX;
	p->layer_mm = LAYER;
	p->alpha_rad = ALPHA_DEG * M_PI / 180;
	p->margin_rad = MARGIN_DEG * M_PI / 180;
	p->min_void_mm3 = min_void_mm3;
	p->lean = 1;
	p->corners = 1; /* the default (mitre_corners) */
	p->map.a[0][0] = 1 / PX;
	p->map.a[1][1] = 1 / PX;
	p->map.b[0] = B;
	p->map.b[1] = B;
}

/* Printer mm of grid pixel (x, y)'s centre. */
static double cx_mm(const struct hl_fill *f, int x)
{
	return (f->u0 + x + 0.5 - B) * PX;
}

static double cy_mm(const struct hl_fill *f, int y)
{
	return (f->v0 + y + 0.5 - B) * PX;
}

/* The fill as one byte per voxel (f->n layers of f->w x f->h, 1 = void),
 * checking on the way that runs are in the grid and row-major ordered.
 * NULL when out of memory. */
static uint8_t *voxels(const struct hl_fill *f, size_t *count)
{
	size_t np = (size_t)f->w * (size_t)f->h;
	uint8_t *v = mem_calloc(np * (size_t)f->n + 1, 1);

	*count = 0;
	if (!v)
		return NULL;
	for (int k = 0; k < f->n; k++)
		for (size_t i = 0; i < f->layer[k].n; i++) {
			const struct hl_span *r = &f->layer[k].run[i];
			int ok = r->y >= 0 && r->y < f->h && r->x0 >= 0 && r->x0 <= r->x1 &&
				 r->x1 < f->w;
			CHECK(ok);
			if (i > 0) {
				const struct hl_span *q = r - 1;
				CHECK(q->y < r->y || (q->y == r->y && q->x1 + 1 < r->x0));
			}
			if (!ok)
				continue;
			for (int x = r->x0; x <= r->x1; x++)
				v[(size_t)k * np + (size_t)r->y * (size_t)f->w + (size_t)x] = 1;
			*count += (size_t)(r->x1 - r->x0 + 1);
		}
	return v;
}

/* hl_fill_build of m under p into f, as voxels (voxels()); NULL (a
 * failed check) when the build fails or memory runs out. */
static uint8_t *built(const struct mesh *m, const struct hl_fill_params *p, struct hl_fill *f,
		      size_t *count)
{
	struct err e;
	int rc;

	err_clear(&e);
	memset(f, 0, sizeof *f);
	*count = 0;
	rc = hl_fill_build(m, NULL, p, NULL, 0, 1, f, &e);
	CHECK_EQ_INT(rc, 0);
	return rc ? NULL : voxels(f, count);
}

/* Is there a solid pixel centre of layer lo (f's grid; outside the grid
 * is outside the part: no support) within dg (mm) of pixel (x, y)? */
static int supported(const struct hl_fill *f, const uint8_t *lo, int x, int y, double dg)
{
	int r = (int)ceil(dg / PX) + 1;

	for (int yy = y - r; yy <= y + r; yy++)
		for (int xx = x - r; xx <= x + r; xx++) {
			if (xx < 0 || yy < 0 || xx >= f->w || yy >= f->h)
				continue;
			if (hypot((xx - x) * PX, (yy - y) * PX) <= dg &&
			    !lo[(size_t)yy * (size_t)f->w + (size_t)xx])
				return 1;
		}
	return 0;
}

/* The rule of docs/hollow.md 4.1 by brute force: pixels that break it
 * (solid in k + 1, void in k, no solid centre of layer k within dg);
 * *front (may be NULL): the pixels the rule applied to. */
static size_t rule_breaks(const struct hl_fill *f, const uint8_t *v, double dg, size_t *front)
{
	size_t np = (size_t)f->w * (size_t)f->h, bad = 0, nf = 0;

	for (int k = 0; k + 1 < f->n; k++) {
		const uint8_t *lo = v + (size_t)k * np, *up = v + (size_t)(k + 1) * np;
		for (int y = 0; y < f->h; y++)
			for (int x = 0; x < f->w; x++) {
				size_t i = (size_t)y * (size_t)f->w + (size_t)x;
				if (!lo[i] || up[i])
					continue;
				bad += !supported(f, lo, x, y, dg);
				nf++;
			}
	}
	if (front)
		*front = nf;
	return bad;
}

/* 3D components of the voxels (4-connected in a layer, the same pixel
 * in the layers above and below: the verifier's connectivity), labelled
 * into lab (1..; 0 = solid); returns their count, volumes (mm^3) in
 * vol[0..min(count, nvol)). */
static int components(const struct hl_fill *f, const uint8_t *v, int32_t *lab, double *vol,
		      int nvol)
{
	size_t np = (size_t)f->w * (size_t)f->h, nvox = np * (size_t)f->n;
	size_t *st = mem_alloc((nvox + 1) * sizeof *st);
	int nc = 0;

	if (!st)
		return -1;
	memset(lab, 0, nvox * sizeof *lab);
	for (size_t s = 0; s < nvox; s++) {
		size_t n = 0;
		if (!v[s] || lab[s])
			continue;
		nc++;
		if (nc <= nvol)
			vol[nc - 1] = 0;
		lab[s] = nc;
		st[n++] = s;
		while (n) {
			size_t i = st[--n], k = i / np, p = i % np;
			int x = (int)(p % (size_t)f->w), y = (int)(p / (size_t)f->w);
			size_t nb[6];
			int m = 0;
			if (nc <= nvol)
				vol[nc - 1] += PX * PX * LAYER;
			if (x > 0)
				nb[m++] = i - 1;
			if (x + 1 < f->w)
				nb[m++] = i + 1;
			if (y > 0)
				nb[m++] = i - (size_t)f->w;
			if (y + 1 < f->h)
				nb[m++] = i + (size_t)f->w;
			if (k > 0)
				nb[m++] = i - np;
			if (k + 1 < (size_t)f->n)
				nb[m++] = i + np;
			for (int q = 0; q < m; q++)
				if (v[nb[q]] && !lab[nb[q]]) {
					lab[nb[q]] = nc;
					st[n++] = nb[q];
				}
		}
	}
	mem_free(st);
	return nc;
}

/* Distance (mm) from (x, y, z) inside box lo..hi to its nearest face. */
static double face_dist(struct vec3 lo, struct vec3 hi, double x, double y, double z)
{
	return fmin(fmin(fmin(x - lo.x, hi.x - x), fmin(y - lo.y, hi.y - y)),
		    fmin(z - lo.z, hi.z - z));
}

/* Continuous groin vault (mm^3) of a square interior of side a and
 * height t whose void's section at depth d below its top is the square
 * less four corner-free triangles of the diagonals dilated by d tan(b):
 * a^2 t - 4 int_0^t ((a/2 - sqrt2 d tan b)_+)^2 dd. */
static double groin_vault(double a, double t, double b)
{
	double s = M_SQRT2 * tan(b), dmax = fmin(t, 0.5 * a / s), h = 0.5 * a;

	/* int_0^dmax (h - s d)^2 dd = (h^3 - (h - s dmax)^3) / (3 s) */
	return a * a * t - 4 * (h * h * h - pow(h - s * dmax, 3)) / (3 * s);
}

static void test_box(void)
{
	/* 6 x 6 x 4 mm: interior 4 x 4 x 2 mm (z 1..3) */
	const struct vec3 lo = {0, 0, 0}, hi = {6, 6, 4};
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh m;
	struct err e;
	uint8_t *v = NULL;
	int32_t *lab = NULL;
	size_t count = 0, np, front = 0;
	double dg = LAYER * tan(ALPHA_DEG * M_PI / 180), wmin = INFINITY, sx = 0, sy = 0;
	double vol, cxy[2], vault, vol1[2];
	int top = -1, bottom = -1;

	err_clear(&e);
	REQUIRE(boxes(&m, &lo, &hi, 1));
	params(&p, 0.5);
	v = built(&m, &p, &f, &count);
	REQUIRE(v && count > 0);
	CHECK_EQ_INT(f.n, 80); /* 4 mm / 0.05 */
	CHECK_NEAR(f.layer_mm, LAYER, 0);
	np = (size_t)f.w * (size_t)f.h;
	for (int k = 0; k < f.n; k++)
		for (int y = 0; y < f.h; y++)
			for (int x = 0; x < f.w; x++) {
				double X = cx_mm(&f, x), Y = cy_mm(&f, y), Z = (k + 0.5) * LAYER;
				if (!v[(size_t)k * np + (size_t)y * (size_t)f.w + (size_t)x])
					continue;
				wmin = fmin(wmin, face_dist(lo, hi, X, Y, Z));
				sx += X;
				sy += Y;
				top = k > top ? k : top;
				bottom = bottom < 0 ? k : bottom;
			}
	/* the wall, pixel centres at mid-planes: at least wall_mm */
	CHECK_NUM(wmin, >=, WALL - 1e-9);
	/* the void spans the interior's layers: mid-planes 1.025 .. 2.975 */
	CHECK_NUM(bottom, >=, 20);
	CHECK_NUM(top, <=, 59);
	CHECK_NUM(top - bottom, >=, 30);
	/* the rule, on every pixel of the void's receding front */
	CHECK_EQ_INT(rule_breaks(&f, v, dg + 1e-9, &front), 0);
	CHECK_NUM(front, >, 1000);
	/* the brute force itself catches an overhang: a 3 x 3 pixel pocket
	 * of void planted in the solid just above the void's highest layer
	 * (solid above it too) leaves its centre pixel, whose four
	 * neighbours are void, with no solid of that layer within dg */
	{
		uint8_t *w = mem_alloc(np * (size_t)f.n + 1);
		int xc = f.w / 2, yc = f.h / 2;
		REQUIRE(w && top + 2 < f.n);
		memcpy(w, v, np * (size_t)f.n);
		for (int dy = -1; dy <= 1; dy++)
			for (int dx = -1; dx <= 1; dx++)
				w[(size_t)(top + 1) * np + (size_t)(yc + dy) * (size_t)f.w +
				  (size_t)(xc + dx)] = 1;
		CHECK_EQ_INT(rule_breaks(&f, w, dg + 1e-9, NULL), 1);
		mem_free(w);
	}
	/* volume: the runs' pixels, f's own sums, bounded by the interior and
	 * by the continuous vault at the design slope */
	hl_fill_mass(&f, &vol, cxy);
	CHECK_NEAR(f.volume_mm3, (double)count * PX * PX * LAYER, 1e-9);
	CHECK_NEAR(vol, (double)count * PX * PX * LAYER, 1e-9);
	vault = groin_vault(4, 2, (ALPHA_DEG - MARGIN_DEG) * M_PI / 180);
	CHECK_NUM(vol, <=, 4 * 4 * 2);
	CHECK_NUM(vol, >=, 0.7 * vault);
	/* centred on the box (symmetric part and grid) */
	CHECK_NEAR(cxy[0], sx / (double)count, 1e-9);
	CHECK_NEAR(cxy[1], sy / (double)count, 1e-9);
	CHECK_NEAR(cxy[0], 3, 0.01);
	CHECK_NEAR(cxy[1], 3, 0.01);
	/* one component, as counted here */
	lab = mem_alloc((np * (size_t)f.n + 1) * sizeof *lab);
	REQUIRE(lab);
	CHECK_EQ_INT(components(&f, v, lab, vol1, 2), 1);
	CHECK_EQ_INT(f.voids, 1);
	CHECK_EQ_INT(f.voids_small, 0);
	CHECK_NEAR(vol1[0], vol, 1e-9);
	/* hl_fill_at: the layer of a mid-plane */
	CHECK(hl_fill_at(&f, (bottom + 0.5) * LAYER) == &f.layer[bottom]);
	CHECK(hl_fill_at(&f, 0.5 * LAYER) == NULL);
	hl_fill_fini(&f);
	/* min_void above the void: dropped, nothing left */
	params(&p, vol + 0.01);
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	CHECK_EQ_INT(f.voids, 0);
	CHECK_EQ_INT(f.voids_small, 1);
	CHECK_NEAR(f.volume_mm3, 0, 0);
	for (int k = 0; k < f.n; k++)
		CHECK_EQ_INT(f.layer[k].n, 0);
	hl_fill_fini(&f);
	mem_free(lab);
	mem_free(v);
	mem_free(m.v);
	mem_free(m.tri);
}

static void test_two_boxes_min_void(void)
{
	/* 6 x 6 x 4 and 3.6 x 3.6 x 3.6 mm, 2 mm apart: interiors 32 and
	 * 5.5 mm^3, one void each */
	const struct vec3 lo[2] = {{0, 0, 0}, {8, 0, 0}}, hi[2] = {{6, 6, 4}, {11.6, 3.6, 3.6}};
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh m;
	struct err e;
	uint8_t *v = NULL, *v2 = NULL;
	int32_t *lab = NULL;
	size_t count = 0, count2 = 0, np;
	double vol[2], thr;
	int nc, big;

	memset(&f, 0, sizeof f);
	err_clear(&e);
	REQUIRE(boxes(&m, lo, hi, 2));
	params(&p, 0);
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	v = voxels(&f, &count);
	REQUIRE(v);
	np = (size_t)f.w * (size_t)f.h;
	lab = mem_alloc((np * (size_t)f.n + 1) * sizeof *lab);
	REQUIRE(lab);
	nc = components(&f, v, lab, vol, 2);
	REQUIRE(nc == 2);
	CHECK_EQ_INT(f.voids, 2);
	CHECK_EQ_INT(rule_breaks(&f, v, LAYER * tan(ALPHA_DEG * M_PI / 180) + 1e-9, NULL), 0);
	big = vol[0] > vol[1] ? 0 : 1;
	CHECK_NUM(vol[1 - big], <, vol[big]);
	CHECK_NUM(vol[1 - big], <=, 1.6 * 1.6 * 1.6);
	/* a threshold between the two: the small one goes, the large one
	 * stays pixel for pixel */
	thr = 0.5 * (vol[0] + vol[1]);
	hl_fill_fini(&f);
	params(&p, thr);
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	CHECK_EQ_INT(f.voids, 1);
	CHECK_EQ_INT(f.voids_small, 1);
	CHECK_NEAR(f.volume_mm3, vol[big], 1e-9);
	v2 = voxels(&f, &count2);
	REQUIRE(v2);
	{
		size_t diff = 0;
		for (size_t i = 0; i < np * (size_t)f.n; i++)
			diff += v2[i] != (lab[i] == big + 1);
		CHECK_EQ_INT(diff, 0);
	}
	hl_fill_fini(&f);
	mem_free(v);
	mem_free(v2);
	mem_free(lab);
	mem_free(m.v);
	mem_free(m.tri);
}

static void test_keep_half_plane(void)
{
	const struct vec3 lo = {0, 0, 0}, hi = {6, 6, 4};
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh m;
	struct err e;
	uint8_t *v = NULL;
	size_t count = 0, np;
	double xmax = -INFINITY, wmin = INFINITY;

	memset(&f, 0, sizeof f);
	err_clear(&e);
	REQUIRE(boxes(&m, &lo, &hi, 1));
	/* void only where x + 0.5 y < 4 (a slanted half-plane) */
	params(&p, 0.1);
	p.keep_set = 1;
	p.keep[0] = 1;
	p.keep[1] = 0.5;
	p.keep[2] = 4;
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	v = voxels(&f, &count);
	REQUIRE(v);
	CHECK_NUM(count, >, 0);
	np = (size_t)f.w * (size_t)f.h;
	for (int k = 0; k < f.n; k++)
		for (int y = 0; y < f.h; y++)
			for (int x = 0; x < f.w; x++) {
				double X = cx_mm(&f, x), Y = cy_mm(&f, y);
				if (!v[(size_t)k * np + (size_t)y * (size_t)f.w + (size_t)x])
					continue;
				xmax = fmax(xmax, X + 0.5 * Y);
				wmin = fmin(wmin, face_dist(lo, hi, X, Y, (k + 0.5) * LAYER));
			}
	CHECK_NUM(xmax, <, 4);
	CHECK_NUM(wmin, >=, WALL - 1e-9);
	CHECK_EQ_INT(rule_breaks(&f, v, LAYER * tan(ALPHA_DEG * M_PI / 180) + 1e-9, NULL), 0);
	hl_fill_fini(&f);
	mem_free(v);
	mem_free(m.v);
	mem_free(m.tri);
}

static void test_rotated_map_empty(void)
{
	const struct vec3 lo = {0, 0, 0}, hi = {6, 6, 4};
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh m;
	struct err e;
	double c = cos(0.5), s = sin(0.5);

	memset(&f, 0, sizeof f);
	err_clear(&e);
	REQUIRE(boxes(&m, &lo, &hi, 1));
	params(&p, 0.5);
	p.map.a[0][0] = c / PX;
	p.map.a[0][1] = -s / PX;
	p.map.a[1][0] = s / PX;
	p.map.a[1][1] = c / PX;
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	CHECK(f.layer == NULL);
	CHECK_EQ_INT(f.n, 0);
	CHECK_EQ_INT(f.voids, 0);
	/* a quarter turn is axis-aligned: it builds */
	p.map.a[0][0] = 0;
	p.map.a[0][1] = -1 / PX;
	p.map.a[1][0] = 1 / PX;
	p.map.a[1][1] = 0;
	p.map.b[0] = 200;
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	CHECK_EQ_INT(f.voids, 1);
	hl_fill_fini(&f);
	mem_free(m.v);
	mem_free(m.tri);
}

/* The distance transforms' threads (p.threads) change nothing: a box
 * whose window is past the transforms' one-thread size (14 x 14 mm, 300 x
 * 300 pixels) gives the same runs, layer by layer, on 1 and 3 threads. */
static void test_threads_same(void)
{
	const struct vec3 lo = {0, 0, 0}, hi = {14, 14, 3};
	struct hl_fill_params p;
	struct hl_fill f1, f3;
	struct mesh m;
	struct err e;

	memset(&f1, 0, sizeof f1);
	memset(&f3, 0, sizeof f3);
	err_clear(&e);
	REQUIRE(boxes(&m, &lo, &hi, 1));
	params(&p, 0.5);
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f1, &e), &e);
	p.threads = 3;
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f3, &e), &e);
	REQUIRE((size_t)f1.w * (size_t)f1.h > 65536);
	CHECK(f1.volume_mm3 > 0);
	CHECK_EQ_INT(f1.n, f3.n);
	CHECK_EQ_INT(f1.voids, f3.voids);
	CHECK_NEAR(f1.volume_mm3, f3.volume_mm3, 0);
	for (int k = 0; k < f1.n && k < f3.n; k++) {
		CHECK_EQ_INT(f1.layer[k].n, f3.layer[k].n);
		if (f1.layer[k].n == f3.layer[k].n && f1.layer[k].n)
			CHECK(memcmp(f1.layer[k].run, f3.layer[k].run,
				     f1.layer[k].n * sizeof *f1.layer[k].run) == 0);
	}
	hl_fill_fini(&f1);
	hl_fill_fini(&f3);
	mem_free(m.v);
	mem_free(m.tri);
}


/* The prism z0..z1 (mm) of a bar 8 x 2.9 mm with a notch 0.1 mm long and
 * 0.08 mm deep half way along one long side, appended to m (arrays sized
 * by the caller: 16 vertices, 28 triangles).  Less the 1 mm wall, its
 * section is a band 0.9 mm wide pinched to 0.82 at the notch: F's ridge
 * (inside distance >= wall_next / 2 = 0.4 mm) stops a few tenths of a
 * millimetre either side of the pinch, two pieces in one layer (measured:
 * two voids born 0.55 mm apart, centres, without hl_fill_apart). */
static void add_notched_bar(struct mesh *m, double z0, double z1)
{
	static const double c[8][2] = {{0, 0},     {3.95, 0}, {3.95, 0.08}, {4.05, 0.08},
				       {4.05, 0},  {8, 0},    {8, 2.9},    {0, 2.9}};
	/* the outline (counter-clockwise from above) in six triangles */
	static const uint32_t cap[6][3] = {{0, 1, 2}, {0, 2, 7}, {2, 3, 7},
					   {3, 6, 7}, {3, 4, 5}, {3, 5, 6}};
	uint32_t v0 = (uint32_t)m->nv;

	for (int l = 0; l < 2; l++)
		for (int i = 0; i < 8; i++)
			m->v[m->nv++] = (struct vec3){c[i][0], c[i][1], l ? z1 : z0};
	for (int t = 0; t < 6; t++) {
		uint32_t *q = m->tri + 3 * m->nt++;
		q[0] = v0 + cap[t][0]; /* bottom: facing down */
		q[1] = v0 + cap[t][2];
		q[2] = v0 + cap[t][1];
		q = m->tri + 3 * m->nt++;
		q[0] = v0 + 8 + cap[t][0];
		q[1] = v0 + 8 + cap[t][1];
		q[2] = v0 + 8 + cap[t][2];
	}
	for (uint32_t i = 0; i < 8; i++) {
		uint32_t j = (i + 1) % 8, *q = m->tri + 3 * m->nt++;
		q[0] = v0 + i;
		q[1] = v0 + j;
		q[2] = v0 + 8 + j;
		q = m->tri + 3 * m->nt++;
		q[0] = v0 + i;
		q[1] = v0 + 8 + j;
		q[2] = v0 + 8 + i;
	}
}

/* Smallest distance (mm) between the pixel centres of two different
 * 8-connected void components of one layer, over every layer of f
 * (INFINITY when no layer holds two); *layer: where. */
static double closest_components(const struct hl_fill *f, const uint8_t *v, int *layer)
{
	size_t np = (size_t)f->w * (size_t)f->h;
	int32_t *lab = mem_alloc(np * sizeof *lab);
	size_t *st = mem_alloc(np * sizeof *st);
	double best = INFINITY;

	*layer = -1;
	if (!lab || !st) {
		mem_free(lab);
		mem_free(st);
		return -1;
	}
	for (int k = 0; k < f->n; k++) {
		const uint8_t *l = v + (size_t)k * np;
		int nc = 0;
		memset(lab, 0, np * sizeof *lab);
		for (size_t s0 = 0; s0 < np; s0++) {
			size_t n = 0;
			if (!l[s0] || lab[s0])
				continue;
			lab[s0] = ++nc;
			st[n++] = s0;
			while (n) {
				size_t i = st[--n];
				int x = (int)(i % (size_t)f->w), y = (int)(i / (size_t)f->w);
				for (int dy = -1; dy <= 1; dy++)
					for (int dx = -1; dx <= 1; dx++) {
						int xx = x + dx, yy = y + dy;
						size_t j = (size_t)yy * (size_t)f->w + (size_t)xx;
						if (xx < 0 || yy < 0 || xx >= f->w || yy >= f->h ||
						    !l[j] || lab[j])
							continue;
						lab[j] = nc;
						st[n++] = j;
					}
			}
		}
		if (nc < 2)
			continue;
		for (size_t i = 0; i < np; i++)
			for (size_t j = i + 1; lab[i] && j < np; j++)
				if (lab[j] && lab[j] != lab[i]) {
					double d = hypot((double)((int)(i % (size_t)f->w) -
								  (int)(j % (size_t)f->w)) * PX,
							 (double)((int)(i / (size_t)f->w) -
								  (int)(j / (size_t)f->w)) * PX);
					if (d < best) {
						best = d;
						*layer = k;
					}
				}
	}
	mem_free(lab);
	mem_free(st);
	return best;
}

static void test_births_apart(void)
{
	/* a bar 3 mm tall with a shallow notch (add_notched_bar): at the top
	 * of C the ridge of F lies in two pieces about 0.55 mm apart in one
	 * layer (the fill before births kept apart made two voids there, a
	 * 0.50 mm wall for wall_next 0.8).  Every two voids of a layer keep
	 * wall_next between their pixels (centres wall_next + a pixel apart,
	 * brute force over every layer); the ridge's two pieces still make
	 * two voids (each written less its near end at the layer of birth) */
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh m;
	struct err e;
	uint8_t *v;
	size_t count = 0;
	double d;
	int layer;

	memset(&f, 0, sizeof f);
	err_clear(&e);
	m.v = mem_alloc(16 * sizeof *m.v);
	m.tri = mem_alloc(28 * 3 * sizeof *m.tri);
	m.nv = m.nt = 0;
	REQUIRE(m.v && m.tri);
	add_notched_bar(&m, 0, 3);
	params(&p, 0);
	REQUIRE_OK(hl_fill_build(&m, NULL, &p, NULL, 0, 1, &f, &e), &e);
	v = voxels(&f, &count);
	REQUIRE(v);
	CHECK_NUM(count, >, 0);
	CHECK_EQ_INT(rule_breaks(&f, v, LAYER * tan(ALPHA_DEG * M_PI / 180) + 1e-9, NULL), 0);
	d = closest_components(&f, v, &layer);
	CHECK_EQ_INT(f.voids, 2);
	CHECK_NUM(d, >=, p.wall_next_mm + PX - 1e-9);
	if (d < p.wall_next_mm + PX)
		fprintf(stderr, "  two voids %.3f mm apart in layer %d\n", d, layer);
	hl_fill_fini(&f);
	mem_free(v);
	mem_free(m.v);
	mem_free(m.tri);
}

/* Mitred corners (p.corners): in a cylinder the void is born under the
 * flat top of the interior, a blob of 20 pixels round its centre, and
 * grows down.  Round growth on these pixels (dg = 1 px a layer) advances
 * a front one pixel a layer along the axes and one diagonal step (0.71
 * px) across them; a void's convex corner may also grow square and keep
 * the rule (the solid beside it is a concave corner, held by both
 * faces), so with corners the section L layers down holds at least the
 * square (2 L - 1)^2 and a quarter more than round growth's.  Both fills
 * are re-checked by brute force: the rule on every front pixel, the wall
 * to the prism's faces, one void. */
static void test_mitre_corners(void)
{
	enum { NS = 64, L = 12 };
	const double c = 3.5, r = 3, h = 4, ri = r * cos(M_PI / NS);
	struct hl_fill_params p;
	struct hl_fill f;
	struct mesh *m = tm_new();
	double dg = LAYER * tan(ALPHA_DEG * M_PI / 180), vol[2], poly[NS][2];
	int fan[NS - 2][3];
	size_t sect[2], teeth[2];

	/* the 64-gon round (c, c), circumradius r, its caps fanned from its
	 * first corner, from z 0 to h */
	REQUIRE(m);
	for (int i = 0; i < NS; i++) {
		poly[i][0] = c + r * cos(2 * M_PI * i / NS);
		poly[i][1] = c + r * sin(2 * M_PI * i / NS);
	}
	for (int i = 0; i < NS - 2; i++) {
		fan[i][0] = 0;
		fan[i][1] = i + 1;
		fan[i][2] = i + 2;
	}
	tm_prism(m, (const double(*)[2])poly, NS, (const int(*)[3])fan, NS - 2, 0, h);
	REQUIRE(m->v && m->tri);
	for (int corners = 0; corners <= 1; corners++) {
		uint8_t *v;
		size_t count = 0, np, front = 0;
		int top = -1;
		double wmin = INFINITY;
		params(&p, 0.5);
		p.corners = corners;
		v = built(m, &p, &f, &count);
		REQUIRE(v && count > 0);
		np = (size_t)f.w * (size_t)f.h;
		for (int k = 0; k < f.n; k++)
			for (int y = 0; y < f.h; y++)
				for (int x = 0; x < f.w; x++) {
					double X = cx_mm(&f, x) - c, Y = cy_mm(&f, y) - c;
					double Z = (k + 0.5) * LAYER, d = fmin(Z, h - Z);
					if (!v[(size_t)k * np + (size_t)y * (size_t)f.w + (size_t)x])
						continue;
					top = k > top ? k : top;
					for (int i = 0; i < NS; i++) {
						double a = 2 * M_PI * (i + 0.5) / NS;
						d = fmin(d, ri - (X * cos(a) + Y * sin(a)));
					}
					wmin = fmin(wmin, d);
				}
		CHECK_NUM(wmin, >=, WALL - 1e-9);
		CHECK_EQ_INT(rule_breaks(&f, v, dg + 1e-9, &front), 0);
		CHECK_NUM(front, >, 1000);
		REQUIRE(top - L >= 0);
		sect[corners] = 0;
		for (size_t i = 0; i < np; i++)
			sect[corners] += v[(size_t)(top - L) * np + i];
		/* teeth: solid pixels of the void's layers with 4 or more void
		 * 8-neighbours (solid teeth left on a diagonal front) */
		teeth[corners] = 0;
		for (int k = 0; k < f.n; k++)
			for (int y = 1; y + 1 < f.h; y++)
				for (int x = 1; x + 1 < f.w; x++) {
					const uint8_t *l = v + (size_t)k * np;
					int nv = 0;
					if (l[(size_t)y * (size_t)f.w + (size_t)x])
						continue;
					for (int dy = -1; dy <= 1; dy++)
						for (int dx = -1; dx <= 1; dx++)
							nv += l[(size_t)(y + dy) * (size_t)f.w +
								(size_t)(x + dx)];
					teeth[corners] += nv >= 4;
				}
		vol[corners] = f.volume_mm3;
		CHECK_EQ_INT(f.voids, 1);
		mem_free(v);
		hl_fill_fini(&f);
	}
	printf("cylinder r %.0f mm: %d layers under the top, section %zu px round, %zu px "
	       "mitred; void %.3f -> %.3f mm3; teeth %zu, %zu\n", r, L, sect[0], sect[1], vol[0],
	       vol[1], teeth[0], teeth[1]);
	CHECK_NUM((double)sect[1], >=, (2.0 * L - 1) * (2.0 * L - 1));
	CHECK_NUM((double)sect[1], >=, 1.25 * (double)sect[0]);
	CHECK_NUM(vol[1], >, vol[0]);
	/* no more solid teeth than round growth leaves (makes_tooth) */
	CHECK_NUM((double)teeth[1], <=, (double)teeth[0]);
	tm_free(m);
}

int main(void)
{
	RUN(test_box);
	RUN(test_threads_same);
	RUN(test_two_boxes_min_void);
	RUN(test_keep_half_plane);
	RUN(test_rotated_map_empty);
	RUN(test_births_apart);
	RUN(test_mitre_corners);
	return harness_report();
}
