/* test_gen.c - lattice generation on an analytic part (a box): Appendix I,
 * spacing of the sampled lattice, SO and PO lowering Gamma with every tet
 * kept valid, density matching on a graded field within an error bound
 * (measured independently), NRRD density input, the Chebyshev centre. */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/polytope.h"
#include "engine/lattice/density.h"
#include "engine/lattice/gen.h"
#include "engine/mesh/mesh.h"

static struct box3 g_box;

static int box_inside(void *c, struct vec3 p)
{
	(void)c;
	return box3_contains(g_box, p);
}

static double box_distance(void *c, struct vec3 p)
{
	double d = fmin(fmin(p.x - g_box.lo.x, g_box.hi.x - p.x),
			fmin(fmin(p.y - g_box.lo.y, g_box.hi.y - p.y),
			     fmin(p.z - g_box.lo.z, g_box.hi.z - p.z)));
	(void)c;
	return fabs(d);
}

static struct vec3 box_v[8];
static uint32_t box_t[36];
static struct mesh box_mesh;

static struct lattice_domain box_domain(double sx, double sy, double sz)
{
	static const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4},
				     {1, 5, 4}, {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6},
				     {1, 3, 5}, {3, 7, 5}};
	struct lattice_domain d;

	g_box.lo = v3(0, 0, 0);
	g_box.hi = v3(sx, sy, sz);
	for (int c = 0; c < 8; c++)
		box_v[c] = v3(sx * (c & 1), sy * ((c >> 1) & 1), sz * ((c >> 2) & 1));
	for (int i = 0; i < 12; i++)
		for (int k = 0; k < 3; k++)
			box_t[3 * i + k] = (uint32_t)f[i][k];
	box_mesh.v = box_v;
	box_mesh.tri = box_t;
	box_mesh.nv = 8;
	box_mesh.nt = 12;
	memset(&d, 0, sizeof d);
	d.box = g_box;
	d.inside = box_inside;
	d.distance = box_distance;
	d.surface = &box_mesh;
	d.threads = 2;
	return d;
}

static void test_appendix_one(void)
{
	/* the chosen root satisfies the density model and is the largest */
	double r = 0.5;
	for (double rho = 0.05; rho < 0.5; rho += 0.05) {
		double L = lattice_spacing_for_density(rho, r);
		CHECK_REL(lattice_density_estimate(L, r), rho, 1e-9);
		CHECK_NUM(L, >, 2 * sqrt(3.0) * r); /* the cylinders have positive length */
	}
	/* monotone: denser needs shorter struts; floor 4 r */
	CHECK_NUM(lattice_spacing_for_density(0.1, r), >, lattice_spacing_for_density(0.3, r));
	CHECK_NUM(lattice_spacing_for_density(0.9, r), >=, 4 * r);
}

static double mean_interior_edge(const struct lattice_tetmesh *t)
{
	uint32_t *ed;
	size_t ne, n = 0;
	double s = 0;
	struct err e;

	if (lattice_tetmesh_edges(t, &ed, &ne, &e))
		return 0;
	for (size_t i = 0; i < ne; i++)
		if (!t->fixed[ed[2 * i]] && !t->fixed[ed[2 * i + 1]]) {
			s += v3_dist(t->p[ed[2 * i]], t->p[ed[2 * i + 1]]);
			n++;
		}
	mem_free(ed);
	return n ? s / n : 0;
}

static double min_tet_volume(const struct lattice_tetmesh *t)
{
	double m = INFINITY;
	for (size_t k = 0; k < t->nt; k++) {
		const uint32_t *q = t->tet + 4 * k;
		struct vec3 a = t->p[q[0]];
		m = fmin(m, v3_dot(v3_sub(t->p[q[1]], a),
				   v3_cross(v3_sub(t->p[q[2]], a), v3_sub(t->p[q[3]], a))) / 6);
	}
	return m;
}

/* Spacing follows Appendix I; SO then PO lower Gamma and raise Psi; PO
 * moves only interior nodes and keeps every tet positively oriented. */
