/* test_erode.c - 3D erosion of a layer stack (erode.h): a box shrinks by
 * exactly r on every side including top and bottom, a ball of radius R
 * becomes one of radius R - r, thin parts vanish, and the distance field
 * equals a brute-force voxel distance on random stacks.  Also the raster
 * form, argument checks, source errors and allocation failures. */
#include "harness.h"
#include "meshgen.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/geom/path.h"
#include "engine/slice/erode.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

/* Source slicing a mesh at mid-layer heights. */
struct mesh_src {
	struct slicer *s;
	double layer_mm;
	int calls, last;
};

static int mesh_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	struct mesh_src *ms = ctx;
	ms->calls++;
	if (k != ms->last + 1)
		return ERR_SET(e, ERR_INTERNAL, "source asked for %d after %d", k, ms->last);
	ms->last = k;
	return slice_at(ms->s, (k + 0.5) * ms->layer_mm, region, NULL, e);
}

/* Erode a whole mesh stack; returns the eroded volume (mm^3) and checks
 * each layer with `check` when given. */
static double erode_mesh(const struct mesh *m, double height, double layer_mm, double pixel_mm,
			 double r, struct box3 bb, int *nonempty,
			 void (*check)(int k, const struct paths *reg, void *arg), void *arg)
{
	struct mesh_src ms = {NULL, layer_mm, 0, -1};
	struct slice_erode_source src = {mesh_layer, &ms};
	struct slice_erode_params p = {r, pixel_mm, layer_mm, layer_count_for(height, layer_mm),
				       bb.lo.x, bb.lo.y, bb.hi.x, bb.hi.y};
	struct slice_eroder *er = NULL;
	struct paths reg;
	struct err e;
	double vol = 0;

	paths_init(&reg);
	err_clear(&e);
	*nonempty = 0;
	if (slice_new(m, &ms.s, &e) || slice_erode_new(&p, &src, &er, &e)) {
		fprintf(stderr, "erode_mesh: %s\n", e.msg);
		slice_free(ms.s);
		return NAN;
	}
	for (int k = 0; k < p.layer_count; k++) {
		if (slice_erode_layer(er, k, &reg, &e)) {
			fprintf(stderr, "erode_mesh: %s\n", e.msg);
			vol = NAN;
			break;
		}
		*nonempty += reg.n > 0;
		vol += paths_area_mm2(&reg) * layer_mm;
		if (check)
			check(k, &reg, arg);
	}
	if (ms.calls != p.layer_count)
		vol = NAN; /* every layer pulled exactly once */
	slice_erode_free(er);
	slice_free(ms.s);
	paths_fini(&reg);
	return vol;
}

struct box_expect {
	double x0, y0, x1, y1;
	int bad;
};

static void box_check(int k, const struct paths *reg, void *arg)
{
	struct box_expect *x = arg;
	struct pt2 lo, hi;
	(void)k;
	if (reg->n == 0)
		return;
	x->bad += reg->n != 1;
	paths_bbox(reg, &lo, &hi);
	x->bad += fabs(geom_nm_to_mm(lo.x) - x->x0) > 1e-6 || fabs(geom_nm_to_mm(lo.y) - x->y0) > 1e-6 ||
		  fabs(geom_nm_to_mm(hi.x) - x->x1) > 1e-6 || fabs(geom_nm_to_mm(hi.y) - x->y1) > 1e-6;
}

/* A box shrinks by exactly r on every side: sides to the sub-pixel
 * interpolation, top and bottom to the layer. */
static void test_box(void)
{
	struct mesh *m = tm_new();
	struct box3 bb = {{0, 0, 0}, {10, 8, 6}};
	struct box_expect x = {1, 1, 9, 7, 0};
	int nonempty;
	double vol;

	tm_box(m, 0, 0, 0, 10, 8, 6);
	vol = erode_mesh(m, 6, 0.1, 0.1, 1.0, bb, &nonempty, box_check, &x);
	CHECK_EQ_INT(nonempty, 40); /* layers with 1 < z < 5 */
	CHECK_EQ_INT(x.bad, 0);
	/* 8 x 6 x 4, less the half-pixel chamfers marching squares cuts at
	 * the four vertical edges */
	CHECK_NEAR(vol, 8 * 6 * 4 - 4 * 0.5 * 0.05 * 0.05 * 4, 1e-6);
	/* unaligned grid and layers: exact to a pixel / a layer */
	vol = erode_mesh(m, 6, 0.07, 0.13, 1.3, bb, &nonempty, NULL, NULL);
	CHECK_NEAR(vol, (10 - 2.6) * (8 - 2.6) * (6 - 2.6), (7.4 + 5.4) * 2 * 3.4 * 0.13 + 7.4 * 5.4 * 0.14);
	tm_free(m);
}

