/* test_analyze.c - weld, analyze, repair and place, checked against independent values.
 *
 * Volumes and areas against closed forms (box, tetrahedron, regular
 * icosahedron, sphere limit), topology against the figures in
 * ../shared/meshes/README.md and an Euler characteristic computed here
 * with a separate edge count; repair against deliberately damaged copies;
 * placement against the six axis rotations of the asymmetric P.off.
 */
#include "harness.h"

#include "mesh_fixtures.h"

static struct mesh *load(const char *rel)
{
	struct mesh *m = NULL;
	struct err e;
	char path[256];

	snprintf(path, sizeof path, "meshes/%s", rel);
	err_clear(&e);
	if (mesh_read_file(shared_path(path), MESH_FMT_AUTO, &m, NULL, &e) != 0)
		fprintf(stderr, "%s: %s\n", rel, e.msg);
	return m;
}

static void test_closed_forms(void)
{
	struct mesh *m;
	struct mesh_report r;
	struct err e;
	double a, t = (1 + sqrt(5.0)) / 2;

	m = fx_box(2, 3, 5, -7, 1, 100);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_NEAR(r.volume_mm3, 30, 1e-12);
	CHECK_NEAR(r.area_mm2, 2 * (6 + 10 + 15), 1e-12);
	CHECK(r.watertight);
	CHECK_EQ_INT(r.edges, 18);
	CHECK_EQ_INT(r.components, 1);
	CHECK_NEAR(r.bbox.lo.x, -7, 0);
	CHECK_NEAR(r.bbox.hi.z, 105, 0);
	mesh_free(m);

	m = fx_tetra(3, 2, 1, v3(10, 20, 30));
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_NEAR(r.volume_mm3, 1.0, 1e-12);
	CHECK(r.watertight);
	mesh_free(m);

	/* Regular icosahedron, circumradius R: edge a = R / sin(2 pi / 5),
	 * V = 5 (3 + sqrt 5) a^3 / 12, area = 5 sqrt(3) a^2. */
	m = fx_icosphere(2.0, 0);
	REQUIRE_OK(mesh_weld(m, 0, NULL, NULL, &e), &e);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	a = 2.0 / sin(2 * M_PI / 5);
	CHECK_REL(r.volume_mm3, 5 * (3 + sqrt(5.0)) * a * a * a / 12, 1e-12);
	CHECK_REL(r.area_mm2, 5 * sqrt(3.0) * a * a, 1e-12);
	CHECK_EQ_INT(r.vertices, 12);
	CHECK(r.watertight);
	(void)t;
	mesh_free(m);

	/* Subdivided icosphere: below the sphere's volume, converging to it. */
	m = fx_icosphere(10.0, 4);
	REQUIRE_OK(mesh_weld(m, 0, NULL, NULL, &e), &e);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_NUM(r.volume_mm3, <, 4.0 / 3 * M_PI * 1000);
	CHECK_REL(r.volume_mm3, 4.0 / 3 * M_PI * 1000, 3e-3);
	CHECK_EQ_INT(r.vertices - r.edges + r.triangles, 2);
	CHECK(r.watertight);
	mesh_free(m);
}

