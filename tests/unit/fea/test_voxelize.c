/* test_voxelize.c - fea_voxelize_mesh: a box's fraction sum times h^3 is
 * its volume (unaligned grid, several supersamplings and threads), a wall
 * 0.3 voxel thick counts 0.3 per voxel, the grid limit names
 * fea_voxel_mm, and a voxelized aligned cube solves to the same
 * compliance as the same cube built by hand.
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"
#include "engine/mesh/mesh.h"

/* An axis-aligned box [lo, hi] as 12 triangles, CCW from outside. */
static struct mesh *box_mesh(struct vec3 lo, struct vec3 hi)
{
	static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
					{2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
	struct mesh *m = mesh_new();

	for (int c = 0; c < 8; c++)
		mesh_add_vertex(m, (struct vec3){(c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y,
						 (c & 4) ? hi.z : lo.z});
	for (int f = 0; f < 6; f++) {
		const int *q = quads[f];
		mesh_add_triangle(m, (uint32_t)q[0], (uint32_t)q[1], (uint32_t)q[2]);
		mesh_add_triangle(m, (uint32_t)q[0], (uint32_t)q[2], (uint32_t)q[3]);
	}
	return m;
}

static double fraction_sum(const struct fea_grid *g)
{
	double s = 0;

	for (size_t i = 0; i < (size_t)g->nx * g->ny * g->nz; i++)
		s += g->rho[i];
	return s;
}

static void test_volume(void)
{
	struct mesh *m = box_mesh((struct vec3){0.3, -2.2, 0.1}, (struct vec3){10.3, 5.8, 7.1});
	struct err e;
	const double vol = 10.0 * 8 * 7;

	err_clear(&e);
	for (int ss = 1; ss <= 4; ss += 3)
		for (int th = 1; th <= 2; th++) {
			struct fea_grid g;
			REQUIRE_OK(fea_voxelize_mesh(m, 0.7, ss, 1000000, th, &g, &e), &e);
			CHECK_REL(fraction_sum(&g) * 0.7 * 0.7 * 0.7, vol, 0.005);
			CHECK_EQ_INT(g.nx, 15 + 2);
			CHECK_NUM(g.part_lo_mm.x, ==, 0.3);
			CHECK_NUM(g.part_hi_mm.z, ==, 7.1);
			CHECK_NEAR(g.lo_mm.y, -2.2 - 0.7, 1e-12);
			/* the padding layer is empty */
			for (int j = 0; j < g.ny; j++)
				for (int i = 0; i < g.nx; i++)
					CHECK_NUM(g.rho[(size_t)j * g.nx + i], ==, 0);
			fea_grid_fini(&g);
		}
	mesh_free(m);
}

static void test_thin_wall(void)
{
	const double h = 0.5;
	struct mesh *m = box_mesh((struct vec3){0, 0, 0}, (struct vec3){0.3 * h, 5 * h, 5 * h});
	struct fea_grid g;
	struct err e;

	err_clear(&e);
	REQUIRE_OK(fea_voxelize_mesh(m, h, 2, 1000000, 1, &g, &e), &e);
	CHECK_EQ_INT(g.nx, 3);
	CHECK_EQ_INT(g.ny, 7);
	for (int k = 1; k <= 5; k++)
		for (int j = 1; j <= 5; j++) {
			CHECK_NEAR(g.rho[((size_t)k * g.ny + j) * g.nx + 1], 0.3, 1e-4);
			CHECK_NUM(g.rho[((size_t)k * g.ny + j) * g.nx + 0], ==, 0);
		}
	fea_grid_fini(&g);
	/* the limit names the parameter */
	CHECK_EQ_INT(fea_voxelize_mesh(m, h, 2, 100, 1, &g, &e), ERR_LIMIT);
	CHECK_STR(e.field, "fea_voxel_mm");
	CHECK_CONTAINS(e.msg, "exceeds the limit of 100");
	mesh_free(m);
}

static void test_solve_voxelized(void)
{
	struct mesh *m = box_mesh((struct vec3){-3, -2, 0}, (struct vec3){3, 2, 8});
	struct fea_grid g, hand;
	struct fea_loads l;
	struct fea_solver *s = NULL;
	struct fea_result r1, r2;
	struct err e;
	const struct fea_material mat = {FEA_PLA_E_MPA, FEA_PLA_NU};

	err_clear(&e);
	REQUIRE_OK(fea_voxelize_mesh(m, 1, 2, 1000000, 2, &g, &e), &e);
	REQUIRE_OK(fea_loads_parse("", mat, &l, &e), &e);
	REQUIRE_OK(fea_solver_new(&g, &l, NULL, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &r1, &e), &e);
	CHECK_EQ_INT(r1.elements, 6 * 4 * 8);
	fea_solver_free(s);
	memset(&hand, 0, sizeof hand);
	hand.nx = 6;
	hand.ny = 4;
	hand.nz = 8;
	hand.h_mm = 1;
	hand.lo_mm = (struct vec3){-3, -2, 0};
	hand.part_lo_mm = hand.lo_mm;
	hand.part_hi_mm = (struct vec3){3, 2, 8};
	hand.rho = mem_alloc(6 * 4 * 8 * sizeof *hand.rho);
	for (int i = 0; i < 6 * 4 * 8; i++)
		hand.rho[i] = 1;
	REQUIRE_OK(fea_solver_new(&hand, &l, NULL, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &r2, &e), &e);
	CHECK_REL(r1.compliance_nmm, r2.compliance_nmm, 1e-5);
	CHECK_NUM(r1.compliance_nmm, >, 0);
	fea_solver_free(s);
	fea_loads_fini(&l);
	fea_grid_fini(&g);
	fea_grid_fini(&hand);
	mesh_free(m);
}

/* The paper-001 beam (100 x 6.25 x 50 mm, placed off the origin as a job
 * places it) voxelised at 2 mm: three full voxels and a 12.5 % one
 * through its thickness, pinned at one bottom end, on a roller at the
 * other.  The model is held, but the Galerkin operator of its coarsest
 * level is only semidefinite: it must solve, not be refused as singular
 * (it was, "coarsest multigrid level 1, node 0,3,0"). */
static void test_thin_beam_coarse(void)
{
	struct mesh *m = box_mesh((struct vec3){70, 96.875, 0}, (struct vec3){170, 103.125, 50});
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;

	err_clear(&e);
	REQUIRE_OK(fea_voxelize_mesh(m, 2, 4, 1000000, 1, &g, &e), &e);
	REQUIRE_OK(fea_loads_parse("fixed box=0,0,-0.5,2,6.25,0.5 axes=xyz; "
				   "fixed box=98,0,-0.5,100,6.25,0.5 axes=z; "
				   "force box=48,0,49.5,52,6.25,50.5 n=0,0,-62",
				   (struct fea_material){2500, 0.4}, &l, &e),
		   &e);
	fea_opts_default(&o);
	REQUIRE_OK(fea_solver_new(&g, &l, &o, &s, &e), &e);
	REQUIRE_OK(fea_solve(s, &r, &e), &e);
	CHECK_INT(r.levels, >=, 2);
	CHECK(r.residual <= 1e-6);
	CHECK(r.compliance_nmm > 0);
	fea_solver_free(s);
	fea_loads_fini(&l);
	fea_grid_fini(&g);
	mesh_free(m);
}

int main(void)
{
	RUN(test_thin_beam_coarse);
	RUN(test_volume);
	RUN(test_thin_wall);
	RUN(test_solve_voxelized);
	return harness_report();
}
