/* test_mesh_out.c - the STL/OBJ writers behind the same writer table as the
 * layer formats: a tetrahedron through out_open/out_mesh/out_close reads back
 * with its own volume (computed here from the four corners, not by the
 * writer's mesh_analyze), and the two kinds of writer refuse each other's
 * input (a layer to a mesh writer, a mesh to a layer writer).
 */
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/metrics.h"
#include "engine/core/sink.h"
#include "engine/mesh/mesh.h"
#include "engine/output/output.h"
#include "engine/output/printer/printer.h"
#include "engine/slice/layer.h"
#include "harness.h"

/* Corners (mm): volume = 10 * 20 * 30 / 6 = 1000 mm^3. */
static struct mesh *tetra(void)
{
	struct mesh *m = mesh_new();
	int rc = !m;

	rc = rc || mesh_add_vertex(m, (struct vec3){0, 0, 0});
	rc = rc || mesh_add_vertex(m, (struct vec3){10, 0, 0});
	rc = rc || mesh_add_vertex(m, (struct vec3){0, 20, 0});
	rc = rc || mesh_add_vertex(m, (struct vec3){0, 0, 30});
	rc = rc || mesh_add_triangle(m, 0, 2, 1);
	rc = rc || mesh_add_triangle(m, 0, 1, 3);
	rc = rc || mesh_add_triangle(m, 0, 3, 2);
	rc = rc || mesh_add_triangle(m, 1, 2, 3);
	if (rc) {
		mesh_free(m);
		return NULL;
	}
	return m;
}

static void write_one(enum out_format f, struct buf *b, struct metrics *m)
{
	struct out_info oi;
	struct out_writer *w = NULL;
	struct mesh *t = tetra();
	struct sink s;
	struct layer ly;
	struct err e;

	REQUIRE(t);
	memset(&oi, 0, sizeof oi);
	oi.format = f;
	oi.job_name = "tetra";
	oi.threads = 1;
	sink_init_buf(&s, b);
	err_clear(&e);
	REQUIRE_OK(out_open(&oi, &s, &w, &e), &e);
	memset(&ly, 0, sizeof ly);
	CHECK(out_layer(w, &ly, &e) == ERR_INTERNAL); /* a mesh writer takes no layers */
	err_clear(&e);
	REQUIRE_OK(out_mesh(w, t, &e), &e);
	CHECK(out_mesh(w, t, &e) == ERR_INTERNAL); /* one mesh */
	err_clear(&e);
	REQUIRE_OK(out_close(w, m, &e), &e);
	out_free(w);
	mesh_free(t);
}

/* Signed volume of a binary STL's triangles, read here byte by byte. */
static double stl_volume(const struct buf *b)
{
	uint32_t n;
	double v = 0;

	if (b->len < 84)
		return -1;
	memcpy(&n, b->data + 80, 4);
	if (b->len != 84 + (size_t)n * 50)
		return -1;
	for (uint32_t i = 0; i < n; i++) {
		float f[12];
		double p[3][3];

		memcpy(f, b->data + 84 + (size_t)i * 50, sizeof f);
		for (int k = 0; k < 3; k++)
			for (int j = 0; j < 3; j++)
				p[k][j] = f[3 + 3 * k + j];
		v += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
		      p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
		      p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) /
		     6.0;
	}
	return v;
}

static void test_stl(void)
{
	struct buf b;
	struct metrics m;
	const struct metric *v;

	buf_init(&b);
	metrics_init(&m);
	write_one(OUT_STL, &b, &m);
	CHECK_NEAR(stl_volume(&b), 1000.0, 1e-6);
	v = metrics_get(&m, "material_volume_mm3");
	REQUIRE(v);
	CHECK_NEAR(v->num, 1000.0, 1e-6);
	v = metrics_get(&m, "result_mesh.triangles");
	REQUIRE(v);
	CHECK_EQ_INT((int)v->ival, 4);
	metrics_fini(&m);
	buf_fini(&b);
}

static void test_obj(void)
{
	struct buf b;
	struct metrics m;
	int verts = 0, faces = 0;

	buf_init(&b);
	metrics_init(&m);
	write_one(OUT_OBJ, &b, &m);
	for (size_t i = 0; i < b.len; i++) {
		if (i == 0 || b.data[i - 1] == '\n') {
			verts += b.data[i] == 'v' && i + 1 < b.len && b.data[i + 1] == ' ';
			faces += b.data[i] == 'f' && i + 1 < b.len && b.data[i + 1] == ' ';
		}
	}
	CHECK_EQ_INT(verts, 4);
	CHECK_EQ_INT(faces, 4);
	metrics_fini(&m);
	buf_fini(&b);
}

/* A layer writer refuses a mesh. */
static void test_layer_writer_refuses_mesh(void)
{
	struct out_info oi;
	struct out_writer *w = NULL;
	struct mesh *t = tetra();
	struct printer p;
	struct buf b;
	struct sink s;
	struct err e;

	REQUIRE(t);
	err_clear(&e);
	REQUIRE_OK(printer_lookup("generic-fdm", &p, &e), &e);
	memset(&oi, 0, sizeof oi);
	oi.format = OUT_GCODE;
	oi.printer = &p;
	oi.layer_count = 1;
	oi.layer_mm = 0.2;
	oi.part_bbox = (struct box3){{0, 0, 0}, {10, 20, 0.2}};
	oi.job_name = "tetra";
	oi.threads = 1;
	buf_init(&b);
	sink_init_buf(&s, &b);
	REQUIRE_OK(out_open(&oi, &s, &w, &e), &e);
	CHECK(out_mesh(w, t, &e) == ERR_INTERNAL);
	out_free(w);
	mesh_free(t);
	buf_fini(&b);
}

int main(void)
{
	RUN(test_stl);
	RUN(test_obj);
	RUN(test_layer_writer_refuses_mesh);
	return harness_report();
}