static void test_weld(void)
{
	struct mesh *m = fx_icosphere(1.0, 2), *c;
	struct err e;
	size_t merged, dropped, nt = m->nt;

	/* 320 triangles as a soup of 960 corners -> 162 vertices */
	REQUIRE_OK(mesh_weld(m, 0, &merged, &dropped, &e), &e);
	CHECK_EQ_INT(m->nv, 162);
	CHECK_EQ_INT(merged, 960 - 162);
	CHECK_EQ_INT(dropped, 0);
	CHECK_EQ_INT(m->nt, nt);
	/* -0 and +0 weld; a triangle collapsing to a repeated index is dropped */
	c = mesh_new();
	mesh_add_vertex(c, v3(0, 0, 0));
	mesh_add_vertex(c, v3(-0.0, 0, -0.0));
	mesh_add_vertex(c, v3(1, 0, 0));
	mesh_add_vertex(c, v3(0, 1, 0));
	mesh_add_vertex(c, v3(1 + 1e-9, 0, 0));
	mesh_add_triangle(c, 0, 2, 3);
	mesh_add_triangle(c, 1, 2, 0);
	mesh_add_triangle(c, 0, 4, 3);
	REQUIRE_OK(mesh_weld(c, 0, &merged, &dropped, &e), &e);
	CHECK_EQ_INT(c->nv, 4);
	CHECK_EQ_INT(merged, 1);
	CHECK_EQ_INT(dropped, 1);
	CHECK_EQ_INT(c->nt, 2);
	/* tolerance: 1e-9 apart merges at 1e-6, and the two triangles coincide */
	REQUIRE_OK(mesh_weld(c, 1e-6, &merged, &dropped, &e), &e);
	CHECK_EQ_INT(c->nv, 3);
	CHECK_EQ_INT(merged, 1);
	CHECK_EQ_INT(c->tri[3], c->tri[0]);
	CHECK_EQ_INT(mesh_weld(c, -1, NULL, NULL, &e), ERR_PARAM);
	CHECK_STR(e.field, "tol_mm");
	mesh_free(c);
	/* tolerance weld of a jittered soup: each corner within 1e-7 of its
	 * true position; tol 1e-5 (far below edge lengths) recovers 162 */
	c = fx_icosphere(1.0, 2);
	{
		size_t i;
		srand(7);
		for (i = 0; i < c->nv; i++)
			c->v[i] = v3_add(c->v[i], v3(1e-7 * (rand() / (double)RAND_MAX - 0.5),
						     1e-7 * (rand() / (double)RAND_MAX - 0.5),
						     1e-7 * (rand() / (double)RAND_MAX - 0.5)));
	}
	REQUIRE_OK(mesh_weld(c, 1e-5, &merged, &dropped, &e), &e);
	CHECK_EQ_INT(c->nv, 162);
	mesh_free(c);
	mesh_free(m);
}

struct shared_fig {
	const char *file;
	size_t triangles, border;
	int watertight;
	long euler; /* V - E + F after welding; 99 = not checked */
};

static void test_shared_meshes(void)
{
	static const struct shared_fig figs[] = {
		{"bunny.stl", 69451, 223, 0, 99},
		{"mushroom.off", 4608, 64, 0, 99},
		{"ChineseDragon-10kv.off", 19994, 6, 0, 99},
		{"armadillo.off", 52000, 0, 1, 2},
		{"camel.off", 19536, 0, 1, 2},
		{"femur.off", 7798, 0, 1, 99},
		{"cow.off", 5804, 0, 1, 99},
		{"knot1.off", 6400, 0, 1, 0}, /* genus 1: torus */
		{"gearwheel.stl", 2444, 0, 1, 99},
		{"P.off", 52, 0, 1, 0}, /* the P has a hole: genus 1 */
	};
	size_t i;

	for (i = 0; i < sizeof figs / sizeof figs[0]; i++) {
		struct mesh *m = load(figs[i].file);
		struct mesh_report r;
		struct err e;
		if (!m) {
			CHECK(m != NULL);
			continue;
		}
		REQUIRE_OK(mesh_repair(m, &r, &e), &e);
		CHECK_EQ_INT(r.triangles, figs[i].triangles);
		if (r.border_edges != figs[i].border || r.watertight != figs[i].watertight)
			fprintf(stderr, "%s\n", figs[i].file);
		CHECK_EQ_INT(r.border_edges, figs[i].border);
		CHECK_EQ_INT(r.watertight, figs[i].watertight);
		CHECK_EQ_INT(r.nonmanifold_edges, 0);
		CHECK_EQ_INT(r.inconsistent_edges, 0);
		CHECK_EQ_INT(r.edges, fx_count_edges(m));
		if (figs[i].euler != 99)
			CHECK_EQ_INT((long)m->nv - (long)fx_count_edges(m) + (long)m->nt,
				     figs[i].euler);
		if (figs[i].watertight)
			CHECK_NUM(r.volume_mm3, >, 0);
		mesh_free(m);
	}
}

