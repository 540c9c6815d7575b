/* test_nomem.c - allocation-failure injection through every reader and algorithm.
 *
 * For n = 1, 2, ... the n-th allocation fails (mem_fail_after): each call
 * must return ERR_NOMEM (or succeed once n passes the number of
 * allocations it makes) and leave nothing allocated; the SANITIZE=1 build
 * turns any leak into a failure at exit.
 */
#include "harness.h"

#include "engine/core/sink.h"
#include "mesh_fixtures.h"

/* A small mesh with a quad and a non-convex hexagon, in each format. */
static const char *const texts[] = {
	"v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 1\n"
	"f 1 2 3 4 5 6\nf 1 2 7\nf -1 -2 -3 -4\n",
	"OFF\n7 3 0\n0 0 0\n2 0 0\n2 1 0\n1 1 0\n1 2 0\n0 2 0\n0 0 1\n"
	"6 0 1 2 3 4 5\n3 0 1 6\n4 6 5 4 3\n",
	"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
	"property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
	"0 0 0\n1 0 0\n1 1 0\n0 0 1\n4 0 1 2 3\n3 0 1 3\n",
	"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
	"endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
	"vertex 0 1 1\nendloop\nendfacet\nendsolid t\n",
};

static int read_with_failures(const void *d, size_t len, const char *what)
{
	long n;
	int calls = 0;

	for (n = 1; n < 10000; n++) {
		struct mesh *m = NULL;
		struct err e;
		int rc;
		err_clear(&e);
		mem_fail_after(n);
		rc = mesh_read_buffer(d, len, MESH_FMT_AUTO, NULL, &m, NULL, &e);
		mem_fail_after(-1);
		calls++;
		if (rc == 0) {
			CHECK(m != NULL);
			mesh_free(m);
			return calls;
		}
		if (rc != ERR_NOMEM)
			fprintf(stderr, "%s: n=%ld rc=%d %s\n", what, n, rc, e.msg);
		CHECK_EQ_INT(rc, ERR_NOMEM);
		CHECK(m == NULL);
		if (rc != ERR_NOMEM)
			return calls;
	}
	CHECK(0);
	return calls;
}

static void test_text_readers(void)
{
	size_t i;

	for (i = 0; i < sizeof texts / sizeof texts[0]; i++)
		CHECK_INT(read_with_failures(texts[i], strlen(texts[i]), texts[i]), >, 1);
}

static void test_binary_readers(void)
{
	struct mesh *m = fx_icosphere(1, 1);
	struct buf b;
	struct sink s;
	struct err e;

	buf_init(&b);
	sink_init_buf(&s, &b);
	REQUIRE_OK(mesh_weld(m, 0, NULL, NULL, &e), &e);
	REQUIRE_OK(mesh_write_stl(m, 1, &s, &e), &e);
	CHECK_INT(read_with_failures(b.data, b.len, "stl-bin"), >, 1);
	buf_reset(&b);
	REQUIRE_OK(mesh_write_ply(m, 1, &s, &e), &e);
	CHECK_INT(read_with_failures(b.data, b.len, "ply-bin"), >, 1);
	buf_fini(&b);
	mesh_free(m);
}

/* Algorithms on a copy: ERR_NOMEM until enough allocations succeed. */
static void test_algorithms(void)
{
	struct mesh *src = fx_icosphere(1, 2);
	int step;

	for (step = 0; step < 5; step++) {
		long n;
		for (n = 1; n < 1000; n++) {
			struct mesh *m = mesh_clone(src);
			struct mesh_report r;
			struct mesh_bvh *b = NULL;
			struct buf out;
			struct sink s;
			struct err e;
			int rc;
			REQUIRE(m);
			if (step > 0)
				REQUIRE_OK(mesh_weld(m, 0, NULL, NULL, &e), &e);
			buf_init(&out);
			sink_init_buf(&s, &out);
			err_clear(&e);
			mem_fail_after(n);
			switch (step) {
			case 0: rc = mesh_weld(m, n % 2 ? 0 : 1e-6, NULL, NULL, &e); break;
			case 1: rc = mesh_analyze(m, &r, &e); break;
			case 2: rc = mesh_repair(m, &r, &e); break;
			case 3: rc = mesh_bvh_new(m, &b, &e); break;
			default: rc = mesh_write_obj(m, &s, &e); break;
			}
			mem_fail_after(-1);
			mesh_bvh_free(b);
			buf_fini(&out);
			mesh_free(m);
			if (rc == 0)
				break;
			CHECK_EQ_INT(rc, ERR_NOMEM);
			if (rc != ERR_NOMEM) {
				fprintf(stderr, "step %d n=%ld: %s\n", step, n, e.msg);
				break;
			}
		}
		CHECK_INT(n, <, 1000);
	}
	mesh_free(src);
}

int main(void)
{
	RUN(test_text_readers);
	RUN(test_binary_readers);
	RUN(test_algorithms);
	return harness_report();
}
