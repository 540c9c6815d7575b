/* test_slicer.c - streaming lattice slicing: realised strut radius, field
 * against a brute-force sum, in-core vs out-of-core vs multi-threaded
 * images, portable vs SIMD row kernel. */
#include "harness.h"

#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/lattice/kernel.h"
#include "engine/lattice/lattice.h"
#include "engine/lattice/rowkern.h"
#include "engine/lattice/slicer.h"
#include "engine/lattice/strut.h"

static double rnd(unsigned long long *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*s >> 11) / 9007199254740992.0;
}

/* Square pixels of pitch p (mm) with pixel (0,0)'s corner at (x0, y0). */
static struct raster_map plain_map(double p, double x0, double y0)
{
	struct raster_map m = {{{1 / p, 0}, {0, 1 / p}}, {-x0 / p, -y0 / p}};
	return m;
}

/* Slice a single lattice at z into r through map; sorted in memory. */
static int slice_once(const struct lattice *q, double R, int aa, double z,
		      const struct raster_map *map, struct raster *r, float *field, struct err *e)
{
	struct lattice_sorter *so = NULL;
	struct lattice_slicer *sl = NULL;
	struct lattice_slicer_opts o = {R, 2, aa};
	int rc;

	if ((rc = lattice_sorter_new(64u << 20, NULL, &so, e)) != 0)
		return rc;
	if (!(rc = lattice_sorter_add_lattice(so, q, e)) && !(rc = lattice_sorter_finish(so, e)) &&
	    !(rc = lattice_slicer_new(lattice_sorter_source(so), &o, &sl, e)))
		rc = lattice_slicer_render(sl, z, map, r, field, 0, 0, e);
	lattice_slicer_free(sl);
	lattice_sorter_free(so);
	return rc;
}

static struct lattice *one_strut(struct vec3 a, struct vec3 b, double r)
{
	struct lattice *q = lattice_new();
	lattice_add_node(q, a);
	lattice_add_node(q, b);
	lattice_add_edge(q, 0, 1, r);
	return q;
}

/* A long isolated strut cut across its middle: the cross-section is the
 * disc (vertical strut) or ellipse (tilted) of the predicted radius. */
static void test_single_strut_radius(void)
{
	struct err e;
	double p = 0.004, rr = 0.5, R = 0.75;
	struct raster *r = raster_new(400, 400);
	struct raster_map m = plain_map(p, -0.8, -0.8);
	double tilt[] = {0, 30, 50};

	REQUIRE(r);
	for (int k = 0; k < 3; k++) {
		double th = tilt[k] * M_PI / 180, L = 30;
		struct vec3 d = v3(sin(th), 0, cos(th));
		struct lattice *q = one_strut(v3_scale(d, -L), v3_scale(d, L), rr);
		double area_exact = M_PI * rr * rr / cos(th), a_bin, a_aa, rad_bin, rad_aa;
		size_t n = 0;

		/* shrink x so the ellipse fits: stretch the map's x pitch */
		m = plain_map(p / cos(th), -0.8 / cos(th), -0.8);
		m.a[0][0] = cos(th) / p;
		m.b[0] = 0.8 / p;
		REQUIRE_OK(slice_once(q, R, 0, 0.0, &m, r, NULL, &e), &e);
		for (size_t i = 0; i < (size_t)r->w * r->h; i++)
			n += r->px[i] == 255;
		a_bin = n * raster_map_pixel_area_mm2(&m);
		REQUIRE_OK(slice_once(q, R, 1, 0.0, &m, r, NULL, &e), &e);
		a_aa = raster_coverage_px(r) * raster_map_pixel_area_mm2(&m);
		rad_bin = sqrt(a_bin * cos(th) / M_PI);
		rad_aa = sqrt(a_aa * cos(th) / M_PI);
		fprintf(stderr, "tilt %2.0f deg: area exact %.5f binary %.5f aa %.5f; radius %.5f %.5f\n",
			tilt[k], area_exact, a_bin, a_aa, rad_bin, rad_aa);
		CHECK_NEAR(rad_bin, rr, 0.002);
		CHECK_NEAR(rad_aa, rr, 0.0005);
		lattice_free(q);
	}
	raster_free(r);
}

static struct lattice *random_lattice(unsigned long long seed, int n, double box, double rmax)
{
	struct lattice *q = lattice_new();

	for (int i = 0; i < n; i++)
		lattice_add_node(q, v3(box * rnd(&seed), box * rnd(&seed), box * rnd(&seed)));
	for (int i = 0; i < 3 * n; i++) {
		uint32_t a = (uint32_t)(rnd(&seed) * n), b = (uint32_t)(rnd(&seed) * n);
		if (a != b && v3_dist(q->node[a], q->node[b]) < box * 0.5)
			lattice_add_edge(q, a, b, 0.08 + (rmax - 0.08) * rnd(&seed));
	}
	return q;
}

/* Field at every pixel centre against a double-precision sum over all
 * struts (no culling): the culling never drops a contribution. */
