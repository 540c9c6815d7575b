/* test_write.c - every writer round-trips through its reader with the same geometry.
 *
 * Indexed formats (OBJ, OFF, PLY ascii/binary) must give back identical
 * vertices (bitwise, the text writers print round-trip precision) and
 * indices; STL gives a soup whose triangle corners equal the source
 * corners exactly (ASCII) or rounded to float32 (binary).
 */
#include "harness.h"

#include "engine/core/sink.h"
#include "mesh_fixtures.h"

enum wfmt { W_STL_BIN, W_STL_ASCII, W_OBJ, W_OFF, W_PLY_ASCII, W_PLY_BIN, W_COUNT };

static const char *const wname[W_COUNT] = {"stl-bin", "stl-ascii", "obj", "off", "ply-ascii",
					   "ply-bin"};

static int write_fmt(const struct mesh *m, enum wfmt f, struct sink *s, struct err *e)
{
	switch (f) {
	case W_STL_BIN: return mesh_write_stl(m, 1, s, e);
	case W_STL_ASCII: return mesh_write_stl(m, 0, s, e);
	case W_OBJ: return mesh_write_obj(m, s, e);
	case W_OFF: return mesh_write_off(m, s, e);
	case W_PLY_ASCII: return mesh_write_ply(m, 0, s, e);
	default: return mesh_write_ply(m, 1, s, e);
	}
}

static void round_trip(const struct mesh *m, enum wfmt f)
{
	struct buf b;
	struct sink s;
	struct err e;
	struct mesh *r = NULL;
	struct mesh_read_info info;
	size_t i, bad = 0;
	int k;

	buf_init(&b);
	sink_init_buf(&s, &b);
	err_clear(&e);
	REQUIRE_OK(write_fmt(m, f, &s, &e), &e);
	CHECK_EQ_INT(s.bytes, b.len);
	/* detection by content must find the format without a hint */
	if (mesh_read_buffer(b.data, b.len, MESH_FMT_AUTO, NULL, &r, &info, &e) != 0) {
		fprintf(stderr, "%s: %s\n", wname[f], e.msg);
		CHECK(0);
		buf_fini(&b);
		return;
	}
	CHECK_EQ_INT(info.warnings, 0);
	CHECK_EQ_INT(r->nt, m->nt);
	if (f == W_STL_BIN || f == W_STL_ASCII) {
		CHECK_EQ_INT(info.binary, f == W_STL_BIN);
		/* the reader shares identical corners: no 3-per-triangle soup */
		if (f == W_STL_ASCII)
			CHECK_EQ_INT(r->nv, m->nv);
		else
			CHECK_INT(r->nv, <=, m->nv);
		for (i = 0; i < m->nt && r->nt == m->nt; i++)
			for (k = 0; k < 3; k++) {
				struct vec3 p = m->v[m->tri[3 * i + (size_t)k]];
				struct vec3 q = r->v[r->tri[3 * i + (size_t)k]];
				if (f == W_STL_BIN)
					p = v3((float)p.x, (float)p.y, (float)p.z);
				bad += p.x != q.x || p.y != q.y || p.z != q.z;
			}
	} else {
		CHECK_EQ_INT(r->nv, m->nv);
		for (i = 0; i < m->nv && r->nv == m->nv; i++)
			bad += memcmp(&m->v[i], &r->v[i], sizeof m->v[i]) != 0;
		for (i = 0; i < 3 * m->nt && r->nt == m->nt; i++)
			bad += m->tri[i] != r->tri[i];
	}
	if (bad)
		fprintf(stderr, "%s: %zu mismatches\n", wname[f], bad);
	CHECK_EQ_INT(bad, 0);
	mesh_free(r);
	buf_fini(&b);
}

static void test_generated(void)
{
	struct mesh *m = fx_icosphere(12.345678901234567, 2);
	struct err e;
	size_t i;
	int f;

	REQUIRE(m);
	REQUIRE_OK(mesh_weld(m, 0, NULL, NULL, &e), &e);
	/* awkward values: tiny, huge, negative zero, many digits */
	m->v[0].x = 1e-310;
	m->v[1].y = -0.0;
	m->v[2].z = 0.1 + 0.2;
	m->v[3].x = 987654321.123456789; /* near MESH_MAX_COORD */
	for (i = 4; i < m->nv; i++)
		m->v[i].x += 1.0 / 3.0;
	for (f = 0; f < W_COUNT; f++)
		round_trip(m, (enum wfmt)f);
	mesh_free(m);
}

static void test_femur(void)
{
	struct mesh *m = NULL;
	struct err e;
	int f;

	err_clear(&e);
	REQUIRE_OK(mesh_read_file(shared_path("meshes/femur.off"), MESH_FMT_AUTO, &m, NULL, &e),
		   &e);
	for (f = 0; f < W_COUNT; f++)
		round_trip(m, (enum wfmt)f);
	mesh_free(m);
}

static void test_refuses(void)
{
	struct mesh bad = {0};
	struct vec3 v[3] = {{0, 0, 0}, {1, 0, 0}, {1e300, 0, 0}};
	uint32_t tri[3] = {0, 1, 5};
	struct buf b;
	struct sink s;
	struct err e;

	buf_init(&b);
	sink_init_buf(&s, &b);
	bad.v = v;
	bad.tri = tri;
	bad.nv = 3;
	bad.nt = 1;
	err_clear(&e);
	CHECK_EQ_INT(mesh_write_obj(&bad, &s, &e), ERR_INTERNAL);
	CHECK_CONTAINS(e.msg, "refers to vertex 5");
	tri[2] = 2;
	CHECK_EQ_INT(mesh_write_stl(&bad, 1, &s, &e), ERR_LIMIT);
	CHECK_CONTAINS(e.msg, "float32");
	s.limit = 10; /* the sink's limit is reported */
	CHECK_EQ_INT(mesh_write_off(&bad, &s, &e), ERR_LIMIT);
	buf_fini(&b);
}

int main(void)
{
	RUN(test_generated);
	RUN(test_femur);
	RUN(test_refuses);
	return harness_report();
}
