/* bench_mesh.c - mesh input speed: read + weld + analyze, repair, BVH queries.
 *
 * Prints wall times for a generated binary STL of ~1M triangles (a
 * finely subdivided sphere, written with mesh_write_stl) and the shared
 * armadillo.off / bunny.stl, and BVH build/query rates.  Not part of
 * `make test`: build with `make bench-mesh` (or tests/bench/run.sh).
 * Usage: bench_mesh [SHARED_DIR]
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/mesh/mesh.h"

static double now(void)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* UV sphere with nu x nv quads -> 2 nu nv triangles (soup written as STL). */
static struct mesh *uv_sphere(int nu, int nv)
{
	struct mesh *m = mesh_new();
	int i, j;

	for (j = 0; j <= nv; j++)
		for (i = 0; i < nu; i++) {
			double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
			double s = j == 0 || j == nv ? 0 : sin(th); /* exact poles */
			mesh_add_vertex(m, v3(25 * s * cos(ph), 25 * s * sin(ph), 25 * cos(th)));
		}
	for (j = 0; j < nv; j++)
		for (i = 0; i < nu; i++) {
			uint32_t a = (uint32_t)(j * nu + i), b = (uint32_t)(j * nu + (i + 1) % nu);
			uint32_t c = a + (uint32_t)nu, d = b + (uint32_t)nu;
			mesh_add_triangle(m, a, c, b);
			mesh_add_triangle(m, b, c, d);
		}
	return m;
}

static void bench_file(const char *path)
{
	struct mesh *m = NULL;
	struct mesh_report r;
	struct mesh_bvh *b = NULL;
	struct err e;
	double t0, t1, t2, t3, t4, t5, t6, acc = 0;
	size_t merged, dropped;
	int i, n = 100000, in = 0;

	err_clear(&e);
	t0 = now();
	if (mesh_read_file(path, MESH_FMT_AUTO, &m, NULL, &e)) {
		printf("%s: %s\n", path, e.msg);
		return;
	}
	t1 = now();
	mesh_weld(m, 0, &merged, &dropped, &e);
	t2 = now();
	mesh_analyze(m, &r, &e);
	t3 = now();
	printf("%-28s %9zu tris  read %.3f s  weld %.3f s  analyze %.3f s  = %.3f s"
	       "  (border %zu, watertight %d)\n",
	       path, r.triangles, t1 - t0, t2 - t1, t3 - t2, t3 - t0, r.border_edges,
	       r.watertight);
	t3 = now();
	mesh_repair(m, &r, &e);
	t4 = now();
	if (mesh_bvh_new(m, &b, &e) == 0) {
		struct vec3 s = box3_size(r.bbox);
		t5 = now();
		srand(1);
		for (i = 0; i < n; i++) {
			struct vec3 p = v3(r.bbox.lo.x + s.x * rand() / RAND_MAX,
					   r.bbox.lo.y + s.y * rand() / RAND_MAX,
					   r.bbox.lo.z + s.z * rand() / RAND_MAX);
			in += mesh_bvh_inside(b, p);
		}
		t6 = now();
		srand(1);
		for (i = 0; i < n; i++) {
			struct vec3 p = v3(r.bbox.lo.x + s.x * rand() / RAND_MAX,
					   r.bbox.lo.y + s.y * rand() / RAND_MAX,
					   r.bbox.lo.z + s.z * rand() / RAND_MAX);
			acc += mesh_bvh_closest(b, p, NULL, NULL);
		}
		printf("%-28s repair %.3f s  bvh build %.3f s  inside %.2f us/query (%d%% in)"
		       "  closest %.2f us/query\n",
		       "", t4 - t3, t5 - t4, (t6 - t5) / n * 1e6, 100 * in / n,
		       (now() - t6) / n * 1e6);
		(void)acc;
		mesh_bvh_free(b);
	}
	mesh_free(m);
}

int main(int argc, char **argv)
{
	const char *shared = argc > 1 ? argv[1] : "../shared";
	char path[1024], tmp[] = "/tmp/infilld-bench-XXXXXX";
	struct mesh *m = uv_sphere(1000, 500);
	struct buf b;
	struct sink s;
	struct err e;
	int fd;

	buf_init(&b);
	sink_init_buf(&s, &b);
	if (mesh_write_stl(m, 1, &s, &e) || (fd = mkstemp(tmp)) < 0 ||
	    write(fd, b.data, b.len) != (ssize_t)b.len) {
		fprintf(stderr, "cannot write the generated STL\n");
		return 1;
	}
	close(fd);
	mesh_free(m);
	buf_fini(&b);
	printf("generated: UV sphere, binary STL %s\n", tmp);
	bench_file(tmp);
	unlink(tmp);
	snprintf(path, sizeof path, "%s/meshes/armadillo.off", shared);
	bench_file(path);
	snprintf(path, sizeof path, "%s/meshes/bunny.stl", shared);
	bench_file(path);
	return 0;
}