static void test_field_matches_brute_force(void)
{
	struct err e;
	struct lattice *q = random_lattice(77, 40, 4, 0.35);
	double R = 0.6, p = 0.04, worst = 0;
	int w = 110, h = 100, mism = 0;
	struct raster_map m = plain_map(p, -0.2, -0.1);
	struct raster *r = raster_new(w, h);
	float *field = mem_alloc(sizeof(float) * w * h);

	REQUIRE(r && field);
	for (double z = 0.3; z < 4; z += 0.9) {
		REQUIRE_OK(slice_once(q, R, 0, z, &m, r, field, &e), &e);
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				double x, y, f = 0;
				raster_map_invert(&m, i + 0.5, j + 0.5, &x, &y);
				for (size_t k = 0; k < q->nedges; k++) {
					struct vec3 a = q->node[q->edge[k].a], b = q->node[q->edge[k].b];
					/* through float like the stream */
					a = v3((float)a.x, (float)a.y, (float)a.z);
					b = v3((float)b.x, (float)b.y, (float)b.z);
					f += lattice_weight_for_radius(q->edge[k].radius_mm, 1, R) *
					     lattice_kernel_integral(v3(x, y, z), a, b, R);
				}
				worst = fmax(worst, fabs(f - field[j * w + i]) / fmax(1, f));
				if ((f > 1 + 1e-4 && r->px[j * w + i] != 255) ||
				    (f < 1 - 1e-4 && r->px[j * w + i] != 0))
					mism++;
			}
	}
	fprintf(stderr, "field vs brute force: worst relative error %.3g\n", worst);
	CHECK_NUM(worst, <, 2e-5);
	CHECK_EQ_INT(mism, 0);
	mem_free(field);
	raster_free(r);
	lattice_free(q);
}

/* A jittered grid lattice with varied radii. */
static struct lattice *grid_lattice(int n, double sp, unsigned long long seed)
{
	struct lattice *q = lattice_new();

	for (int k = 0; k < n; k++)
		for (int j = 0; j < n; j++)
			for (int i = 0; i < n; i++)
				lattice_add_node(q, v3(sp * (i + 0.3 * rnd(&seed)),
						       sp * (j + 0.3 * rnd(&seed)),
						       sp * (k + 0.3 * rnd(&seed))));
	for (int k = 0; k < n; k++)
		for (int j = 0; j < n; j++)
			for (int i = 0; i < n; i++) {
				uint32_t v = (uint32_t)((k * n + j) * n + i);
				if (i + 1 < n)
					lattice_add_edge(q, v, v + 1, 0.1 + 0.15 * rnd(&seed));
				if (j + 1 < n)
					lattice_add_edge(q, v, v + n, 0.1 + 0.15 * rnd(&seed));
				if (k + 1 < n)
					lattice_add_edge(q, v, v + n * n, 0.1 + 0.15 * rnd(&seed));
				if (i + 1 < n && k + 1 < n)
					lattice_add_edge(q, v, v + n * n + 1, 0.1 + 0.15 * rnd(&seed));
			}
	return q;
}

/* The same lattice sliced from memory (one sorted run), through the
 * external sorter with many spilled runs, and streamed from its binary
 * file, with 1, 2 and 3 threads: identical images and fields. */
