/* test_neighbours.c - mesh_facet_neighbours (engine/mesh/edges.c) against
 * a brute-force search: on a closed icosphere every edge has exactly the
 * neighbour that shares both its ends, and the relation is symmetric; a
 * removed facet leaves its three neighbours with a border edge; a third
 * facet on an edge makes it non-manifold (no neighbour for any of them).
 */
#include "harness.h"
#include "unit/slice/meshgen.h"

#include "engine/core/err.h"
#include "engine/mesh/mesh.h"

/* The facet other than t holding both a and b, counting them: brute force. */
static uint32_t brute(const struct mesh *m, size_t t, uint32_t a, uint32_t b, int *count)
{
	uint32_t found = MESH_NO_FACET;

	*count = 0;
	for (size_t g = 0; g < m->nt; g++) {
		int ha = 0, hb = 0;
		if (g == t)
			continue;
		for (int k = 0; k < 3; k++) {
			ha |= m->tri[3 * g + (size_t)k] == a;
			hb |= m->tri[3 * g + (size_t)k] == b;
		}
		if (ha && hb) {
			found = (uint32_t)g;
			(*count)++;
		}
	}
	return *count == 1 ? found : MESH_NO_FACET;
}

static void check_all(const struct mesh *m, const uint32_t *nb)
{
	for (size_t t = 0; t < m->nt; t++)
		for (int k = 0; k < 3; k++) {
			int count;
			uint32_t a = m->tri[3 * t + (size_t)k], b = m->tri[3 * t + (size_t)(k + 1) % 3];
			CHECK_EQ_INT(nb[3 * t + (size_t)k], brute(m, t, a, b, &count));
		}
}

static void test_closed(void)
{
	struct mesh *m = tm_icosphere(v3(0, 0, 0), 1, 2);
	uint32_t *nb = malloc(3 * m->nt * sizeof *nb);
	struct err e;
	size_t border = 0;

	REQUIRE_OK(mesh_facet_neighbours(m, nb, &e), &e);
	check_all(m, nb);
	for (size_t i = 0; i < 3 * m->nt; i++) {
		border += nb[i] == MESH_NO_FACET;
		/* symmetric: t's neighbour lists t back */
		if (nb[i] != MESH_NO_FACET) {
			const uint32_t *o = nb + 3 * (size_t)nb[i];
			CHECK(o[0] == i / 3 || o[1] == i / 3 || o[2] == i / 3);
		}
	}
	CHECK_EQ_INT(border, 0);
	/* open it: exactly the three edges of the removed facet become borders */
	tm_delete_tri(m, 7);
	REQUIRE_OK(mesh_facet_neighbours(m, nb, &e), &e);
	check_all(m, nb);
	border = 0;
	for (size_t i = 0; i < 3 * m->nt; i++)
		border += nb[i] == MESH_NO_FACET;
	CHECK_EQ_INT(border, 3);
	free(nb);
	tm_free(m);
}

static void test_nonmanifold(void)
{
	/* three triangles on the edge 0-1 (a fin) and one lone triangle */
	struct mesh *m = tm_new();
	uint32_t nb[12];
	struct err e;

	tm_vert(m, 0, 0, 0);
	tm_vert(m, 1, 0, 0);
	tm_vert(m, 0, 1, 0);
	tm_vert(m, 0, -1, 0);
	tm_vert(m, 0, 0, 1);
	tm_tri(m, 0, 1, 2);
	tm_tri(m, 1, 0, 3);
	tm_tri(m, 1, 0, 4);
	tm_tri(m, 2, 3, 4);
	REQUIRE_OK(mesh_facet_neighbours(m, nb, &e), &e);
	check_all(m, nb);
	CHECK_EQ_INT(nb[0], MESH_NO_FACET); /* edge 0-1 of facet 0 is used three times */
	CHECK_EQ_INT(nb[3], MESH_NO_FACET);
	CHECK_EQ_INT(nb[6], MESH_NO_FACET);
	tm_free(m);
}

int main(void)
{
	RUN(test_closed);
	RUN(test_nonmanifold);
	return harness_report();
}
