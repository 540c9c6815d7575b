/* test_tree.c - the rhombic hierarchy (engine/rhombic/tree.c, carve.c,
 * classify.c) against independent geometry: the root holds the part (eq.
 * 3) with the aspect of eq. 1; children tile their parent exactly
 * (volumes, and point location agreeing with brute-force rhombus tests
 * over every leaf); a cavity's layer rectangle equals the plane section
 * of its prism computed from the prism's edges; the cavity is the cell
 * offset by t (distance to the cell's faces); classification of a box
 * (cells inside keep the skin, cells across its faces are boundary);
 * the carved mesh is a closed 2-manifold of the expected volume.
 */
#include "harness.h"
#include "unit/slice/meshgen.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/rhombic/optimize.h"
#include "engine/rhombic/rhombic.h"

static uint64_t rng = 0x243f6a8885a308d3ULL;
static double urand(void)
{
	return (double)(harness_xorshift64(&rng) >> 11) / 9007199254740992.0;
}

static struct mesh *box_mesh(double x0, double y0, double z0, double x1, double y1, double z1)
{
	struct mesh *m = tm_new();
	tm_box(m, x0, y0, z0, x1, y1, z1);
	return m;
}

/* Leaf contains (u, z, v) by the rhombus inequality (brute force). */
static int in_cell(const struct rh_frame *f, const struct rh_cell *c, double u, double z, double v)
{
	struct rh_geom g;
	rh_cell_geom(f, c, &g);
	return fabs(u - g.cu) / g.a + fabs(z - g.cz) / g.b < 1 && v >= g.vlo && v < g.vhi;
}

static void test_root(void)
{
	struct mesh *m = box_mesh(10, 20, 0, 110, 70, 6.25);
	static const double alphas[] = {30, 45, 60};
	static const double orients[] = {0, 15, 90, 135};

	for (size_t ia = 0; ia < 3; ia++)
		for (size_t io = 0; io < 4; io++) {
			struct rh_frame f;
			double alpha = alphas[ia] * M_PI / 180;
			rh_frame_init(&f, m, alpha, orients[io], 1.0, 1.2);
			/* eq. 1 */
			CHECK_NEAR(f.b0_mm / f.a0_mm, tan(M_PI / 2 - alpha), 1e-12);
			/* eq. 3: the inner box (w/2 along u, h/2 along z) holds every vertex */
			for (size_t i = 0; i < m->nv; i++) {
				double u, v;
				rh_to_cell(&f, m->v[i].x, m->v[i].y, &u, &v);
				CHECK(fabs(u - f.cu_mm) <= f.a0_mm / 2 + 1e-9);
				CHECK(fabs(m->v[i].z - f.cz_mm) <= f.b0_mm / 2 + 1e-9);
				CHECK(v >= f.v0_mm - 1.2 - 1e-9 && v <= f.v0_mm + f.e_mm + 1.2 + 1e-9);
			}
			/* extrusion: between w_L / 2 and w_L once v is cut */
			for (int L = 0; L <= f.max_level; L++) {
				double ev = ldexp(f.e_mm, -f.vsplit[L]), wl = ldexp(2 * f.a0_mm, -L);
				CHECK(ev <= wl || f.vsplit[L] == 0);
				if (f.vsplit[L] > 0)
					CHECK(ev > wl / 2 - 1e-12);
				CHECK(rh_face_distance(ldexp(f.a0_mm, -L), ldexp(f.b0_mm, -L)) >= 2.0);
				CHECK(ev >= 2.0);
			}
		}
	tm_free(m);
}