/* Signed volume computed here, about the origin (independent code). */
static double volume_here(const struct mesh *m)
{
	double v = 0;
	size_t t;

	for (t = 0; t < m->nt; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], b = m->v[m->tri[3 * t + 1]],
			    c = m->v[m->tri[3 * t + 2]];
		v += a.x * (b.y * c.z - b.z * c.y) - a.y * (b.x * c.z - b.z * c.x) +
		     a.z * (b.x * c.y - b.y * c.x);
	}
	return v / 6;
}

static void flip(struct mesh *m, size_t t)
{
	uint32_t x = m->tri[3 * t + 1];

	m->tri[3 * t + 1] = m->tri[3 * t + 2];
	m->tri[3 * t + 2] = x;
}

static void test_repair(void)
{
	struct mesh *m = load("armadillo.off"), *box, *cav;
	struct mesh_report r;
	struct err e;
	double v0;
	size_t t, flipped = 0;

	REQUIRE(m);
	v0 = volume_here(m);
	/* flip a random third of the faces: repair must restore all of them */
	srand(3);
	for (t = 0; t < m->nt; t++)
		if (rand() % 3 == 0) {
			flip(m, t);
			flipped++;
		}
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_INT(r.inconsistent_edges, >, 0);
	REQUIRE_OK(mesh_repair(m, &r, &e), &e);
	CHECK_EQ_INT(r.reoriented_faces, flipped);
	CHECK_EQ_INT(r.flipped, 0);
	CHECK(r.watertight);
	CHECK_REL(volume_here(m), v0, 1e-9);
	/* inside out as a whole */
	for (t = 0; t < m->nt; t++)
		flip(m, t);
	REQUIRE_OK(mesh_repair(m, &r, &e), &e);
	CHECK_EQ_INT(r.flipped, 1);
	CHECK_EQ_INT(r.flipped_components, 1);
	CHECK_EQ_INT(r.reoriented_faces, 0);
	CHECK_REL(r.volume_mm3, v0, 1e-9);
	mesh_free(m);

	/* A box with a cavity (inner box, inward), written wrongly (both
	 * outward), plus a separate inside-out tetrahedron elsewhere and a
	 * duplicated soup + a zero-area face. */
	box = fx_box(10, 10, 10, 0, 0, 0);
	cav = fx_box(4, 4, 4, 3, 3, 3);
	{
		size_t k, base = box->nv;
		struct mesh *tet = fx_tetra(1, 1, 1, v3(50, 0, 0));
		for (k = 0; k < cav->nv; k++)
			mesh_add_vertex(box, cav->v[k]);
		for (k = 0; k < cav->nt; k++)
			mesh_add_triangle(box, (uint32_t)(base + cav->tri[3 * k]),
					  (uint32_t)(base + cav->tri[3 * k + 1]),
					  (uint32_t)(base + cav->tri[3 * k + 2]));
		base = box->nv;
		for (k = 0; k < tet->nv; k++)
			mesh_add_vertex(box, tet->v[k]);
		for (k = 0; k < tet->nt; k++)
			mesh_add_triangle(box, (uint32_t)(base + tet->tri[3 * k]),
					  (uint32_t)(base + tet->tri[3 * k + 2]),
					  (uint32_t)(base + tet->tri[3 * k + 1]));
		mesh_add_vertex(box, v3(60, 0, 0));
		mesh_add_vertex(box, v3(61, 0, 0));
		mesh_add_vertex(box, v3(62, 0, 0));
		mesh_add_triangle(box, (uint32_t)box->nv - 3, (uint32_t)box->nv - 2,
				  (uint32_t)box->nv - 1);
		mesh_free(tet);
	}
	REQUIRE_OK(mesh_repair(box, &r, &e), &e);
	CHECK_EQ_INT(r.components, 3);
	CHECK_EQ_INT(r.flipped_components, 2); /* cavity turned inward, tetra outward */
	CHECK_EQ_INT(r.dropped_triangles, 1);  /* the collinear face */
	CHECK_EQ_INT(r.degenerate_faces, 0);
	CHECK(r.watertight);
	CHECK_NEAR(r.volume_mm3, 1000 - 64 + 1.0 / 6, 1e-9);
	CHECK_NEAR(volume_here(box), 1000 - 64 + 1.0 / 6, 1e-9);
	mesh_free(box);
	mesh_free(cav);
}

