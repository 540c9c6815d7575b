/* test_slice.c - the layer schedule and the z-sweep slicer (slice_at):
 * volumes against the divergence theorem and analytic values, loop
 * orientation, vertex-on-plane and horizontal faces, open and
 * non-manifold meshes, restarts, bad input, allocation failures. */
#include "harness.h"
#include "meshgen.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

/* Sum of region area x layer height over the schedule of a mesh whose
 * z range starts at 0; checks every region path is a proper loop. */
static double sliced_volume(const struct mesh *m, double height, double layer_mm,
			    struct slice_stats *st, int *bad_loops)
{
	struct slicer *s = NULL;
	struct paths reg;
	struct err e;
	double vol = 0;
	int n = layer_count_for(height, layer_mm);

	paths_init(&reg);
	err_clear(&e);
	*bad_loops = 0;
	if (slice_new(m, &s, &e))
		return NAN;
	for (int k = 0; k < n; k++) {
		struct layer ly;
		layer_place(&ly, k, n, layer_mm);
		if (slice_at(s, ly.z_mm, &reg, st, &e)) {
			vol = NAN;
			break;
		}
		for (size_t i = 0; i < reg.n; i++)
			*bad_loops += reg.v[i].n < 3 || path_area2_nm2(&reg.v[i]) == 0;
		vol += paths_area_mm2(&reg) * layer_mm;
	}
	paths_fini(&reg);
	slice_free(s);
	return vol;
}

static void test_schedule(void)
{
	struct layer ly;

	CHECK_EQ_INT(layer_count_for(50, 0.05), 1000);
	CHECK_EQ_INT(layer_count_for(1.0, 0.3), 4);
	CHECK_EQ_INT(layer_count_for(0.15, 0.05), 3);
	CHECK_EQ_INT(layer_count_for(0.3, 0.1), 3);
	CHECK_EQ_INT(layer_count_for(0.01, 0.05), 1);
	CHECK_EQ_INT(layer_count_for(50.0001, 0.05), 1001);
	CHECK_EQ_INT(layer_count_for(0, 0.05), 0);
	CHECK_EQ_INT(layer_count_for(10, 0), 0);
	CHECK_EQ_INT(layer_count_for(NAN, 0.05), 0);
	CHECK_EQ_INT(layer_count_for(INFINITY, 0.05), 0);
	CHECK_EQ_INT(layer_count_for(1e9, 1e-3), 0); /* beyond LAYER_MAX_COUNT */
	for (int k = 0; k < 1000; k += 37) {
		layer_place(&ly, k, 1000, 0.05);
		CHECK_EQ_INT(ly.index, k);
		CHECK_EQ_INT(ly.count, 1000);
		CHECK_NEAR(ly.z_mm, (k + 0.5) * 0.05, 1e-12);
		CHECK_NEAR(ly.z_top_mm, (k + 1) * 0.05, 1e-12);
		CHECK_NEAR(ly.height_mm, 0.05, 0);
	}
}

static void test_cube(void)
{
	struct mesh *m = tm_new();
	struct slicer *s = NULL;
	struct paths reg;
	struct slice_stats st = {0, 0, 0};
	struct err e;
	int bad;

	paths_init(&reg);
	err_clear(&e);
	tm_box(m, 0, 0, 0, 10, 10, 10);
	tm_weld(m);
	CHECK_NEAR(tm_volume(m), 1000, 1e-9);
	CHECK_NEAR(sliced_volume(m, 10, 0.05, &st, &bad), 1000, 1e-6);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.loops, 200);
	CHECK_EQ_INT(st.chains_closed, 0);
	CHECK_EQ_INT(st.segments, 200 * 8);

	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 3.3, &reg, NULL, &e), &e);
	REQUIRE(reg.n == 1);
	CHECK_NEAR(path_area_mm2(&reg.v[0]), 100, 1e-9); /* outer loop CCW */
	/* Plane through the top face: its vertices count as above, so the
	 * section is the one just below (the full square), and the top face
	 * itself contributes nothing. */
	REQUIRE_OK(slice_at(s, 10, &reg, NULL, &e), &e);
	CHECK_EQ_INT(reg.n, 1);
	CHECK_NEAR(paths_area_mm2(&reg), 100, 1e-9);
	/* Plane through the bottom face: nothing lies below. */
	REQUIRE_OK(slice_at(s, 0, &reg, NULL, &e), &e);
	CHECK_EQ_INT(reg.n, 0);
	/* Above and below the part. */
	REQUIRE_OK(slice_at(s, 10.001, &reg, NULL, &e), &e);
	CHECK_EQ_INT(reg.n, 0);
	REQUIRE_OK(slice_at(s, -1, &reg, NULL, &e), &e);
	CHECK_EQ_INT(reg.n, 0);
	REQUIRE_OK(slice_at(s, 5, &reg, NULL, &e), &e);
	CHECK_NEAR(paths_area_mm2(&reg), 100, 1e-9);
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);
}

