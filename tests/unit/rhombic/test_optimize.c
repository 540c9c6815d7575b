/* test_optimize.c - the rhombic engine's design updates (engine/rhombic/
 * stability.c, optimize.c) against independent measures: a part shaped
 * like a Gamma that tips over as solid stands after refinement, and the
 * incrementally updated centre of mass equals the centroid of the carved
 * mesh by the divergence theorem; the stiffness loop on a block keeps
 * below the volume target, its compliance falls with every refinement,
 * stays above the solid's, and its cavity bookkeeping equals a recount.
 */
#include "harness.h"
#include "unit/slice/meshgen.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/fea/fea.h"
#include "engine/rhombic/optimize.h"
#include "engine/rhombic/rhombic.h"

/* A Gamma in the (x, z) plane (column x 0..10, arm x 10..L at z 30..40),
 * 10 mm deep along y: polygon prism along z, then y and z swapped (a
 * reflection, so the triangles are turned). */
static struct mesh *gamma_mesh(double L)
{
	const double poly[6][2] = {{0, 0}, {10, 0}, {10, 30}, {L, 30}, {L, 40}, {0, 40}};
	const int tris[4][3] = {{0, 1, 2}, {0, 2, 5}, {2, 3, 4}, {2, 4, 5}};
	struct mesh *m = tm_new();

	tm_prism(m, poly, 6, tris, 4, 0, 10);
	for (size_t i = 0; i < m->nv; i++)
		m->v[i] = v3(m->v[i].x, m->v[i].z, m->v[i].y);
	for (size_t t = 0; t < m->nt; t++) {
		uint32_t s = m->tri[3 * t + 1];
		m->tri[3 * t + 1] = m->tri[3 * t + 2];
		m->tri[3 * t + 2] = s;
	}
	return m;
}

static void build(const struct mesh *m, double wall, double skin, double orient,
		  struct rh_tree *t, struct err *e)
{
	struct rh_vox vx;
	struct rh_frame f;
	double vox = 0.25, tau = skin + sqrt(3) / 2 * vox;

	REQUIRE_OK(rh_vox_build(m, vox, tau, (size_t)1 << 26, &vx, e), e);
	rh_frame_init(&f, m, 45 * M_PI / 180, orient, wall, tau);
	rh_tree_init(t, &f);
	REQUIRE_OK(rh_tree_build(t, &vx, 2, e), e);
	rh_vox_fini(&vx);
}

static void test_stability_gamma(void)
{
	struct mesh *m = gamma_mesh(31);
	struct rh_tree t;
	struct rh_stab_report r;
	struct rh_carve cr;
	struct mesh *carved = NULL;
	struct err e;
	double vol, pv;
	struct vec3 mom, pm;

	err_clear(&e);
	CHECK(tm_volume(m) > 0);
	build(m, 0.6, 0.6, 0, &t, &e);
	REQUIRE(t.cavities > 20);
	REQUIRE_OK(rh_stability(&t, m, 0.1, 0, &r, &e), &e);
	/* the solid part's centre of mass: (10*40*5 + 23*10*21.5) / 630 mm */
	CHECK_NEAR(r.com_solid.x, (400 * 5 + 210 * 20.5) / 610.0, 1e-9);
	CHECK(!r.solid_inside);
	CHECK_NEAR(r.hull_center.x, 5, 1e-6);
	CHECK_NEAR(r.hull_center.y, 5, 1e-6);
	CHECK(r.splits > 0);
	fprintf(stderr, "gamma: solid %.3f initial %.3f after %.3f, %zu splits, %zu cavities\n", r.com_solid.x, r.com_initial.x, r.com_after.x, r.splits, t.cavities);
	CHECK(r.inside);
	CHECK(r.hull_distance_mm > 0);
	CHECK(r.com_after.x < 10);
	/* the incremental centre of mass = the carved solid's centroid */
	REQUIRE_OK(rh_carve_init(&cr, &t, &e), &e);
	REQUIRE_OK(rh_carve_mesh(&cr, m, &carved, &e), &e);
	mesh_mass(carved, &vol, &mom);
	mesh_mass(m, &pv, &pm);
	CHECK_NEAR(vol, pv - t.cavity_volume_mm3, 1e-6 * pv);
	CHECK_NEAR(mom.x / vol, r.com_after.x, 1e-6);
	CHECK_NEAR(mom.y / vol, r.com_after.y, 1e-6);
	CHECK_NEAR(mom.z / vol, r.com_after.z, 1e-6);
	mesh_free(carved);
	rh_carve_fini(&cr);
	rh_tree_fini(&t);
	tm_free(m);
}

static void test_stiffness_block(void)
{
	struct mesh *m = tm_new();
	struct rh_tree t;
	struct rh_stiff_opts o;
	struct rh_stiff_report r;
	struct fea_loads l;
	struct fea_material mat = {FEA_PLA_E_MPA, FEA_PLA_NU};
	struct err e;
	double pv = 40.0 * 10 * 20, f0, before;

	err_clear(&e);
	tm_box(m, 0, 0, 0, 40, 10, 20);
	build(m, 0.5, 0.5, 0, &t, &e);
	REQUIRE(t.cavities > 10);
	f0 = (pv - t.cavity_volume_mm3) / pv;
	REQUIRE_OK(fea_loads_parse("fixed box=0,0,0,2,10,0 axes=xyz; fixed box=38,0,0,40,10,0 "
				   "axes=z; force box=18,0,20,22,10,20 n=0,0,-50",
				   mat, &l, &e),
		   &e);
	memset(&o, 0, sizeof o);
	o.part_vol_mm3 = pv;
	o.target = f0 + 0.08;
	o.split_pct = 5;
	o.max_iterations = 200;
	o.adaptive = 1;
	o.fea_voxel_mm = 1;
	o.supersample = 4;
	o.max_elements = 1u << 20;
	o.threads = 2;
	o.penal = FEA_PENAL;
	o.rho_min = 0.1;
	REQUIRE_OK(rh_stiffness(&t, m, &l, &o, &r, &e), &e);
	CHECK(r.iterations >= 2);
	CHECK_EQ_INT(r.nhist, (size_t)r.iterations + 2);
	for (size_t i = 1; i + 1 < r.nhist; i++) {
		CHECK(r.hist[i].fraction > r.hist[i - 1].fraction);
		CHECK(r.hist[i].compliance_nmm < r.hist[i - 1].compliance_nmm);
	}
	CHECK(r.hist[r.nhist - 2].fraction <= o.target + 1e-12);
	CHECK(r.hist[r.nhist - 2].fraction > f0 + 0.04);
	CHECK(r.compliance_nmm > r.compliance_solid_nmm);
	CHECK_NEAR(r.hist[r.nhist - 1].fraction, 1.0, 0);
	before = t.cavity_volume_mm3;
	rh_tree_recount(&t);
	CHECK_NEAR(t.cavity_volume_mm3, before, 1e-6 * pv);
	rh_stiff_report_fini(&r);
	fea_loads_fini(&l);
	rh_tree_fini(&t);
	tm_free(m);
}

int main(void)
{
	RUN(test_stability_gamma);
	RUN(test_stiffness_block);
	return harness_report();
}
