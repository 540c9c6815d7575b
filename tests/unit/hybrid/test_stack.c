/* test_stack.c - the hybrid engine's designed layer stack
 * (engine/hybrid/stack.c) on a 16 x 12 x 8 mm box filled with muscle
 * fibres along z and with the crystal, checked by an invariant checker
 * written here (flood fill and brute-force distances, nothing of
 * stack.c):
 *   - every 8-connected material region of layer k + 1 has a pixel above
 *     material of layer k (no floating island);
 *   - every material pixel of layer k + 1 on the MFS side has material of
 *     layer k within h tan(alpha) (no overhang beyond alpha);
 *   - the shell is solid: every part pixel outside the interior is
 *     material; voids only inside the interior;
 *   - the fibres' cells are open through the middle of the box (the rule
 *     fills no more than 1 % of the cells there) and closed under its roof.
 * The checker is shown to fail on the raw candidates (the same design
 * without the support rule: its cells end under the roof in a flat
 * ceiling).
 */
#include "harness.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hybrid/stack.h"
#include "engine/mesh/mesh.h"

#define LAYER_MM 0.1
#define PITCH_MM 0.1
#define ALPHA_DEG 45.0

static struct mesh *box_mesh(double x, double y, double z)
{
	struct mesh *m = mesh_new();
	struct err e;
	static const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
				     {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};

	if (!m)
		return NULL;
	for (int k = 0; k < 2; k++)
		for (int j = 0; j < 2; j++)
			for (int i = 0; i < 2; i++)
				mesh_add_vertex(m, v3(i * x, j * y, k * z));
	for (int t = 0; t < 12; t++)
		mesh_add_triangle(m, (uint32_t)f[t][0], (uint32_t)f[t][1], (uint32_t)f[t][2]);
	memset(&e, 0, sizeof e);
	mesh_weld(m, 1e-9, NULL, NULL, &e);
	return m;
}

static int mat(const struct hy_stack *st, int k, int i, int j)
{
	return hy_stack_material(st, k, i, j);
}

/* Violations of the checker's invariants over the whole stack. */
struct verdict {
	long islands, overhang_px, shell_holes, voids_outside;
};

static struct verdict check_stack(const struct hy_stack *st)
{
	struct verdict v = {0, 0, 0, 0};
	int w = st->w, h = st->h;
	int *lab = malloc(sizeof(int) * (size_t)w * h), *stack = malloc(sizeof(int) * (size_t)w * h);
	double r = LAYER_MM * tan(ALPHA_DEG * M_PI / 180) + 1e-9;
	int rp = (int)ceil(r / PITCH_MM);

	if (!lab || !stack) {
		CHECK(!"out of memory");
		free(lab);
		free(stack);
		return v;
	}
	for (int k = 0; k + 1 < st->layers; k++) {
		int c = 0;
		memset(lab, 0, sizeof(int) * (size_t)w * h);
		for (int s = 0; s < w * h; s++) {
			int sp = 0, rests = 0;
			if (lab[s] || !mat(st, k + 1, s % w, s / w))
				continue;
			lab[s] = ++c;
			stack[sp++] = s;
			while (sp) {
				int q = stack[--sp], qx = q % w, qy = q / w;
				rests |= mat(st, k, qx, qy);
				for (int dy = -1; dy <= 1; dy++)
					for (int dx = -1; dx <= 1; dx++) {
						int x = qx + dx, y = qy + dy;
						if (x < 0 || y < 0 || x >= w || y >= h || lab[y * w + x] ||
						    !mat(st, k + 1, x, y))
							continue;
						lab[y * w + x] = c;
						stack[sp++] = y * w + x;
					}
			}
			v.islands += !rests;
		}
		/* distances: brute force in the r window */
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				int ok = 0;
				if (!mat(st, k + 1, i, j) || mat(st, k, i, j))
					continue;
				for (int dy = -rp; dy <= rp && !ok; dy++)
					for (int dx = -rp; dx <= rp && !ok; dx++)
						ok = (dx * dx + dy * dy) * PITCH_MM * PITCH_MM <= r * r &&
						     mat(st, k, i + dx, j + dy);
				v.overhang_px += !ok;
			}
	}
	for (int k = 0; k < st->layers; k++)
		for (int j = 0; j < h; j++)
			for (int i = 0; i < w; i++) {
				size_t b = (size_t)j * w + i;
				int part = (int)((st->part[k * st->words + (b >> 6)] >> (b & 63)) & 1);
				int in = (int)((st->interior[k * st->words + (b >> 6)] >> (b & 63)) & 1);
				if (part && !in && !mat(st, k, i, j))
					v.shell_holes++;
				if (hy_stack_void(st, k, i, j) && !in)
					v.voids_outside++;
			}
	free(lab);
	free(stack);
	return v;
}

/* Void pixels of layer k. */
static long voids_in_layer(const struct hy_stack *st, int k)
{
	long n = 0;

	for (int j = 0; j < st->h; j++)
		for (int i = 0; i < st->w; i++)
			n += hy_stack_void(st, k, i, j);
	return n;
}