static void test_so_po_reduce_gamma(void)
{
	struct err e;
	struct lattice_domain d = box_domain(40, 40, 40);
	struct lattice_density den;
	struct lattice_tetmesh raw = {0}, so = {0};
	struct lattice_build_stats st;
	struct lattice_support_metrics m0, m1, m2;
	struct lattice_po_opts po = {M_PI / 4, 100, 3, NULL};
	struct lattice_po_stats ps;
	struct lattice_build_opts o = {1.0, 0.5, &den, 11, 1000000, NULL};
	struct vec3 *before;
	size_t moved_fixed = 0;
	double L;

	lattice_density_constant(&den, d.box, 0.2);
	L = lattice_spacing_for_density(0.2, 0.5);
	REQUIRE_OK(lattice_build_tetmesh(&d, &o, &raw, &st, &e), &e);
	CHECK_NEAR(mean_interior_edge(&raw), L, 0.1 * L);
	CHECK_INT(st.surface_nodes, >, 100);
	CHECK_NUM(min_tet_volume(&raw), >, 0);
	lattice_support_measure(&raw, M_PI / 4, &m0);
	/* an isotropic tet mesh: Psi = 1 - cos 45 deg = 0.29 */
	CHECK_NEAR(m0.psi, 1 - cos(M_PI / 4), 0.05);

	o.so_k = 1.6;
	REQUIRE_OK(lattice_build_tetmesh(&d, &o, &so, &st, &e), &e);
	lattice_support_measure(&so, M_PI / 4, &m1);
	before = mem_alloc(so.np * sizeof *before);
	REQUIRE(before);
	memcpy(before, so.p, so.np * sizeof *before);
	REQUIRE_OK(lattice_po_optimize(&so, &po, &ps, &e), &e);
	lattice_support_measure(&so, M_PI / 4, &m2);
	for (size_t i = 0; i < so.np; i++)
		moved_fixed += so.fixed[i] && v3_dist(before[i], so.p[i]) > 0;
	fprintf(stderr, "gamma raw %.4f SO %.4f SO+PO %.4f; psi %.3f %.3f %.3f; PO %d rounds\n",
		m0.gamma, m1.gamma, m2.gamma, m0.psi, m1.psi, m2.psi, ps.rounds);
	CHECK_NUM(m1.gamma, <, 0.8 * m0.gamma);
	CHECK_NUM(m2.gamma, <, 0.85 * m1.gamma);
	CHECK_NUM(m1.psi, >, m0.psi + 0.1);
	CHECK_NUM(m2.psi, >, m1.psi);
	CHECK_NEAR(ps.gamma_after, m2.gamma, 1e-12);
	CHECK_EQ_INT(moved_fixed, 0);
	CHECK_NUM(min_tet_volume(&so), >, 0);
	mem_free(before);
	lattice_tetmesh_fini(&raw);
	lattice_tetmesh_fini(&so);
}

/* g(theta): zero up to alpha; the paper's polynomial close to eq. 20's
 * integral (which the polynomial fits). */
static void test_support_g(void)
{
	CHECK_NUM(lattice_support_g(0.3, M_PI / 4), ==, 0);
	CHECK_NUM(lattice_support_g(M_PI / 4, M_PI / 4), ==, 0);
	CHECK_NEAR(lattice_support_g(M_PI / 2, M_PI / 4), 0.745, 0.01);
	/* eq. 20 at alpha = 44.9999 deg against the polynomial at 45 */
	for (double th = 0.95; th < M_PI / 2; th += 0.1)
		CHECK_NEAR(lattice_support_g(th, M_PI / 4 - 1e-7), lattice_support_g(th, M_PI / 4),
			   0.05);
	/* a horizontal strut: risky arc from asin(sin alpha) to pi/2 of sin(phi) */
	CHECK_NEAR(lattice_support_g(M_PI / 2, M_PI / 6), cos(M_PI / 6), 1e-4);
}

/* A graded field (0.1 at the bottom to 0.3 at the top): matched density
 * per voxel, measured on a regular grid independent of the matching's
 * Monte-Carlo points. */
static void test_density_matching_graded(void)
{
	struct err e;
	struct lattice_domain d = box_domain(40, 40, 40);
	struct lattice_density den;
	struct lattice_tetmesh t = {0};
	struct lattice_build_stats st;
	struct lattice_build_opts o = {1.6, 0.5, &den, 5, 1000000, NULL};
	struct lattice_match_opts mo = {&den, 0.25, 0.5, 1.5, 8, 2, 1000, 4, 2, 9, NULL};
	struct lattice_match_stats ms;
	struct lattice *q = NULL;
	double mean, mx, mean0, mx0;
	size_t nv;

	lattice_density_gradient(&den, d.box, v3(0.5, 0.5, 0), v3(0.5, 0.5, 1), 0.1, 0.3);
	REQUIRE_OK(lattice_build_tetmesh(&d, &o, &t, &st, &e), &e);
	/* unmatched baseline: uniform struts of the initial radius */
	{
		struct lattice *u = lattice_new();
		uint32_t *ed;
		size_t ne;
		REQUIRE(u);
		REQUIRE_OK(lattice_tetmesh_edges(&t, &ed, &ne, &e), &e);
		for (size_t i = 0; i < t.np; i++)
			lattice_add_node(u, t.p[i]);
		for (size_t i = 0; i < ne; i++)
			lattice_add_edge(u, ed[2 * i], ed[2 * i + 1], 0.5);
		u->support_mm = 0.75;
		REQUIRE_OK(lattice_measure_density(u, &d, &den, 8, 2, &mean0, &mx0, &nv, &e), &e);
		mem_free(ed);
		lattice_free(u);
	}
	REQUIRE_OK(lattice_match_density(&t, &d, &mo, &q, &ms, &e), &e);
	REQUIRE_OK(lattice_measure_density(q, &d, &den, 8, 2, &mean, &mx, &nv, &e), &e);
	fprintf(stderr,
		"density error: unmatched mean %.4f max %.4f; matched mean %.4f max %.4f over %zu "
		"voxels; R %.3f, radii %.3f..%.3f, %zu tets split\n",
		mean0, mx0, mean, mx, nv, q->support_mm, 0.25, lattice_max_radius(q),
		ms.subdivided_tets);
	CHECK_INT(nv, >=, 100);
	CHECK_NUM(mean, <, 0.025);
	CHECK_NUM(mx, <, 0.08);
	CHECK_NUM(mean, <, 0.5 * mean0);
	/* every radius within [r_min, R / factor] and below R */
	for (size_t i = 0; i < q->nedges; i++) {
		CHECK_NUM(q->edge[i].radius_mm, >=, 0.25 - 1e-6);
		CHECK_NUM(q->edge[i].radius_mm, <, q->support_mm);
	}
	CHECK_NEAR(q->support_mm, 1.5 * lattice_max_radius(q), 1e-6);
	lattice_free(q);
	lattice_tetmesh_fini(&t);
}