static void test_tiling_and_location(void)
{
	struct mesh *m = box_mesh(0, 0, 0, 80, 40, 50);
	struct rh_frame f;
	struct rh_tree t;
	struct err e;

	err_clear(&e);
	rh_frame_init(&f, m, 40 * M_PI / 180, 30, 0.5, 0.5);
	rh_tree_init(&t, &f);
	REQUIRE(f.max_level >= 4);
	REQUIRE_OK(rh_tree_roots(&t, &e), &e);
	for (int32_t k = 0; k < t.nroots; k++)
		t.c[k].state = RH_CAVITY;
	/* random splits, checking each split's children tile the parent */
	for (int it = 0; it < 300; it++) {
		int32_t idx = (int32_t)(urand() * (double)t.n);
		struct rh_geom pg;
		double vol = 0;
		if (t.c[idx].state != RH_CAVITY || !rh_tree_can_split(&t, idx))
			continue;
		REQUIRE_OK(rh_tree_split(&t, idx, &e), &e);
		rh_cell_geom(&f, &t.c[idx], &pg);
		for (int c = 0; c < t.c[idx].nchild; c++) {
			struct rh_cell *ch = &t.c[t.c[idx].child + c];
			struct rh_geom g;
			ch->state = RH_CAVITY;
			rh_cell_geom(&f, ch, &g);
			vol += 2 * g.a * g.b * (g.vhi - g.vlo);
			/* each child's corners lie in the parent */
			CHECK(fabs(g.cu - pg.cu) / pg.a + fabs(g.cz - pg.cz) / pg.b <= 0.5 + 1e-12);
			CHECK(g.vlo >= pg.vlo - 1e-9 && g.vhi <= pg.vhi + 1e-9);
		}
		CHECK_REL(vol, 2 * pg.a * pg.b * (pg.vhi - pg.vlo), 1e-12);
	}
	CHECK(rh_tree_levels(&t) >= 4);
	/* point location = the one leaf whose rhombus holds the point */
	for (int it = 0; it < 3000; it++) {
		double u = f.cu_mm + (2 * urand() - 1) * f.a0_mm;
		double z = f.cz_mm + (2 * urand() - 1) * f.b0_mm;
		double v = f.v0_mm + urand() * f.e_mm, x, y;
		int32_t got, want = -1;
		int hits = 0;
		rh_to_printer(&f, u, v, &x, &y);
		got = rh_tree_locate(&t, x, y, z);
		for (size_t i = 0; i < t.n; i++)
			if (t.c[i].state == RH_CAVITY && in_cell(&f, &t.c[i], u, z, v)) {
				want = (int32_t)i;
				hits++;
			}
		if (fabs(u - f.cu_mm) / f.a0_mm + fabs(z - f.cz_mm) / f.b0_mm < 1) {
			CHECK_EQ_INT(hits, 1);
			CHECK_EQ_INT(got, want);
		} else {
			CHECK_EQ_INT(hits, 0);
		}
	}
	/* outside the root: nothing */
	CHECK_EQ_INT(rh_tree_locate(&t, 1e4, 1e4, 1e4), -1);
	rh_tree_fini(&t);
	tm_free(m);
}

/* Plane section of a cavity prism from its 12 edges: the intersection
 * points' convex hull area (the points are the section's corners). */
static double section_area_by_edges(const struct rh_frame *f, const struct rh_cavity *cv,
				    double z)
{
	double du[4] = {cv->a * cv->k, 0, -cv->a * cv->k, 0};
	double dz[4] = {0, cv->b * cv->k, 0, -cv->b * cv->k};
	double P[8][3], pts[16][2], cx = 0, cy = 0, area = 0;
	int n = 0, edges[12][2];

	for (int c = 0; c < 8; c++) {
		double x, y;
		rh_to_printer(f, cv->cu + du[c & 3], c < 4 ? cv->vlo : cv->vhi, &x, &y);
		P[c][0] = x;
		P[c][1] = y;
		P[c][2] = cv->cz + dz[c & 3];
	}
	for (int c = 0; c < 4; c++) {
		edges[c][0] = c, edges[c][1] = (c + 1) % 4;
		edges[4 + c][0] = 4 + c, edges[4 + c][1] = 4 + (c + 1) % 4;
		edges[8 + c][0] = c, edges[8 + c][1] = c + 4;
	}
	for (int k = 0; k < 12; k++) {
		double *a = P[edges[k][0]], *b = P[edges[k][1]];
		if ((a[2] - z) * (b[2] - z) < 0) {
			double s = (z - a[2]) / (b[2] - a[2]);
			pts[n][0] = a[0] + s * (b[0] - a[0]);
			pts[n][1] = a[1] + s * (b[1] - a[1]);
			cx += pts[n][0];
			cy += pts[n][1];
			n++;
		}
	}
	if (n < 3)
		return 0;
	cx /= n;
	cy /= n;
	/* sort by angle about the centroid, then the shoelace formula */
	for (int i = 0; i < n; i++)
		for (int j = i + 1; j < n; j++)
			if (atan2(pts[j][1] - cy, pts[j][0] - cx) < atan2(pts[i][1] - cy, pts[i][0] - cx)) {
				double t0 = pts[i][0], t1 = pts[i][1];
				pts[i][0] = pts[j][0], pts[i][1] = pts[j][1];
				pts[j][0] = t0, pts[j][1] = t1;
			}
	for (int i = 0; i < n; i++)
		area += pts[i][0] * pts[(i + 1) % n][1] - pts[(i + 1) % n][0] * pts[i][1];
	return area / 2;
}