/* Staircase: profile in XZ with treads at z = 1, 2, 3, extruded 2 mm in
 * y.  Vertices and horizontal faces lie exactly on planes z = 1, 2, 3. */
static struct mesh *staircase(void)
{
	const double p[10][2] = {{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 3},
				 {2, 3}, {2, 2}, {1, 2}, {1, 1}, {0, 1}};
	const int t[8][3] = {{0, 1, 8}, {0, 8, 9}, {2, 6, 7}, {2, 7, 8},
			     {2, 8, 1}, {3, 4, 5}, {3, 5, 6}, {3, 6, 2}};
	struct mesh *m = tm_new();

	tm_prism(m, p, 10, t, 8, 0, 2);
	for (size_t i = 0; i < m->nv; i++) /* rotate +90 deg about x: y -> z */
		m->v[i] = v3(m->v[i].x, -m->v[i].z, m->v[i].y);
	tm_weld(m);
	return m;
}

static void test_staircase(void)
{
	struct mesh *m = staircase();
	struct slicer *s = NULL;
	struct paths reg;
	struct err e;
	struct slice_stats st = {0, 0, 0};
	int bad;
	/* section just below z: width of the steps at height < z, times 2 */
	const double z[] = {0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 0.0, 3.5};
	const double area[] = {6, 6, 4, 4, 2, 2, 0, 0};

	paths_init(&reg);
	err_clear(&e);
	CHECK_NEAR(tm_volume(m), 12, 1e-12);
	CHECK_NEAR(sliced_volume(m, 3, 0.1, &st, &bad), 12, 1e-9);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.chains_closed, 0);
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	for (size_t i = 0; i < sizeof z / sizeof z[0]; i++) {
		REQUIRE_OK(slice_at(s, z[i], &reg, NULL, &e), &e);
		CHECK_NEAR(paths_area_mm2(&reg), area[i], 1e-9);
		CHECK_INT(reg.n, <=, 1);
	}
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);
}

static void test_sphere(void)
{
	const double R = 10;
	struct mesh *m = tm_icosphere(v3(0, 0, R), R, 5);
	struct slice_stats st = {0, 0, 0};
	double exact = tm_volume(m), ball = 4.0 / 3.0 * M_PI * R * R * R, vol;
	int bad;

	CHECK_REL(exact, ball, 0.005); /* the tessellation is fine enough */
	vol = sliced_volume(m, 2 * R, 0.05, &st, &bad);
	/* midpoint rule over layers: O(dz^2) from the exact polyhedron */
	CHECK_REL(vol, exact, 2e-4);
	CHECK_REL(vol, ball, 0.005);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.loops, 400);
	CHECK_EQ_INT(st.chains_closed, 0);
	tm_free(m);
}

static void test_torus(void)
{
	struct mesh *m = tm_torus(v3(0, 0, 3), 10, 3, 128, 64);
	struct slicer *s = NULL;
	struct paths reg;
	struct err e;
	struct slice_stats st = {0, 0, 0};
	double exact = tm_volume(m);
	int bad, pos = 0, neg = 0;

	paths_init(&reg);
	err_clear(&e);
	CHECK_REL(exact, 2 * M_PI * M_PI * 10 * 9, 0.01);
	CHECK_REL(sliced_volume(m, 6, 0.05, &st, &bad), exact, 5e-4);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.loops, 2 * 120);
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 3.01, &reg, NULL, &e), &e);
	REQUIRE(reg.n == 2);
	for (size_t i = 0; i < reg.n; i++) {
		pos += path_area_mm2(&reg.v[i]) > 0;
		neg += path_area_mm2(&reg.v[i]) < 0;
	}
	CHECK_EQ_INT(pos, 1); /* outer CCW */
	CHECK_EQ_INT(neg, 1); /* hole CW */
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);
}

/* Inside-out input: every loop comes out clockwise; the nonzero rule
 * still reads it as material (mesh repair normally flips it first). */