static void test_nrrd_density(void)
{
	struct err e;
	struct lattice_density d;
	struct box3 b = {{0, 0, 0}, {10, 20, 30}};
	char buf[512];
	size_t n;
	float vals[8] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f};

	n = (size_t)snprintf(buf, sizeof buf,
			     "NRRD0004\n# a 2x2x2 grid\ntype: float\ndimension: 3\nsizes: 2 2 2\n"
			     "encoding: raw\nendian: little\nspacings: 1 1 1\n\n");
	memcpy(buf + n, vals, sizeof vals);
	REQUIRE_OK(lattice_density_load_buffer(&d, b, buf, n + sizeof vals, &e), &e);
	/* voxel centres: exact values; the middle: the mean */
	CHECK_NEAR(lattice_density_at(&d, v3(2.5, 5, 7.5)), 0.1, 1e-6);
	CHECK_NEAR(lattice_density_at(&d, v3(7.5, 15, 22.5)), 0.8, 1e-6);
	CHECK_NEAR(lattice_density_at(&d, v3(5, 10, 15)), 0.45, 1e-6);
	CHECK_NEAR(d.lo, 0.1, 1e-6);
	CHECK_NEAR(d.hi, 0.8, 1e-6);
	lattice_density_fini(&d);
	/* wrong size, bad values, bad header */
	CHECK_EQ_INT(lattice_density_load_buffer(&d, b, buf, n + 7, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "bytes");
	vals[3] = 1.5f;
	memcpy(buf + n, vals, sizeof vals);
	CHECK_EQ_INT(lattice_density_load_buffer(&d, b, buf, n + sizeof vals, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "voxel 3");
	CHECK_EQ_INT(lattice_density_load_buffer(&d, b, "NRRD0004\ntype: short\n\n", 22, &e),
		     ERR_PARSE);
	CHECK_EQ_INT(lattice_density_load_buffer(&d, b, "P5 2 2", 6, &e), ERR_PARSE);
}

static void test_chebyshev_center(void)
{
	/* the box [0,2]x[0,4]x[0,6]: largest ball radius 1 */
	struct vec3 n[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 2}, {0, 0, -1}};
	double d[6] = {2, 0, 4, 0, 12, 0}, r;
	struct vec3 c;

	REQUIRE(geom_chebyshev_center(n, d, 6, v3(0.1, 0.2, 0.3), 100, &c, &r) == 0);
	CHECK_NEAR(r, 1, 1e-9);
	CHECK_NEAR(c.x, 1, 1e-9);
	CHECK(c.y >= 1 - 1e-9 && c.y <= 3 + 1e-9);
	/* a start outside is refused */
	CHECK(geom_chebyshev_center(n, d, 6, v3(-1, 0.2, 0.3), 100, &c, &r) != 0);
	/* a regular tetrahedron's insphere: radius = edge / sqrt(24) */
	{
		struct vec3 p[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
		struct vec3 nn[4];
		double dd[4];
		for (int f = 0; f < 4; f++) {
			struct vec3 a = p[(f + 1) % 4], b = p[(f + 2) % 4], cc = p[(f + 3) % 4];
			nn[f] = v3_cross(v3_sub(b, a), v3_sub(cc, a));
			if (v3_dot(nn[f], v3_sub(p[f], a)) > 0)
				nn[f] = v3_scale(nn[f], -1);
			dd[f] = v3_dot(nn[f], a);
		}
		REQUIRE(geom_chebyshev_center(nn, dd, 4, v3(0.1, 0, 0), 10, &c, &r) == 0);
		CHECK_NEAR(r, sqrt(8.0) / sqrt(24.0), 1e-9);
		CHECK_NEAR(v3_len(c), 0, 1e-9);
	}
}

int main(void)
{
	RUN(test_appendix_one);
	RUN(test_support_g);
	RUN(test_chebyshev_center);
	RUN(test_nrrd_density);
	RUN(test_so_po_reduce_gamma);
	RUN(test_density_matching_graded);
	return harness_report();
}
