/* test_nlp.c - the support-free offset optimisation on synthetic voids.
 *
 * A box-shaped inner region (10 x 10 mm, 20 slices of 0.5 mm) must become
 * a void whose ceiling collapses onto the square's medial axis (the two
 * diagonals) with every face within alpha of the vertical: a groin vault.
 * Its continuous optimum: at depth d below the top (z = 9.75) the void is
 * the square minus four triangles of area (5 - sqrt2 d)^2 each, so
 * V = int_0^9.5 [100 - 4 (5 - sqrt2 d)^2]_+ dd = 100 * 9.5 - 4 * 125 / (3 sqrt2)
 *   = 832.1 mm^3.  The discrete optimum lies below it (eq. 5 holds the
 * zigzag cross edges, not just the faces, to h tan alpha).  Constraints are re-checked by
 * hl_void_check(), an evaluation independent of the solver's callbacks,
 * and the volume by the divergence theorem.
 *
 * Slabs of unequal thickness (adaptive slices): the same box with gaps
 * alternating 0.4 and 0.6 mm; every face and every facing-down cross edge
 * is measured here, from the positions alone, against its own rise (a
 * solver that used one h for all would leave the 0.4 mm slabs' faces at
 * atan(0.5 / 0.4) = 51 degrees); the volume against the continuous
 * optimum 100 H - 500 / (3 sqrt 2) for the box's height H; and
 * hl_void_loop_h against the trapezoid weights by hand.  The flat-top
 * measure (hl_void_top_overhang_mm2) reads the uncollapsed square less a
 * rim of the print layer's reach, and about 0 for the collapsed vault.
 */
#include "harness.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/opt_int.h"
#include "loopgen.h"

static void opts_init(struct hl_nlp_opts *o, double alpha_deg)
{
	memset(o, 0, sizeof *o);
	o->alpha_rad = alpha_deg * M_PI / 180;
	o->ceil_eps_mm2 = 1e-4;
	o->gate_tau = 1e-3;
	o->max_iter = 500;
	o->max_outer = 4;
}

static void test_box_roof(void)
{
	enum { NS = 20 };
	struct hl_loop L[NS];
	const struct hl_loop *lp[NS];
	struct hl_void v;
	struct hl_nlp_opts o;
	struct hl_check c;
	struct err e;
	size_t used;
	double h = 0.5, s = 0.5 * h * tan(M_PI / 4);

	for (int k = 0; k < NS; k++) {
		rect_loop(&L[k], 0, 0, 10, 10, s, 0.25 + h * k, k);
		lp[k] = &L[k];
	}
	hl_void_init(&v);
	err_clear(&e);
	REQUIRE_OK(hl_void_build(lp, NS, NULL, &v, &used, &e), &e);
	CHECK_EQ_INT(used, NS);
	CHECK_EQ_INT(v.nt, v.nxe);
	/* directions point inward; bounds reach the medial axis (<= 5 mm) */
	for (size_t j = 0; j < v.nv; j++) {
		CHECK(v.ub[j] <= 5.0 * sqrt(2) + 1e-6);
		CHECK_NEAR(hypot(v.dir[2 * j], v.dir[2 * j + 1]), 1, 1e-9);
	}
	/* the uniform void (l = 0) has a flat ceiling: the check must see it */
	{
		double *zero = mem_calloc(v.nv, sizeof *zero);
		hl_void_check(&v, zero, M_PI / 4, 1e-3, &c);
		CHECK_NEAR(c.top_area_mm2, 100, 1e-6);
		CHECK_NEAR(hl_void_volume(&v, zero), 100 * 9.5, 1e-6);
		mem_free(zero);
	}
	opts_init(&o, 45);
	REQUIRE_OK(hl_nlp_solve(&v, 1, &o, &e), &e);
	CHECK_EQ_INT(v.status, 0);
	hl_void_check(&v, v.l, M_PI / 4, 1e-3, &c);
	fprintf(stderr, "check: face %g rad, edge %g mm, top %g mm2 (eps %g)\n", c.worst_face, c.worst_edge_mm, c.top_area_mm2, v.ceil_eps_mm2);
	CHECK(c.worst_face <= 1e-4);
	CHECK(c.worst_edge_mm <= 1e-3);
	CHECK(c.top_area_mm2 <= 1e-3);
	CHECK(c.min_shift_mm >= 0);
	CHECK(c.max_shift_mm <= 1e-12);
	fprintf(stderr, "box vault: volume %.1f mm3 (bound 832.1), %d iterations, %d rounds, %.2f s\n",
		v.volume_mm3, v.iterations, v.outer, v.seconds);
	CHECK(v.volume_mm3 <= 832.1);
	CHECK(v.volume_mm3 >= 0.8 * 832.1);
	/* the flat top print layers cannot bridge: at offset 0 the whole
	 * 10 mm square less a reach-wide rim (the check must see it); once
	 * collapsed onto the diagonals, nothing */
	{
		double a, reach = 0.05 * tan(M_PI / 4);
		REQUIRE_OK(hl_void_top_overhang_mm2(&v, NULL, reach, &a, &e), &e);
		CHECK_NEAR(a, (10 - 2 * reach) * (10 - 2 * reach), 1e-3);
		REQUIRE_OK(hl_void_top_overhang_mm2(&v, v.l, reach, &a, &e), &e);
		fprintf(stderr, "collapsed top beyond %.3f mm of its edge: %g mm2\n", reach, a);
		CHECK_NUM(a, <, 1e-4);
	}
	hl_void_fini(&v);
	for (int k = 0; k < NS; k++)
		hl_loop_fini(&L[k]);
}