static void test_cavity_section(void)
{
	struct mesh *m = box_mesh(0, 0, 0, 60, 30, 40);
	struct rh_frame f;
	struct rh_tree t;
	struct rh_carve cr;
	struct paths rects;
	struct err e;

	err_clear(&e);
	paths_init(&rects);
	rh_frame_init(&f, m, 45 * M_PI / 180, 25, 1.0, 1.0);
	rh_tree_init(&t, &f);
	REQUIRE_OK(rh_tree_roots(&t, &e), &e);
	REQUIRE_OK(rh_tree_split(&t, 0, &e), &e);
	REQUIRE_OK(rh_tree_split(&t, t.c[0].child + 1, &e), &e);
	for (size_t i = 0; i < t.n; i++)
		if (t.c[i].state == RH_OUT)
			t.c[i].state = RH_CAVITY;
	rh_tree_recount(&t);
	REQUIRE_OK(rh_carve_init(&cr, &t, &e), &e);
	REQUIRE(cr.n == t.cavities);
	for (size_t q = 0; q < cr.n; q++) {
		const struct rh_cavity *cv = &cr.cv[q];
		/* the cavity face lies t from the cell face: the cavity's corner
		 * (cu + a k, cz) is t from the cell edge p + q = 1 */
		double dist = (cv->a - cv->a * cv->k) * cv->b / sqrt(cv->a * cv->a + cv->b * cv->b);
		CHECK_NEAR(dist, f.t_mm, 1e-9);
		CHECK_NEAR(cv->volume_mm3, 2 * cv->a * cv->b * cv->k * cv->k * (cv->vhi - cv->vlo),
			   1e-9);
	}
	/* sweep z upwards: every layer's rectangles equal the sections */
	for (double z = -5; z < 45; z += 0.37) {
		double want = 0, got;
		REQUIRE_OK(rh_carve_rects(&cr, z, &rects, &e), &e);
		for (size_t q = 0; q < cr.n; q++)
			want += section_area_by_edges(&f, &cr.cv[q], z);
		got = paths_area_mm2(&rects);
		CHECK_NEAR(got, want, 1e-6 * (1 + want));
		for (size_t i = 0; i < rects.n; i++)
			CHECK(path_area_mm2(&rects.v[i]) > 0); /* counter-clockwise */
	}
	rh_carve_fini(&cr);
	paths_fini(&rects);
	rh_tree_fini(&t);
	tm_free(m);
}