static void test_inside_out(void)
{
	struct mesh *m = tm_new();
	struct slicer *s = NULL;
	struct paths reg;
	struct err e;

	paths_init(&reg);
	err_clear(&e);
	tm_box(m, 0, 0, 0, 4, 5, 6);
	tm_weld(m);
	for (size_t t = 0; t < m->nt; t++) {
		uint32_t x = m->tri[3 * t + 1];
		m->tri[3 * t + 1] = m->tri[3 * t + 2];
		m->tri[3 * t + 2] = x;
	}
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 1, &reg, NULL, &e), &e);
	CHECK_NEAR(paths_area_mm2(&reg), 20, 1e-9);
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);
}

/* An open box (side faces missing) still slices to closed, correct
 * layers; the number of repaired chains is reported. */
static void test_open_mesh(void)
{
	struct mesh *m = tm_new();
	struct slicer *s = NULL;
	struct paths reg;
	struct slice_stats st = {0, 0, 0};
	struct err e;
	int bad;

	paths_init(&reg);
	err_clear(&e);
	tm_box(m, 0, 0, 0, 10, 10, 10);
	tm_weld(m);
	/* box triangles: 0-3 caps, then two per side: delete one whole side
	 * (x = 10) and half of the side y = 10 */
	tm_delete_tri(m, 11);
	tm_delete_tri(m, 6);
	tm_delete_tri(m, 5);
	CHECK_NEAR(sliced_volume(m, 10, 0.1, &st, &bad), 1000, 1e-6);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.loops, 0);
	CHECK_INT(st.chains_closed, >=, 100);
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 2.5, &reg, NULL, &e), &e);
	REQUIRE(reg.n == 1);
	CHECK_NEAR(path_area_mm2(&reg.v[0]), 100, 1e-9);
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);

	/* A sphere with a cap of triangles removed around its equator
	 * side: the chord closing each layer is inside the hole, so the
	 * area stays within the hole's sagitta of the closed sphere's. */
	m = tm_icosphere(v3(0, 0, 10), 10, 4);
	{
		struct mesh *full = tm_icosphere(v3(0, 0, 10), 10, 4);
		double vfull, vopen;
		size_t removed = 0;
		for (size_t t = 0; t < m->nt;) {
			struct vec3 c = v3_scale(v3_add(v3_add(m->v[m->tri[3 * t]],
								m->v[m->tri[3 * t + 1]]),
							 m->v[m->tri[3 * t + 2]]),
						 1.0 / 3.0);
			if (c.x > 8.5) {
				tm_delete_tri(m, t);
				removed++;
			} else {
				t++;
			}
		}
		CHECK_INT(removed, >, 10);
		memset(&st, 0, sizeof st);
		vfull = sliced_volume(full, 20, 0.1, &st, &bad);
		memset(&st, 0, sizeof st);
		vopen = sliced_volume(m, 20, 0.1, &st, &bad);
		CHECK_EQ_INT(bad, 0);
		CHECK_INT(st.chains_closed, >, 0);
		/* the cap x > ~8.5 holds about 1.2% of the ball's volume; the
		 * straight closure cuts it off */
		CHECK_REL(vopen, vfull, 0.02);
		CHECK_NUM(vopen, <, vfull);
		tm_free(full);
	}
	tm_free(m);
}

/* A tube (radii 9 and 10, 10 tall) whose outer and inner walls both
 * have a 3.5 mm wide window at the same angles.  Nearest-end joining
 * would cross the 1 mm wall from the outer chain to the inner one; the
 * chains are closed across their own windows instead. */