struct ball_expect {
	double cz, rr, tol, maxdev;
};

static void ball_check(int k, const struct paths *reg, void *arg)
{
	struct ball_expect *x = arg;
	double z = (k + 0.5) * 0.1 - x->cz;
	for (size_t i = 0; i < reg->n; i++)
		for (size_t j = 0; j < reg->v[i].n; j++) {
			double px = geom_nm_to_mm(reg->v[i].pts[j].x), py = geom_nm_to_mm(reg->v[i].pts[j].y);
			double d = fabs(sqrt(px * px + py * py + z * z) - x->rr);
			x->maxdev = d > x->maxdev ? d : x->maxdev;
		}
}

/* A ball of radius R eroded by r is the ball of radius R - r: every
 * contour point within a pixel of that sphere, volume within the
 * volumes of radius R - r -+ one pixel.  (The voxel model's outside
 * boxes poke up to half a pixel diagonal into a curved surface, so the
 * eroded radius comes out about 0.7 pixel small: a thicker shell.) */
static void test_ball(void)
{
	const double R = 6, r = 2, p = 0.1;
	struct mesh *m = tm_icosphere(v3(0, 0, R), R, 5);
	struct box3 bb = {{-R, -R, 0}, {R, R, 2 * R}};
	struct ball_expect x = {R, R - r, p, 0};
	int nonempty;
	double vol, v = 4.0 / 3.0 * M_PI;

	vol = erode_mesh(m, 2 * R, 0.1, p, r, bb, &nonempty, ball_check, &x);
	CHECK_NUM(x.maxdev, <, p);
	CHECK_NUM(vol, >, v * pow(R - r - p, 3));
	CHECK_NUM(vol, <, v * pow(R - r + p, 3));
	CHECK_REL(vol, v * pow(R - r - 0.7 * p, 3), 0.01);
	CHECK_INT(nonempty, <=, 80); /* |z - R| < 4: 80 mid-planes */
	CHECK_INT(nonempty, >=, 78);
	tm_free(m);
}

/* Thin parts erode to nothing: a 1 mm plate and a 1 mm wall at r = 0.6. */
static void test_thin(void)
{
	struct mesh *m = tm_new();
	struct box3 bb = {{0, 0, 0}, {20, 20, 1}};
	int nonempty;

	tm_box(m, 0, 0, 0, 20, 20, 1);
	CHECK_NEAR(erode_mesh(m, 1, 0.05, 0.05, 0.6, bb, &nonempty, NULL, NULL), 0, 0);
	CHECK_EQ_INT(nonempty, 0);
	tm_free(m);
	m = tm_new();
	tm_box(m, 0, 0, 0, 1, 20, 20);
	bb.hi = v3(1, 20, 20);
	CHECK_NEAR(erode_mesh(m, 20, 0.05, 0.05, 0.6, bb, &nonempty, NULL, NULL), 0, 0);
	CHECK_EQ_INT(nonempty, 0);
	/* the same wall at r = 0.4 keeps a 0.2 mm core */
	CHECK_REL(erode_mesh(m, 20, 0.05, 0.05, 0.4, bb, &nonempty, NULL, NULL),
		  0.2 * 19.2 * 19.2, 0.01);
	tm_free(m);
}

/* ---- brute force on random voxel stacks ---- */

struct vox {
	int n, nz;            /* pixels per side (grid pixels 1..n), layers */
	unsigned char *in;    /* nz * n * n */
	double p, dz;
};

static int vox_in(const struct vox *v, int i, int j, int k) /* grid pixel coordinates */
{
	if (i < 1 || j < 1 || i > v->n || j > v->n || k < 0 || k >= v->nz)
		return 0;
	return v->in[((size_t)k * v->n + (size_t)(j - 1)) * v->n + (size_t)(i - 1)];
}

static int vox_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	const struct vox *v = ctx;
	struct paths raw;
	int rc;

	paths_init(&raw);
	for (int j = 1; j <= v->n; j++)
		for (int i = 1; i <= v->n; i++)
			if (vox_in(v, i, j, k)) {
				/* grid pixel i covers x in [(i - 1) p, i p] (origin x0 - p) */
				struct pt2 sq[4] = {
					{geom_mm_to_nm((i - 1) * v->p), geom_mm_to_nm((j - 1) * v->p)},
					{geom_mm_to_nm(i * v->p), geom_mm_to_nm((j - 1) * v->p)},
					{geom_mm_to_nm(i * v->p), geom_mm_to_nm(j * v->p)},
					{geom_mm_to_nm((i - 1) * v->p), geom_mm_to_nm(j * v->p)}};
				paths_add_pts(&raw, sq, 4);
			}
	rc = clip_union(&raw, CLIP_FILL_NONZERO, region, e);
	paths_fini(&raw);
	return rc;
}