static void test_box_roof_uneven(void)
{
	enum { NS = 20 };
	struct hl_loop L[NS];
	const struct hl_loop *lp[NS];
	struct hl_void v;
	struct hl_nlp_opts o;
	struct err e;
	size_t used;
	double z = 0.25, s = 0.5 * 0.4 * tan(M_PI / 4), H, bound, ta = tan(M_PI / 4);
	double worst_face = -1, worst_edge = -1;

	for (int k = 0; k < NS; k++) {
		rect_loop(&L[k], 0, 0, 10, 10, s, z, k);
		lp[k] = &L[k];
		z += k % 2 ? 0.6 : 0.4;
	}
	H = L[NS - 1].z_mm - L[0].z_mm;
	hl_void_init(&v);
	err_clear(&e);
	REQUIRE_OK(hl_void_build(lp, NS, NULL, &v, &used, &e), &e);
	CHECK_EQ_INT(used, NS);
	/* trapezoid weights: the end loops their own gap, the others half of each */
	CHECK_NEAR(hl_void_loop_h(&v, 0), 0.4, 1e-12);
	CHECK_NEAR(hl_void_loop_h(&v, 1), 0.5, 1e-12);
	CHECK_NEAR(hl_void_loop_h(&v, 2), 0.5, 1e-12);
	CHECK_NEAR(hl_void_loop_h(&v, NS - 1), L[NS - 1].z_mm - L[NS - 2].z_mm, 1e-12);
	opts_init(&o, 45);
	REQUIRE_OK(hl_nlp_solve(&v, 1, &o, &e), &e);
	CHECK_EQ_INT(v.status, 0);
	REQUIRE(v.l != NULL);
	for (size_t t = 0; t < v.nt; t++) {
		const uint32_t *q = v.tri + 3 * t;
		struct vec3 a = hl_void_pos(&v, q[0], v.l[q[0]]), b = hl_void_pos(&v, q[1], v.l[q[1]]),
			    c = hl_void_pos(&v, q[2], v.l[q[2]]);
		struct vec3 N = v3_cross(v3_sub(b, a), v3_sub(c, a));
		double nn = v3_len(N);
		if (nn > 1e-9) /* -n.z <= sin alpha: within alpha of the vertical */
			worst_face = fmax(worst_face, -N.z / nn - sin(M_PI / 4));
	}
	for (size_t k = 0; k < v.nxe; k++) {
		const struct hl_xedge *x = &v.xe[k];
		double nz = 0;
		for (int i = 0; i < 2; i++) {
			const uint32_t *q = v.tri + 3 * x->f[i];
			struct vec3 a = hl_void_pos(&v, q[0], v.l[q[0]]),
				    b = hl_void_pos(&v, q[1], v.l[q[1]]),
				    c = hl_void_pos(&v, q[2], v.l[q[2]]);
			nz += 0.5 * v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a))).z;
		}
		if (nz < -1e-3) {
			struct vec3 p = hl_void_pos(&v, x->lo, v.l[x->lo]),
				    q = hl_void_pos(&v, x->hi, v.l[x->hi]);
			worst_edge = fmax(worst_edge, hypot(q.x - p.x, q.y - p.y) - (q.z - p.z) * ta);
		}
	}
	fprintf(stderr, "uneven vault: face %g, edge %g mm, volume %.1f mm3 (H %.2f)\n", worst_face,
		worst_edge, v.volume_mm3, H);
	CHECK_NUM(worst_face, <=, 1e-4);
	CHECK_NUM(worst_edge, <=, 1e-3);
	bound = 100 * H - 500 / (3 * sqrt(2));
	CHECK_NUM(v.volume_mm3, <=, bound);
	CHECK_NUM(v.volume_mm3, >=, 0.8 * bound);
	hl_void_fini(&v);
	for (int k = 0; k < NS; k++)
		hl_loop_fini(&L[k]);
}