static void test_windows(void)
{
	const int n = 64;
	struct mesh *m = tm_new();
	struct slicer *s = NULL;
	struct paths reg;
	struct slice_stats st = {0, 0, 0};
	struct err e;
	double chord_loss = 0;

	paths_init(&reg);
	err_clear(&e);
	for (int i = 0; i < n; i++) { /* ring vertices: outer/inner x bottom/top */
		double a = 2 * M_PI * i / n;
		tm_vert(m, 10 * cos(a), 10 * sin(a), 0);
		tm_vert(m, 10 * cos(a), 10 * sin(a), 10);
		tm_vert(m, 9 * cos(a), 9 * sin(a), 0);
		tm_vert(m, 9 * cos(a), 9 * sin(a), 10);
	}
	for (int i = 0; i < n; i++) {
		uint32_t a = (uint32_t)(4 * i), b = (uint32_t)(4 * ((i + 1) % n));
		int window = i < 4; /* angles 0..22.5 deg */
		if (!window) {
			tm_tri(m, a, b, b + 1); /* outer wall, facing out */
			tm_tri(m, a, b + 1, a + 1);
			tm_tri(m, a + 2, b + 3, b + 2); /* inner wall, facing the axis */
			tm_tri(m, a + 2, a + 3, b + 3);
		}
		tm_tri(m, a + 1, b + 1, b + 3); /* top */
		tm_tri(m, a + 1, b + 3, a + 3);
		tm_tri(m, a, b + 2, b); /* bottom */
		tm_tri(m, a, a + 2, b + 2);
	}
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 5, &reg, &st, &e), &e);
	CHECK_EQ_INT(st.chains_closed, 2);
	CHECK_EQ_INT(reg.n, 2); /* still an annulus: outer CCW, hole CW */
	/* the polygonal annulus, less nothing: the window chords are the
	 * polygon's own edges across 4 segments */
	for (int r = 9; r <= 10; r++) {
		double seg = 0.5 * r * r * sin(2 * M_PI / n), big = 0.5 * r * r * sin(8 * M_PI / n);
		chord_loss += (r == 10 ? 1 : -1) * (4 * seg - big);
	}
	CHECK_NEAR(paths_area_mm2(&reg),
		   0.5 * n * sin(2 * M_PI / n) * (100 - 81) - chord_loss, 1e-4);
	paths_fini(&reg);
	slice_free(s);
	tm_free(m);
}

/* Two cubes sharing one vertical edge: after welding that edge has four
 * faces.  Sections are two unit squares touching at a corner. */
static void test_nonmanifold(void)
{
	struct mesh *m = tm_new();
	struct slice_stats st = {0, 0, 0};
	int bad;

	tm_box(m, 0, 0, 0, 1, 1, 1);
	tm_box(m, 1, 1, 0, 2, 2, 1);
	tm_weld(m);
	CHECK_EQ_INT(m->nv, 14);
	CHECK_NEAR(sliced_volume(m, 1, 0.05, &st, &bad), 2, 1e-9);
	CHECK_EQ_INT(bad, 0);
	CHECK_EQ_INT(st.chains_closed, 0);
	tm_free(m);

	/* Two cubes sharing a whole face, welded: the shared face's two
	 * copies cancel under the nonzero union. */
	m = tm_new();
	tm_box(m, 0, 0, 0, 1, 1, 1);
	tm_box(m, 1, 0, 0, 2, 1, 1);
	tm_weld(m);
	CHECK_NEAR(sliced_volume(m, 1, 0.05, &st, &bad), 2, 1e-9);
	tm_free(m);

	/* A fin: one triangle hanging off a cube edge (three faces on that
	 * edge).  Its chain closes on itself with no area. */
	m = tm_new();
	tm_box(m, 0, 0, 0, 1, 1, 1);
	tm_weld(m);
	/* welded vertices are sorted: 4 = (1,0,0), 5 = (1,0,1) */
	CHECK(m->v[4].x == 1 && m->v[4].y == 0 && m->v[4].z == 0 && m->v[5].z == 1);
	tm_tri(m, 4, 5, tm_vert(m, 2, 0, 0.5));
	CHECK_NEAR(sliced_volume(m, 1, 0.05, &st, &bad), 1, 1e-9);
	CHECK_EQ_INT(bad, 0);
	tm_free(m);

	/* An unwelded soup (every triangle its own vertices): chains meet
	 * end to end at seams and are joined there. */
	m = tm_icosphere(v3(0, 0, 5), 5, 3);
	{
		struct mesh *soup = tm_new();
		double vw, vs;
		for (size_t t = 0; t < m->nt; t++) {
			uint32_t c[3];
			for (int k = 0; k < 3; k++) {
				struct vec3 p = m->v[m->tri[3 * t + (size_t)k]];
				c[k] = tm_vert(soup, p.x, p.y, p.z);
			}
			tm_tri(soup, c[0], c[1], c[2]);
		}
		memset(&st, 0, sizeof st);
		vw = sliced_volume(m, 10, 0.1, &st, &bad);
		memset(&st, 0, sizeof st);
		vs = sliced_volume(soup, 10, 0.1, &st, &bad);
		CHECK_REL(vs, vw, 1e-6);
		CHECK_EQ_INT(bad, 0);
		CHECK_INT(st.chains_closed, >, 1000);
		tm_free(soup);
	}
	tm_free(m);

	/* Overlapping shells: the union counts once. */
	m = tm_new();
	tm_box(m, 0, 0, 0, 2, 2, 1);
	tm_box(m, 1, 1, 0, 3, 3, 1);
	CHECK_NEAR(sliced_volume(m, 1, 0.05, &st, &bad), 7, 1e-9);
	tm_free(m);
}