static void test_classify_box(void)
{
	const double X = 40, Y = 24, Z = 30, skin = 1.0, wall = 1.0, vox = 0.25;
	struct mesh *m = box_mesh(0, 0, 0, X, Y, Z);
	struct rh_vox vx;
	struct rh_frame f;
	struct rh_tree t;
	struct mesh *out = NULL;
	struct rh_carve cr;
	struct mesh_report rep;
	struct err e;
	double tau = skin + sqrt(3) / 2 * vox;
	size_t cav = 0;

	err_clear(&e);
	REQUIRE_OK(rh_vox_build(m, vox, tau, (size_t)1 << 26, &vx, &e), &e);
	/* a voxel centre 0.8 mm deep is near, 2 mm deep is deep, outside out */
	{
		int i = (int)floor((X / 2 - vx.lo.x) / vox), j = (int)floor((Y / 2 - vx.lo.y) / vox);
		int k1 = (int)floor((0.8 - vx.lo.z) / vox), k2 = (int)floor((2.0 - vx.lo.z) / vox);
		size_t row = (size_t)vx.nx * (size_t)vx.ny;
		CHECK_EQ_INT(vx.code[k1 * row + (size_t)j * vx.nx + i], RH_VOX_NEAR);
		CHECK_EQ_INT(vx.code[k2 * row + (size_t)j * vx.nx + i], RH_VOX_DEEP);
		CHECK_EQ_INT(vx.code[0], RH_VOX_OUT);
	}
	rh_frame_init(&f, m, 45 * M_PI / 180, 0, wall, tau);
	rh_tree_init(&t, &f);
	REQUIRE_OK(rh_tree_build(&t, &vx, 2, &e), &e);
	CHECK(t.cavities > 10);
	for (size_t i = 0; i < t.n; i++) {
		struct rh_geom g;
		int cls;
		if (t.c[i].state == RH_OUT || t.c[i].state == RH_SPLIT)
			continue;
		rh_cell_geom(&f, &t.c[i], &g);
		cls = rh_classify(&f, &vx, &t.c[i]);
		if (t.c[i].state == RH_CAVITY) {
			/* inside: the whole rhombic prism keeps the skin (to a voxel) */
			cav++;
			CHECK_EQ_INT(cls, RH_CLASS_IN);
			CHECK(g.cu - g.a >= skin - 1e-9 && g.cu + g.a <= X - skin + 1e-9);
			CHECK(g.cz - g.b >= skin - 1e-9 && g.cz + g.b <= Z - skin + 1e-9);
			CHECK(g.vlo >= skin - 1e-9 && g.vhi <= Y - skin + 1e-9);
		} else {
			/* solid leaves: boundary cells at the minimum size */
			CHECK_EQ_INT(cls, RH_CLASS_BOUNDARY);
			CHECK(!rh_tree_can_split(&t, (int32_t)i));
		}
	}
	CHECK_EQ_INT(cav, t.cavities);
	/* a cell straddling the box's top face is boundary, one above it out */
	{
		struct rh_cell c = {0};
		int L = f.max_level;
		struct rh_geom g;
		c.level = (uint8_t)L;
		for (c.i = 0; c.i < (1 << L); c.i++)
			for (c.j = 0; c.j < (1 << L); c.j++) {
				rh_cell_geom(&f, &c, &g);
				if (g.cz + g.b < Z + 0.3 && g.cz - g.b > Z - 0.3 && g.cu > 5 && g.cu < X - 5)
					CHECK_EQ_INT(rh_classify(&f, &vx, &c), RH_CLASS_BOUNDARY);
				if (g.cz - g.b > Z + 1 || g.cu + g.a < -1)
					CHECK_EQ_INT(rh_classify(&f, &vx, &c), RH_CLASS_OUT);
			}
	}
	/* the carved mesh: closed, oriented, volume = box - cavities */
	REQUIRE_OK(rh_carve_init(&cr, &t, &e), &e);
	REQUIRE_OK(rh_carve_mesh(&cr, m, &out, &e), &e);
	REQUIRE_OK(mesh_analyze(out, &rep, &e), &e);
	CHECK_EQ_INT(rep.border_edges, 0);
	CHECK_EQ_INT(rep.nonmanifold_edges, 0);
	CHECK_EQ_INT(rep.inconsistent_edges, 0);
	CHECK_EQ_INT(rep.components, 1 + t.cavities);
	CHECK_NEAR(tm_volume(out), X * Y * Z - t.cavity_volume_mm3, 1e-6 * X * Y * Z);
	mesh_free(out);
	rh_carve_fini(&cr);
	/* refinement adds exactly the lost cavity volume; uniform steps
	 * reach the target */
	{
		double before = t.cavity_volume_mm3, added = 0;
		int steps = 0;
		for (size_t i = 0; i < t.n; i++)
			if (t.c[i].state == RH_CAVITY) {
				REQUIRE_OK(rh_tree_refine(&t, (int32_t)i, &added, &e), &e);
				break;
			}
		CHECK(added > 0);
		CHECK_NEAR(t.cavity_volume_mm3, before - added, 1e-9 * before);
		rh_tree_recount(&t);
		CHECK_NEAR(t.cavity_volume_mm3, before - added, 1e-6 * before);
		REQUIRE_OK(rh_uniform(&t, X * Y * Z, 0.9, &steps, &e), &e);
		CHECK(steps >= 1);
		CHECK((X * Y * Z - t.cavity_volume_mm3) / (X * Y * Z) >= 0.9 || t.cavities == 0);
	}
	rh_tree_fini(&t);
	rh_vox_fini(&vx);
	tm_free(m);
}

int main(void)
{
	RUN(test_root);
	RUN(test_tiling_and_location);
	RUN(test_cavity_section);
	RUN(test_classify_box);
	return harness_report();
}