/* The work budget's cap (hl_nlp_opts.iter_cap): a solve stops at the cap
 * (the vault takes more uncapped) and says so, an uncapped one does not,
 * and a round with no iterations left solves nothing: its void keeps its
 * support-free start. */
static void test_iteration_cap(void)
{
	enum { NS = 20 };
	struct hl_loop L[NS];
	const struct hl_loop *lp[NS];
	struct hl_void v, w;
	struct hl_nlp_opts o;
	struct hl_check c;
	struct err e;
	size_t used;
	double h = 0.5, s = 0.5 * h * tan(M_PI / 4);
	int free_it;

	for (int k = 0; k < NS; k++) {
		rect_loop(&L[k], 0, 0, 10, 10, s, 0.25 + h * k, k);
		lp[k] = &L[k];
	}
	hl_void_init(&v);
	hl_void_init(&w);
	err_clear(&e);
	REQUIRE_OK(hl_void_build(lp, NS, NULL, &v, &used, &e), &e);
	REQUIRE_OK(hl_void_build(lp, NS, NULL, &w, &used, &e), &e);
	opts_init(&o, 45);
	REQUIRE_OK(hl_nlp_solve(&v, 1, &o, &e), &e);
	free_it = v.iterations;
	fprintf(stderr, "vault uncapped: %d iterations\n", free_it);
	CHECK_NUM(free_it, >, 24);
	CHECK_EQ_INT(v.capped, 0);
	o.iter_cap = free_it + 10; /* room to spare: not cut */
	REQUIRE_OK(hl_nlp_solve(&v, 1, &o, &e), &e);
	CHECK_EQ_INT(v.iterations, free_it);
	CHECK_EQ_INT(v.capped, 0);
	o.iter_cap = 20;
	REQUIRE_OK(hl_nlp_solve(&v, 1, &o, &e), &e);
	CHECK_NUM(v.iterations, <=, 20);
	CHECK_NUM(v.iterations, >=, 19);
	CHECK_EQ_INT(v.capped, 1);
	/* none left: the start, support-free, no iteration */
	o.iter_cap = -1;
	REQUIRE_OK(hl_solve_round(&w, 1, &o, 1, NULL, 0, 1, &e), &e);
	CHECK_EQ_INT(w.iterations, 0);
	CHECK_EQ_INT(w.capped, 0); /* not run (work_capped() reads iter_cap < 0) */
	CHECK_EQ_INT(w.status, HL_STATUS_FALLBACK);
	hl_void_check(&w, w.l, M_PI / 4, 1e-3, &c);
	CHECK(c.worst_face <= 1e-4);
	CHECK(c.worst_edge_mm <= 1e-3);
	hl_void_fini(&v);
	hl_void_fini(&w);
	for (int k = 0; k < NS; k++)
		hl_loop_fini(&L[k]);
}

int main(void)
{
	RUN(test_box_roof);
	RUN(test_box_roof_uneven);
	RUN(test_iteration_cap);
	return harness_report();
}
