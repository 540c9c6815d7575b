/* test_fragments.c - beads of the optimised voids (engine/hollow/
 * fragments.c) on a synthetic part: a 20 x 20 x 10 mm box holding a
 * 10 x 10 x 6 mm void and a 0.3 mm cube of void (a bead).  The bead and
 * only the bead is found under min_void_mm3, with its volume to the
 * voxel; a threshold below both finds none, one above both finds both.
 * The grid is 0.05 mm pixels and 0.05 mm layers, so the bead is 6 x 6 x 6
 * voxels (0.027 mm3).
 */
#include "harness.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"
#include "engine/hollow/fill/fill.h"
#include "engine/mesh/mesh.h"

#include "boxgen.h"

#define PX 0.05
#define LAYER 0.05

/* Offsets of the grid keep pixel edges on whole multiples of PX, so the
 * bead covers exactly 6 x 6 pixels. */
static void part(struct mesh *m)
{
	m->v = mem_alloc(24 * sizeof *m->v);
	m->tri = mem_alloc(36 * 3 * sizeof *m->tri);
	REQUIRE(m->v && m->tri);
	m->nv = m->nt = 0;
	add_box(m, v3(0, 0, 0), v3(20, 20, 10), 0);
	add_box(m, v3(2, 2, 2), v3(12, 12, 8), 1);
	add_box(m, v3(15, 15, 4), v3(15.3, 15.3, 4.3), 1);
}

static void find(const struct mesh *m, double min_mm3, int antialias, struct hl_fill *f)
{
	struct raster_map map;
	struct err e;

	memset(&map, 0, sizeof map);
	map.a[0][0] = 1 / PX;
	map.a[1][1] = 1 / PX;
	map.b[0] = 10;
	map.b[1] = 10;
	memset(f, 0, sizeof *f);
	REQUIRE_OK(hl_fragments_find(m, 8, 12, &map, antialias, 128, LAYER, min_mm3, f, &e), &e);
}

static void test_bead_found(void)
{
	struct mesh m;
	struct hl_fill f;
	int layers = 0;

	part(&m);
	for (int aa = 0; aa < 2; aa++) {
		find(&m, 8, aa, &f);
		CHECK_EQ_INT((long long)f.voids, 1);
		CHECK_EQ_INT((long long)f.voids_small, 1); /* the big void, not kept */
		CHECK_NEAR(f.volume_mm3, 0.3 * 0.3 * 0.3, 1e-9);
		/* every run inside the bead's box: pixel centres of image
		 * (u0 + x, v0 + y) are at ((u + 0.5) - 10) PX mm */
		layers = 0;
		for (int k = 0; k < f.n; k++) {
			if (f.layer[k].n)
				layers++;
			for (size_t i = 0; i < f.layer[k].n; i++) {
				const struct hl_span *r = &f.layer[k].run[i];
				double y = (f.v0 + r->y + 0.5 - 10) * PX;
				double x0 = (f.u0 + r->x0 + 0.5 - 10) * PX, x1 = (f.u0 + r->x1 + 0.5 - 10) * PX;
				CHECK(y > 15 && y < 15.3 && x0 > 15 && x1 < 15.3);
				CHECK((k + 0.5) * LAYER > 4 && (k + 0.5) * LAYER < 4.3);
			}
		}
		CHECK_EQ_INT(layers, 6);
		hl_fill_fini(&f);
	}
	/* below both: nothing; above both: both, 600 + 0.027 mm3 */
	find(&m, 0.01, 1, &f);
	CHECK_EQ_INT((long long)f.voids, 0);
	CHECK_EQ_INT((long long)f.voids_small, 2);
	hl_fill_fini(&f);
	find(&m, 1000, 1, &f);
	CHECK_EQ_INT((long long)f.voids, 2);
	CHECK_NEAR(f.volume_mm3, 600 + 0.027, 1e-6);
	hl_fill_fini(&f);
	/* no void surface: nothing to find */
	m.nt = 12;
	m.nv = 8;
	find(&m, 8, 1, &f);
	CHECK_EQ_INT((long long)f.voids, 0);
	CHECK(f.layer == NULL);
	hl_fill_fini(&f);
	mem_free(m.v);
	mem_free(m.tri);
}

int main(void)
{
	RUN(test_bead_found);
	return harness_report();
}
