/* test_tetra.c - the TetGen shim: Delaunay volumes, constrained meshing of a
 * cube, and self-intersecting input reported as an error (never a crash). */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/geom/vec.h"
#include "engine/mesh/mesh.h"
#include "engine/mesh/tetra.h"

static double tet_volume(const struct tetra_mesh *t, size_t k)
{
	const double *p[4];
	struct vec3 a, b, c;

	for (int i = 0; i < 4; i++)
		p[i] = t->xyz + 3 * t->tet[4 * k + i];
	a = v3(p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
	b = v3(p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
	c = v3(p[3][0] - p[0][0], p[3][1] - p[0][1], p[3][2] - p[0][2]);
	return v3_dot(a, v3_cross(b, c)) / 6;
}

static double rnd(unsigned long long *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*s >> 11) / 9007199254740992.0;
}

static void test_delaunay_fills_the_hull(void)
{
	struct err e;
	struct tetra_mesh t;
	double xyz[3 * 208], vol = 0, vmin = 1;
	unsigned long long seed = 3;
	size_t n = 0;

	for (int c = 0; c < 8; c++) { /* the cube's corners bound the hull */
		xyz[3 * n] = 2.0 * (c & 1);
		xyz[3 * n + 1] = 2.0 * ((c >> 1) & 1);
		xyz[3 * n + 2] = 2.0 * ((c >> 2) & 1);
		n++;
	}
	for (int i = 0; i < 200; i++, n++)
		for (int k = 0; k < 3; k++)
			xyz[3 * n + k] = 2 * rnd(&seed);
	REQUIRE_OK(tetra_delaunay(xyz, n, &t, &e), &e);
	CHECK_EQ_INT(t.npoints, n);
	CHECK_INT(t.ntets, >, n);
	for (size_t k = 0; k < t.ntets; k++) {
		double v = tet_volume(&t, k);
		vol += fabs(v);
		vmin = fmin(vmin, v);
	}
	CHECK_NUM(vmin, >, 0); /* every tet positively oriented */
	CHECK_NEAR(vol, 8.0, 1e-9);
	fprintf(stderr, "delaunay: %zu tets, total volume %.12f\n", t.ntets, vol);
	tetra_mesh_fini(&t);
	tetra_mesh_fini(&t); /* idempotent */
}

static void test_degenerate_points(void)
{
	struct err e;
	struct tetra_mesh t;
	double flat[3 * 5] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5, 0.3, 0};
	double few[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};

	CHECK_EQ_INT(tetra_delaunay(flat, 5, &t, &e), ERR_GEOMETRY);
	CHECK_EQ_INT(tetra_delaunay(few, 3, &t, &e), ERR_GEOMETRY);
	CHECK(t.xyz == NULL && t.tet == NULL);
}

/* Unit cube surface, outward-facing triangles. */
static struct vec3 cube_v[16];
static uint32_t cube_t[2 * 36];
static void cube(struct mesh *m, double s, struct vec3 o, size_t off_v, size_t off_t)
{
	static const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4},
				     {1, 5, 4}, {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6},
				     {1, 3, 5}, {3, 7, 5}};
	for (int c = 0; c < 8; c++)
		cube_v[off_v + c] = v3(o.x + s * (c & 1), o.y + s * ((c >> 1) & 1),
				       o.z + s * ((c >> 2) & 1));
	for (int i = 0; i < 12; i++)
		for (int k = 0; k < 3; k++)
			cube_t[3 * (off_t + i) + k] = (uint32_t)(off_v + f[i][k]);
	m->v = cube_v;
	m->tri = cube_t;
}

static void test_volume_mesh_of_cube(void)
{
	struct err e;
	struct mesh m;
	struct tetra_mesh t;
	struct tetra_opts o = {1.5, 0.01, NULL};
	double vol = 0;
	size_t pairs = 99;

	cube(&m, 1.0, v3(0, 0, 0), 0, 0);
	m.nv = 8;
	m.nt = 12;
	REQUIRE_OK(tetra_self_intersections(&m, &pairs, &e), &e);
	CHECK_EQ_INT(pairs, 0);
	REQUIRE_OK(tetra_mesh_volume(&m, &o, &t, &e), &e);
	for (size_t k = 0; k < t.ntets; k++) {
		double v = tet_volume(&t, k);
		CHECK_NUM(fabs(v), <=, 0.01 + 1e-12);
		vol += fabs(v);
	}
	CHECK_INT(t.ntets, >=, 100);
	CHECK_NEAR(vol, 1.0, 1e-9);
	tetra_mesh_fini(&t);
}

/* Two interpenetrating cubes in one surface: TetGen's check finds the
 * intersections and the meshing call returns an error. */
static void test_self_intersection_reported(void)
{
	struct err e;
	struct mesh m;
	struct tetra_mesh t;
	size_t pairs = 0;
	int rc;

	cube(&m, 1.0, v3(0, 0, 0), 0, 0);
	cube(&m, 1.0, v3(0.5, 0.4, 0.3), 8, 12);
	m.nv = 16;
	m.nt = 24;
	REQUIRE_OK(tetra_self_intersections(&m, &pairs, &e), &e);
	fprintf(stderr, "intersecting face pairs: %zu\n", pairs);
	CHECK_INT(pairs, >, 0);
	rc = tetra_mesh_volume(&m, NULL, &t, &e);
	CHECK_EQ_INT(rc, ERR_GEOMETRY);
	CHECK_CONTAINS(e.msg, "intersects itself");
	CHECK(t.tet == NULL);
}

int main(void)
{
	RUN(test_delaunay_fills_the_hull);
	RUN(test_degenerate_points);
	RUN(test_volume_mesh_of_cube);
	RUN(test_self_intersection_reported);
	return harness_report();
}