static double gb(int d)
{
	double a = fabs((double)d) - 0.5;
	return d == 0 ? 0 : a * a;
}

static void test_brute_force(void)
{
	struct vox v = {18, 22, NULL, 0.1, 0.07};
	uint64_t s = 99;
	long compared = 0, wrong = 0, cavity = 0;

	v.in = malloc((size_t)v.nz * v.n * v.n);
	for (int trial = 0; trial < 3; trial++) {
		struct slice_erode_params p = {0.2 + 0.1 * trial, v.p, v.dz, v.nz, 0, 0,
					       v.n * v.p, v.n * v.p};
		struct slice_erode_source src = {vox_layer, &v};
		struct slice_eroder *er = NULL;
		struct slice_erode_info info;
		struct err e;
		double bx[4][4];

		err_clear(&e);
		/* union of random balls, plus noise voxels */
		for (int b = 0; b < 4; b++)
			for (int c = 0; c < 4; c++) {
				s = s * 6364136223846793005ull + 1442695040888963407ull;
				bx[b][c] = (double)(s >> 11) / 9007199254740992.0;
			}
		for (int k = 0; k < v.nz; k++)
			for (int j = 1; j <= v.n; j++)
				for (int i = 1; i <= v.n; i++) {
					int in = 0;
					for (int b = 0; b < 4; b++) {
						double dx = (i - 0.5) * v.p - bx[b][0] * v.n * v.p;
						double dy = (j - 0.5) * v.p - bx[b][1] * v.n * v.p;
						double dzz = (k + 0.5) * v.dz - bx[b][2] * v.nz * v.dz;
						double rad = 0.5 + bx[b][3] * 0.6;
						in |= dx * dx + dy * dy + dzz * dzz < rad * rad;
					}
					s = s * 6364136223846793005ull + 1442695040888963407ull;
					in ^= (s >> 56) == 0; /* 1/256 flipped */
					v.in[((size_t)k * v.n + (size_t)(j - 1)) * v.n + (size_t)(i - 1)] =
						(unsigned char)in;
				}
		REQUIRE_OK(slice_erode_new(&p, &src, &er, &e), &e);
		slice_erode_info(er, &info);
		CHECK_EQ_INT(info.w, v.n + 2);
		for (int k = 0; k < v.nz; k++) {
			const float *f;
			REQUIRE_OK(slice_erode_field(er, k, &f, &e), &e);
			for (int j = 1; j <= v.n; j++)
				for (int i = 1; i <= v.n; i++) {
					double best = INFINITY, d, want_f;
					if (!vox_in(&v, i, j, k))
						continue;
					for (int kk = -1; kk <= v.nz; kk++)
						for (int jj = 0; jj <= v.n + 1; jj++)
							for (int ii = 0; ii <= v.n + 1; ii++) {
								if (vox_in(&v, ii, jj, kk))
									continue;
								d = (gb(ii - i) + gb(jj - j)) * v.p * v.p +
								    gb(kk - k) * v.dz * v.dz;
								best = d < best ? d : best;
							}
					want_f = sqrt(best) - p.r_mm;
					if (fabs(want_f) > 2 * v.p) { /* only the sign is promised */
						if ((want_f > 0) != (f[(size_t)j * info.w + i] > 0) && wrong++ < 10)
							fprintf(stderr, "sign k %d i %d j %d: got %g want %g\n", k, i, j,
								f[(size_t)j * info.w + i], want_f);
						continue;
					}
					compared++;
					cavity += want_f >= 0;
					if (fabs(f[(size_t)j * info.w + i] - want_f) > 1e-5 && wrong++ < 10)
						fprintf(stderr, "k %d i %d j %d: got %g want %g\n", k, i, j,
							f[(size_t)j * info.w + i], want_f);
				}
		}
		slice_erode_free(er);
	}
	CHECK_EQ_INT(wrong, 0);
	CHECK_INT(compared, >, 500);
	CHECK_INT(cavity, >, 50);
	free(v.in);
}