static void test_incore_equals_out_of_core(void)
{
	struct err e;
	char path[] = "/tmp/infilld-test-lattice-XXXXXX";
	int fd = mkstemp(path);
	struct lattice *q0 = grid_lattice(9, 1.0, 5), *q = NULL;
	struct lattice_sorter *s1 = NULL, *s2 = NULL;
	struct lattice_stream *st = NULL;
	struct lattice_slicer *sl[3] = {NULL, NULL, NULL};
	struct lattice_slicer_opts o[3] = {{0.45, 1, 1}, {0.45, 2, 1}, {0.45, 3, 1}};
	int w = 230, h = 220, planes = 0, diff_px = 0, diff_f = 0, nonempty = 0;
	struct raster_map m = plain_map(0.045, -0.5, -0.5);
	struct raster *r[3] = {raster_new(w, h), raster_new(w, h), raster_new(w, h)};
	float *f[3] = {mem_alloc(sizeof(float) * w * h), mem_alloc(sizeof(float) * w * h),
		       mem_alloc(sizeof(float) * w * h)};
	struct lattice_file_header hdr;

	REQUIRE(fd >= 0 && r[0] && r[1] && r[2] && f[0] && f[1] && f[2]);
	close(fd);
	REQUIRE_OK(lattice_write_binary(q0, path, &e), &e);
	REQUIRE_OK(lattice_read(path, &q, &e), &e);
	CHECK_EQ_INT(q->nedges, q0->nedges);

	REQUIRE_OK(lattice_sorter_new(1u << 26, NULL, &s1, &e), &e);
	REQUIRE_OK(lattice_sorter_new(100 * sizeof(struct lattice_strut), NULL, &s2, &e), &e);
	REQUIRE_OK(lattice_sorter_add_lattice(s1, q, &e), &e);
	REQUIRE_OK(lattice_sorter_add_lattice(s2, q, &e), &e);
	REQUIRE_OK(lattice_sorter_finish(s1, &e), &e);
	REQUIRE_OK(lattice_sorter_finish(s2, &e), &e);
	CHECK_EQ_INT(lattice_sorter_runs(s1), 0);
	CHECK_INT(lattice_sorter_runs(s2), >, 10);
	REQUIRE_OK(lattice_stream_open(path, &hdr, &st, &e), &e);
	CHECK_EQ_INT(hdr.nedges, q->nedges);
	REQUIRE_OK(lattice_slicer_new(lattice_sorter_source(s1), &o[0], &sl[0], &e), &e);
	REQUIRE_OK(lattice_slicer_new(lattice_sorter_source(s2), &o[1], &sl[1], &e), &e);
	REQUIRE_OK(lattice_slicer_new(lattice_stream_source(st), &o[2], &sl[2], &e), &e);
	for (double z = -0.6; z < 10; z += 0.23) {
		for (int k = 0; k < 3; k++)
			REQUIRE_OK(lattice_slicer_render(sl[k], z, &m, r[k], f[k], 0, 0, &e), &e);
		planes++;
		nonempty += raster_coverage_px(r[0]) > 100;
		for (int k = 1; k < 3; k++) {
			diff_px += memcmp(r[0]->px, r[k]->px, (size_t)w * h) != 0;
			diff_f += memcmp(f[0], f[k], sizeof(float) * w * h) != 0;
		}
	}
	{
		struct lattice_slicer_stats ss;
		lattice_slicer_get_stats(sl[2], &ss);
		CHECK_EQ_INT(ss.struts_read, q->nedges);
		CHECK_INT(ss.max_active, <, q->nedges / 2);
		fprintf(stderr, "planes %d, max active %zu of %zu, node window %zu of %zu\n", planes,
			ss.max_active, q->nedges, lattice_stream_window_peak(st), q->nnodes);
	}
	CHECK_INT(lattice_stream_window_peak(st), <, q->nnodes / 3);
	CHECK_INT(nonempty, >, planes / 2);
	CHECK_EQ_INT(diff_px, 0);
	CHECK_EQ_INT(diff_f, 0);
	for (int k = 0; k < 3; k++) {
		lattice_slicer_free(sl[k]);
		raster_free(r[k]);
		mem_free(f[k]);
	}
	lattice_sorter_free(s1);
	lattice_sorter_free(s2);
	lattice_stream_free(st);
	lattice_free(q);
	lattice_free(q0);
	unlink(path);
}

static void test_rowkern_variants_agree(void)
{
	unsigned long long seed = 9;
	rowkern_fn fast = lattice_rowkern_pick();
	uint32_t a[37], b[37];
	double worst = 0;

	for (int t = 0; t < 2000; t++) {
		struct rowkern_args k;
		int n = 1 + (int)(rnd(&seed) * 36);
		k.c0 = (float)(rnd(&seed) * 0.5);
		k.c1 = (float)(rnd(&seed) * 0.02 - 0.01);
		k.c2 = (float)(-rnd(&seed) * 0.001);
		k.h0 = (float)(rnd(&seed) * 4 - 1);
		k.hs = (float)(rnd(&seed) * 0.1 - 0.05);
		k.l = (float)(rnd(&seed) * 3);
		k.k = (float)(LATTICE_FIX_ONE * (1 + 20 * rnd(&seed)));
		for (int i = 0; i < 37; i++)
			a[i] = b[i] = (uint32_t)(rnd(&seed) * 1e6);
		lattice_rowkern_scalar(&k, a, n);
		fast(&k, b, n);
		for (int i = 0; i < 37; i++)
			worst = fmax(worst, fabs((double)a[i] - b[i]) / LATTICE_FIX_ONE);
		for (int i = n; i < 37; i++)
			CHECK_EQ_INT(a[i], b[i]); /* nothing written past the run */
	}
	fprintf(stderr, "row kernels: worst difference %.3g C\n", worst);
	CHECK_NUM(worst, <, 1e-4);
}

static void test_rejects_bad_input(void)
{
	struct err e;
	struct lattice *q = one_strut(v3(0, 0, 0), v3(0, 0, 1), 0.5);
	struct raster *r = raster_new(10, 10);
	struct raster_map m = plain_map(0.1, -0.5, -0.5), sing = {{{0, 0}, {0, 0}}, {0, 0}};

	REQUIRE(r);
	/* radius not below the support */
	CHECK_EQ_INT(slice_once(q, 0.5, 0, 0.5, &m, r, NULL, &e), ERR_PARAM);
	CHECK_EQ_INT(slice_once(q, 0.8, 0, 0.5, &sing, r, NULL, &e), ERR_PARAM);
	lattice_free(q);
	raster_free(r);
}

int main(void)
{
	RUN(test_single_strut_radius);
	RUN(test_field_matches_brute_force);
	RUN(test_incore_equals_out_of_core);
	RUN(test_rowkern_variants_agree);
	RUN(test_rejects_bad_input);
	return harness_report();
}