static double up_coord(struct vec3 q, int up)
{
	switch (up) {
	case MESH_UP_Z: return q.z;
	case MESH_UP_NZ: return -q.z;
	case MESH_UP_Y: return q.y;
	case MESH_UP_NY: return -q.y;
	case MESH_UP_X: return q.x;
	default: return -q.x;
	}
}

/* A closed box whose front face got a vertex m on its bottom edge 0-1
 * (T-junction) closed by the zero-area cap (0, 1, m): repair must keep it
 * closed by splitting the bottom face at m, not punch a hole. */
static void test_repair_cap(void)
{
	struct mesh *m = fx_box(4, 2, 3, 0, 0, 0);
	struct mesh_report r;
	struct err e;
	size_t t;
	uint32_t mid;

	REQUIRE(m);
	mid = (uint32_t)m->nv;
	mesh_add_vertex(m, v3(1, 0, 0)); /* on edge (0,0,0)-(4,0,0), off-centre */
	for (t = 0; t < m->nt; t++) /* front face (0, 1, 5) -> (0, m, 5) + (m, 1, 5) */
		if (m->tri[3 * t] == 0 && m->tri[3 * t + 1] == 1 && m->tri[3 * t + 2] == 5)
			m->tri[3 * t + 1] = mid;
	mesh_add_triangle(m, mid, 1, 5);
	mesh_add_triangle(m, 0, 1, mid); /* the cap */
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK(r.watertight);
	CHECK_EQ_INT(r.degenerate_faces, 1);
	REQUIRE_OK(mesh_repair(m, &r, &e), &e);
	CHECK_EQ_INT(r.degenerate_faces, 0);
	CHECK_EQ_INT(r.dropped_triangles, 1);
	CHECK_EQ_INT(r.triangles, 14);
	CHECK(r.watertight);
	CHECK_NEAR(r.volume_mm3, 24, 1e-12);
	CHECK_NEAR(r.area_mm2, 2 * (8 + 12 + 6), 1e-12);
	mesh_free(m);
}

/* P.off is 3 x 5 x 1 (x, y, z); its bowl (the P's loop) is at high y. */
static void test_place_axes(void)
{
	static const struct {
		int up;
		double ex, ey, ez; /* expected extents */
	} cases[] = {
		{MESH_UP_Z, 3, 5, 1},  {MESH_UP_NZ, 3, 5, 1}, {MESH_UP_Y, 3, 1, 5},
		{MESH_UP_NY, 3, 1, 5}, {MESH_UP_X, 1, 5, 3},  {MESH_UP_NX, 1, 5, 3},
	};
	size_t i, k;

	for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		struct mesh *m = load("P.off"), *orig;
		struct mesh_placement p = {MESH_UNITS_CM, 2.0, 0, cases[i].up, 60, 30};
		struct mesh_report r;
		struct err e;
		double v0;
		REQUIRE(m);
		orig = mesh_clone(m);
		v0 = volume_here(m);
		REQUIRE_OK(mesh_place(m, &p, &e), &e);
		REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
		/* cm -> mm (x10) and scale 2: extents x20; volume x8000, same sign */
		CHECK_NEAR(r.bbox.hi.x - r.bbox.lo.x, 20 * cases[i].ex, 1e-9);
		CHECK_NEAR(r.bbox.hi.y - r.bbox.lo.y, 20 * cases[i].ey, 1e-9);
		CHECK_NEAR(r.bbox.hi.z - r.bbox.lo.z, 20 * cases[i].ez, 1e-9);
		CHECK_NEAR(r.bbox.lo.z, 0, 0);
		CHECK_NEAR(0.5 * (r.bbox.lo.x + r.bbox.hi.x), 60, 1e-9);
		CHECK_NEAR(0.5 * (r.bbox.lo.y + r.bbox.hi.y), 30, 1e-9);
		CHECK_REL(volume_here(m), 8000 * v0, 1e-12);
		/* the file's up axis is +z now: new z = 20 (u - min u), with u the
		 * file coordinate along `up` (sign included) */
		{
			double umin = INFINITY;
			for (k = 0; k < orig->nv; k++)
				umin = fmin(umin, up_coord(orig->v[k], cases[i].up));
			for (k = 0; k < m->nv; k++)
				CHECK_NEAR(m->v[k].z, 20 * (up_coord(orig->v[k], cases[i].up) - umin),
					   1e-9);
		}
		mesh_free(orig);
		mesh_free(m);
	}
}