/* Going down restarts the sweep: same answers as a fresh slicer. */
static void test_restart(void)
{
	struct mesh *m = tm_icosphere(v3(0, 0, 5), 5, 3);
	struct slicer *s = NULL, *f = NULL;
	struct paths reg, ref;
	struct err e;
	const double z[] = {1, 9, 2.5, 2.5, 0.2, 7};

	paths_init(&reg);
	paths_init(&ref);
	err_clear(&e);
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	for (size_t i = 0; i < sizeof z / sizeof z[0]; i++) {
		REQUIRE_OK(slice_at(s, z[i], &reg, NULL, &e), &e);
		REQUIRE_OK(slice_new(m, &f, &e), &e);
		REQUIRE_OK(slice_at(f, z[i], &ref, NULL, &e), &e);
		slice_free(f);
		CHECK_EQ_INT(reg.n, 1);
		CHECK_EQ_INT(paths_point_count(&reg), paths_point_count(&ref));
		CHECK_NEAR(paths_area_mm2(&reg), paths_area_mm2(&ref), 0);
		CHECK_NUM(paths_area_mm2(&reg), >, 0.5);
	}
	paths_fini(&reg);
	paths_fini(&ref);
	slice_free(s);
	tm_free(m);
}

static void test_bad_input(void)
{
	struct mesh *m = tm_new();
	struct slicer *s = NULL;
	struct paths reg;
	struct err e;
	uint32_t saved;

	paths_init(&reg);
	err_clear(&e);
	tm_box(m, 0, 0, 0, 1, 1, 1);
	saved = m->tri[7];
	m->tri[7] = 99;
	CHECK_EQ_INT(slice_new(m, &s, &e), ERR_GEOMETRY);
	CHECK_EQ_INT(e.item, 2);
	CHECK_CONTAINS(e.msg, "triangle 2");
	m->tri[7] = saved;
	m->v[3].y = NAN;
	err_clear(&e);
	CHECK_EQ_INT(slice_new(m, &s, &e), ERR_GEOMETRY);
	CHECK_CONTAINS(e.msg, "vertex 3");
	m->v[3].y = 1;
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	CHECK_EQ_INT(slice_at(s, NAN, &reg, NULL, &e), ERR_PARAM);
	slice_free(s);
	slice_free(NULL);

	/* Degenerate triangles are skipped; an empty mesh slices to nothing. */
	tm_tri(m, 0, 0, 5);
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 0.5, &reg, NULL, &e), &e);
	CHECK_NEAR(paths_area_mm2(&reg), 1, 1e-12);
	slice_free(s);
	m->nt = 0;
	REQUIRE_OK(slice_new(m, &s, &e), &e);
	REQUIRE_OK(slice_at(s, 0.5, &reg, NULL, &e), &e);
	CHECK_EQ_INT(reg.n, 0);
	slice_free(s);
	paths_fini(&reg);
	tm_free(m);
}

/* Every allocation failure is reported as ERR_NOMEM, without leaks
 * (ASan checks the latter). */
static void test_alloc_failures(void)
{
	struct mesh *m = tm_icosphere(v3(0, 0, 5), 5, 2);
	int n, failed = 0;

	/* open the sphere so the chain closing runs too */
	tm_delete_tri(m, 7);
	for (n = 1; n < 400; n++) {
		struct slicer *s = NULL;
		struct paths reg;
		struct err e;
		int rc;

		paths_init(&reg);
		err_clear(&e);
		mem_fail_after(n);
		rc = slice_new(m, &s, &e);
		for (int k = 0; !rc && k < 10; k++)
			rc = slice_at(s, 0.5 + k, &reg, NULL, &e);
		mem_fail_after(-1);
		slice_free(s);
		paths_fini(&reg);
		if (rc) {
			CHECK_EQ_INT(rc, ERR_NOMEM);
			failed++;
		} else {
			break;
		}
	}
	CHECK_INT(failed, >, 10);
	CHECK_INT(n, <, 400);
	tm_free(m);
}

int main(void)
{
	RUN(test_schedule);
	RUN(test_cube);
	RUN(test_staircase);
	RUN(test_sphere);
	RUN(test_torus);
	RUN(test_inside_out);
	RUN(test_open_mesh);
	RUN(test_windows);
	RUN(test_nonmanifold);
	RUN(test_restart);
	RUN(test_bad_input);
	RUN(test_alloc_failures);
	return harness_report();
}