/* Raster form matches the region's coverage. */
static void test_raster_form(void)
{
	struct mesh *m = tm_new();
	struct mesh_src ms = {NULL, 0.1, 0, -1};
	struct slice_erode_source src = {mesh_layer, &ms};
	struct slice_erode_params p = {1, 0.1, 0.1, 60, 0, 0, 10, 8};
	struct slice_eroder *er = NULL;
	struct raster *r = raster_new(300, 300);
	struct raster_map map = {{{0, 1 / 0.05}, {-1 / 0.05, 0}}, {0, 250}};
	struct err e;

	err_clear(&e);
	tm_box(m, 0, 0, 0, 10, 8, 6);
	REQUIRE_OK(slice_new(m, &ms.s, &e), &e);
	REQUIRE_OK(slice_erode_new(&p, &src, &er, &e), &e);
	REQUIRE_OK(slice_erode_raster(er, 30, &map, 1, r, &e), &e);
	CHECK_NEAR(raster_coverage_px(r) * 0.0025, 48, 0.01);
	/* asking again for the same layer is allowed, going back is not */
	REQUIRE_OK(slice_erode_raster(er, 30, &map, 0, r, &e), &e);
	CHECK_EQ_INT(slice_erode_raster(er, 29, &map, 0, r, &e), ERR_PARAM);
	CHECK_EQ_INT(slice_erode_raster(er, 60, &map, 0, r, &e), ERR_PARAM);
	slice_erode_free(er);
	slice_free(ms.s);
	raster_free(r);
	tm_free(m);
}

static int failing_layer(void *ctx, int k, struct paths *region, struct err *e)
{
	(void)ctx;
	(void)region;
	if (k == 3)
		return ERR_SET(e, ERR_CANCELLED, "stop at layer %d", k);
	return 0;
}

static void test_params_and_errors(void)
{
	struct slice_erode_source src = {failing_layer, NULL};
	struct slice_erode_params ok = {1, 0.1, 0.1, 10, 0, 0, 5, 5}, p;
	struct slice_eroder *er = NULL;
	struct paths reg;
	struct err e;

	paths_init(&reg);
	err_clear(&e);
	p = ok, p.r_mm = 0;
	CHECK_EQ_INT(slice_erode_new(&p, &src, &er, &e), ERR_PARAM);
	CHECK_STR(e.field, "r_mm");
	p = ok, p.pixel_mm = NAN;
	CHECK_EQ_INT(slice_erode_new(&p, &src, &er, &e), ERR_PARAM);
	CHECK_STR(e.field, "pixel_mm");
	p = ok, p.layer_count = 0;
	CHECK_EQ_INT(slice_erode_new(&p, &src, &er, &e), ERR_PARAM);
	p = ok, p.x1_mm = -1;
	CHECK_EQ_INT(slice_erode_new(&p, &src, &er, &e), ERR_PARAM);
	p = ok, p.pixel_mm = 1e-5;
	CHECK_EQ_INT(slice_erode_new(&p, &src, &er, &e), ERR_LIMIT);
	REQUIRE_OK(slice_erode_new(&ok, &src, &er, &e), &e);
	/* layer 0 needs layers up to R >= 3: the source's error comes back */
	CHECK_EQ_INT(slice_erode_layer(er, 0, &reg, &e), ERR_CANCELLED);
	CHECK_CONTAINS(e.msg, "layer 3");
	slice_erode_free(er);
	slice_erode_free(NULL);
	paths_fini(&reg);
}

static void test_alloc_failures(void)
{
	struct mesh *m = tm_icosphere(v3(0, 0, 2), 2, 2);
	int n, failed = 0;

	for (n = 1; n < 3000; n += n < 200 ? 1 : 13) {
		struct mesh_src ms = {NULL, 0.1, 0, -1};
		struct slice_erode_source src = {mesh_layer, &ms};
		struct slice_erode_params p = {0.5, 0.1, 0.1, 40, -2, -2, 2, 2};
		struct slice_eroder *er = NULL;
		struct paths reg;
		struct err e;
		int rc;

		paths_init(&reg);
		err_clear(&e);
		if (slice_new(m, &ms.s, &e))
			break;
		mem_fail_after(n);
		rc = slice_erode_new(&p, &src, &er, &e);
		for (int k = 0; !rc && k < 40; k += 25)
			rc = slice_erode_layer(er, k, &reg, &e);
		mem_fail_after(-1);
		slice_erode_free(er);
		slice_free(ms.s);
		paths_fini(&reg);
		if (!rc)
			break;
		CHECK_EQ_INT(rc, ERR_NOMEM);
		failed++;
	}
	CHECK_INT(failed, >, 15);
	CHECK_INT(n, <, 3000);
	tm_free(m);
}

int main(void)
{
	RUN(test_box);
	RUN(test_ball);
	RUN(test_thin);
	RUN(test_brute_force);
	RUN(test_raster_form);
	RUN(test_params_and_errors);
	RUN(test_alloc_failures);
	return harness_report();
}