static void test_place_units_height_errors(void)
{
	static const double mm[] = {1, 10, 1000, 25.4};
	struct mesh *m;
	struct mesh_placement p;
	struct mesh_report r;
	struct err e;
	int u;

	for (u = MESH_UNITS_MM; u <= MESH_UNITS_IN; u++) {
		m = fx_box(1, 2, 4, 5, 5, 5);
		p = (struct mesh_placement){u, 1.0, 0, MESH_UP_Z, 0, 0};
		REQUIRE_OK(mesh_place(m, &p, &e), &e);
		REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
		CHECK_NEAR(r.bbox.hi.z, 4 * mm[u], 1e-9);
		CHECK_NEAR(r.bbox.lo.x, -0.5 * mm[u], 1e-12);
		mesh_free(m);
	}
	/* height overrides units and scale */
	m = fx_box(1, 2, 4, 0, 0, 0);
	p = (struct mesh_placement){MESH_UNITS_M, 3.0, 50, MESH_UP_Y, 10, 10};
	REQUIRE_OK(mesh_place(m, &p, &e), &e);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_NEAR(r.bbox.hi.z, 50, 1e-12);
	CHECK_NEAR(r.bbox.hi.x - r.bbox.lo.x, 25, 1e-12);
	p.scale = 0;
	CHECK_EQ_INT(mesh_place(m, &p, &e), ERR_PARAM);
	CHECK_STR(e.field, "scale");
	p.scale = 1;
	p.up = 9;
	CHECK_EQ_INT(mesh_place(m, &p, &e), ERR_PARAM);
	CHECK_STR(e.field, "up");
	p.up = MESH_UP_Z;
	p.units = 7;
	CHECK_EQ_INT(mesh_place(m, &p, &e), ERR_PARAM);
	mesh_free(m);
	/* flat part: zero height */
	m = mesh_new();
	mesh_add_vertex(m, v3(0, 0, 0));
	mesh_add_vertex(m, v3(1, 0, 0));
	mesh_add_vertex(m, v3(0, 1, 0));
	mesh_add_triangle(m, 0, 1, 2);
	p = (struct mesh_placement){MESH_UNITS_MM, 1, 0, MESH_UP_Z, 0, 0};
	CHECK_EQ_INT(mesh_place(m, &p, &e), ERR_GEOMETRY);
	CHECK_CONTAINS(e.msg, "zero height");
	m->nt = 0;
	CHECK_EQ_INT(mesh_place(m, &p, &e), ERR_GEOMETRY);
	mesh_free(m);
}

int main(void)
{
	RUN(test_closed_forms);
	RUN(test_weld);
	RUN(test_shared_meshes);
	RUN(test_repair);
	RUN(test_repair_cap);
	RUN(test_place_axes);
	RUN(test_place_units_height_errors);
	return harness_report();
}
