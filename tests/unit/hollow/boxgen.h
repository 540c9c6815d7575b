/* boxgen.h - axis-aligned box meshes for the hollow unit tests (not a
 * test program: included by test_fragments.c and test_topdown.c).
 */
#ifndef INFILLD_TEST_HOLLOW_BOXGEN_H
#define INFILLD_TEST_HOLLOW_BOXGEN_H

#include <stdint.h>

#include "engine/geom/vec.h"
#include "engine/mesh/mesh.h"

/* Box lo..hi (mm, axis-aligned) as 8 vertices and 12 triangles appended
 * to m (arrays sized by the caller); inward 0: normals out of the box (a
 * part), 1: into the box (a void's surface). */
static inline void add_box(struct mesh *m, struct vec3 lo, struct vec3 hi, int inward)
{
	static const uint32_t f[12][3] = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6},
					  {0, 1, 5}, {0, 5, 4}, {2, 6, 7}, {2, 7, 3},
					  {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
	uint32_t v0 = (uint32_t)m->nv;

	for (int i = 0; i < 8; i++)
		m->v[m->nv++] = (struct vec3){i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y,
					      i & 4 ? hi.z : lo.z};
	for (int t = 0; t < 12; t++) {
		uint32_t *q = m->tri + 3 * m->nt++;
		q[0] = v0 + f[t][0];
		q[1] = v0 + f[t][inward ? 2 : 1];
		q[2] = v0 + f[t][inward ? 1 : 2];
	}
}

#endif