static void build(struct hy_stack *st, struct mesh *m, int structure, int raw,
		  struct hy_mfs **mfs, struct capsule **caps, size_t *ncaps)
{
	struct hy_design d;
	struct hy_stack_report rep;
	struct box3 box = box3_empty();
	struct err e;
	double steep = 0;
	int layers;

	memset(&e, 0, sizeof e);
	for (size_t i = 0; i < m->nv; i++)
		box3_add(&box, m->v[i]);
	layers = (int)ceil(box.hi.z / LAYER_MM - 1e-9);
	REQUIRE_OK(hy_stack_init(st, m, box, PITCH_MM, LAYER_MM, layers, 0.8, NULL, &e), &e);
	memset(&d, 0, sizeof d);
	d.structure = structure;
	if (structure == HY_STRUCT_MFS) {
		if (!*mfs)
			REQUIRE_OK(hy_mfs_new_voronoi(v3(0, 0, 1), box3_center(box), 20, 3, 0.6, 7, mfs,
						      &e),
				   &e);
		d.mfs = mfs;
	} else {
		if (!*caps)
			REQUIRE_OK(hy_tcs_build(box.lo, box.hi, 5, 0.6, 1.0, v3(0, 0, 0), 1u << 20, caps,
						ncaps, &steep, &e),
				   &e);
		d.caps = *caps;
		d.ncaps = d.caps_cap = *ncaps;
	}
	d.r_alpha_mm = LAYER_MM * tan(ALPHA_DEG * M_PI / 180);
	d.r_tcs_mm = LAYER_MM * tan(60 * M_PI / 180);
	d.threads = 2;
	d.raw = raw;
	REQUIRE_OK(hy_stack_compose(st, &d, NULL, &rep, &e), &e);
}

static void test_mfs_box(void)
{
	struct mesh *m = box_mesh(16, 12, 8);
	struct hy_stack st, raw;
	struct hy_mfs *mfs = NULL;
	struct capsule *caps = NULL;
	size_t ncaps = 0;
	struct verdict v, vr;
	int mid, top_open;

	REQUIRE(m);
	build(&raw, m, HY_STRUCT_MFS, 1, &mfs, &caps, &ncaps);
	build(&st, m, HY_STRUCT_MFS, 0, &mfs, &caps, &ncaps);
	v = check_stack(&st);
	vr = check_stack(&raw);
	printf("mfs box: designed: %ld islands, %ld overhang px, %ld shell holes; raw candidates: "
	       "%ld islands, %ld overhang px\n",
	       v.islands, v.overhang_px, v.shell_holes, vr.islands, vr.overhang_px);
	CHECK_EQ_INT(v.islands, 0);
	CHECK_EQ_INT(v.overhang_px, 0);
	CHECK_EQ_INT(v.shell_holes, 0);
	CHECK_EQ_INT(v.voids_outside, 0);
	/* the checker sees the flat ceilings of the raw cells */
	CHECK(vr.overhang_px > 100);
	/* the middle of the box keeps its cells as designed; they close under
	 * the roof: the last layers below the top shell hold fewer voids */
	mid = st.layers / 2;
	CHECK(voids_in_layer(&st, mid) > 0);
	/* all but the acute cell corners that reach the void above only
	 * diagonally (1.41 px away, r = 1 px here): they stay filled */
	CHECK(voids_in_layer(&st, mid) >= 0.99 * voids_in_layer(&raw, mid));
	top_open = (int)((8 - 0.8) / LAYER_MM) - 1; /* the last interior layer */
	CHECK(voids_in_layer(&st, top_open) < voids_in_layer(&raw, top_open) / 2);
	hy_stack_fini(&st);
	hy_stack_fini(&raw);
	hy_mfs_free(mfs);
	mesh_free(m);
}

static void test_tcs_box(void)
{
	struct mesh *m = box_mesh(16, 12, 8);
	struct hy_stack st;
	struct hy_mfs *mfs = NULL;
	struct capsule *caps = NULL;
	size_t ncaps = 0;
	struct verdict v;

	REQUIRE(m);
	build(&st, m, HY_STRUCT_TCS, 0, &mfs, &caps, &ncaps);
	v = check_stack(&st);
	printf("tcs box: %ld islands, %ld px over 45 deg (the sticks lean 54.7), %ld shell holes\n",
	       v.islands, v.overhang_px, v.shell_holes);
	CHECK_EQ_INT(v.islands, 0);
	CHECK_EQ_INT(v.shell_holes, 0);
	CHECK_EQ_INT(v.voids_outside, 0);
	CHECK(voids_in_layer(&st, st.layers / 2) > 0);
	hy_stack_fini(&st);
	free(caps);
	mesh_free(m);
}

int main(void)
{
	RUN(test_mfs_box);
	RUN(test_tcs_box);
	return harness_report();
}
