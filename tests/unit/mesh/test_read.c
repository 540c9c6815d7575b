/* test_read.c - mesh readers: OBJ, OFF, PLY, STL syntax, detection and errors.
 *
 * Each case is a small literal file with its expected geometry (checked
 * against hand-computed values) or its expected error code, message
 * substring and place (line / byte offset / record).
 */
#include "harness.h"

#include "mesh_fixtures.h"

#include "engine/mesh/text.h"

static double total_area(const struct mesh *m)
{
	double a = 0;
	size_t t;

	for (t = 0; t < m->nt; t++) {
		struct vec3 p = m->v[m->tri[3 * t]], q = m->v[m->tri[3 * t + 1]],
			    r = m->v[m->tri[3 * t + 2]];
		a += 0.5 * v3_len(v3_cross(v3_sub(q, p), v3_sub(r, p)));
	}
	return a;
}

/* Expect failure with code, substring and line (0 = don't check). */
static void expect_error(const char *src, enum mesh_format fmt, int code, const char *sub,
			 long line)
{
	struct mesh *m = NULL;
	struct err e;
	int rc = fx_read_str(src, fmt, &m, NULL, &e);

	CHECK_EQ_INT(rc, code);
	CHECK(m == NULL);
	CHECK_CONTAINS(e.msg, sub);
	if (line)
		CHECK_EQ_INT(e.line, line);
	mesh_free(m);
}

static void test_obj_basic(void)
{
	const char *src = "# comment\n"
			  "o  my part \n"
			  "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0 0.5 0.5 0.5\n"
			  "vt 0 0\nvn 0 0 1\n"
			  "g group\ns off\nusemtl red\n"
			  "f 1/1/1 2/1/1 3//1\n"
			  "f -4 -2 -1\n";
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;

	REQUIRE_OK(fx_read_str(src, MESH_FMT_AUTO, &m, &info, &e), &e);
	CHECK_EQ_INT(info.format, MESH_FMT_OBJ);
	CHECK_STR(info.name, "my part");
	CHECK_EQ_INT(m->nv, 4);
	CHECK_EQ_INT(m->nt, 2);
	CHECK_EQ_INT(m->tri[0], 0);
	CHECK_EQ_INT(m->tri[2], 2);
	/* relative: -4 -2 -1 with 4 vertices = 0 2 3 */
	CHECK_EQ_INT(m->tri[3], 0);
	CHECK_EQ_INT(m->tri[4], 2);
	CHECK_EQ_INT(m->tri[5], 3);
	CHECK_NEAR(total_area(m), 1.0, 1e-15);
	mesh_free(m);
}

static void test_obj_polygons(void)
{
	/* An L-shaped (non-convex) hexagon: area 3; a fan from corner 0
	 * would overlap, ear clipping must not. */
	const char *src = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n"
			  "f 4 5 6 1 2 3\n"
			  "f 1 2 3 4 5 6 1\n"; /* closing corner repeated: still 7 corners */
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;
	size_t t;

	REQUIRE_OK(fx_read_str(src, MESH_FMT_OBJ, &m, &info, &e), &e);
	CHECK_EQ_INT(m->nt, 4 + 5);
	CHECK_EQ_INT(info.polygons_split, 2);
	/* first polygon: 4 triangles, all CCW (+z), total area 3 */
	for (t = 0; t < 4; t++) {
		struct vec3 p = m->v[m->tri[3 * t]], q = m->v[m->tri[3 * t + 1]],
			    r = m->v[m->tri[3 * t + 2]];
		CHECK_NUM(v3_cross(v3_sub(q, p), v3_sub(r, p)).z, >, 0);
	}
	m->nt = 4;
	CHECK_NEAR(total_area(m), 3.0, 1e-12);
	mesh_free(m);
}

static void test_obj_forward_and_errors(void)
{
	struct mesh *m = NULL;
	struct err e;

	/* forward references are legal once the vertices exist */
	REQUIRE_OK(fx_read_str("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", MESH_FMT_OBJ, &m, NULL, &e),
		   &e);
	CHECK_EQ_INT(m->nt, 1);
	mesh_free(m);
	expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", MESH_FMT_OBJ, ERR_PARSE,
		     "vertex index 4 out of range", 4);
	expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", MESH_FMT_OBJ, ERR_PARSE,
		     "index 0", 4);
	expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", MESH_FMT_OBJ, ERR_PARSE,
		     "before the first vertex", 4);
	expect_error("v 0 0 0\nv 1 nan 0\n", MESH_FMT_OBJ, ERR_PARSE, "vertex 1: coordinate is NaN",
		     2);
	expect_error("v 0 0 0\nv 1 inf 0\n", MESH_FMT_OBJ, ERR_PARSE, "infinite", 2);
	expect_error("v 0 0\n", MESH_FMT_OBJ, ERR_PARSE, "expected 3 coordinates", 1);
	expect_error("v 0 0 0\nv 1 0 0\nf 1 2\n", MESH_FMT_OBJ, ERR_PARSE, "2 corners", 3);
	expect_error("v 0 0 0\nv 1 0 0\nv 1 1 1\nf 1 2 x\n", MESH_FMT_OBJ, ERR_PARSE,
		     "expected a vertex index", 4);
	expect_error("v 1 2 3x\n", MESH_FMT_OBJ, ERR_PARSE, "expected 3 coordinates", 1);
	expect_error("v 0 0 0\n", MESH_FMT_OBJ, ERR_GEOMETRY, "no triangles", 0);
	expect_error("v 0 0 0\n\x01\x02garbage\n", MESH_FMT_OBJ, ERR_PARSE, "binary", 2);
}

static void test_off_variants(void)
{
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;

	/* counts on the header line, comments, blank lines, a quad with a colour */
	REQUIRE_OK(fx_read_str("OFF 4 1 0\n# c\n\n0 0 0\n2 0 0 # x\n2 3 0\n0 3 0\n"
			       "4 0 1 2 3 255 0 0\n",
			       MESH_FMT_AUTO, &m, &info, &e),
		   &e);
	CHECK_EQ_INT(info.format, MESH_FMT_OFF);
	CHECK_EQ_INT(m->nt, 2);
	CHECK_EQ_INT(info.polygons_split, 1);
	CHECK_NEAR(total_area(m), 6.0, 1e-15);
	mesh_free(m);
	/* counts on a later line after comments; COFF with vertex colours */
	REQUIRE_OK(fx_read_str("# lead\nCOFF\n# counts next\n3 1 3\n0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n"
			       "0 1 0 0 0 1 1\n3 0 1 2\n",
			       MESH_FMT_AUTO, &m, &info, &e),
		   &e);
	CHECK_EQ_INT(m->nt, 1);
	CHECK_NEAR(total_area(m), 0.5, 1e-15);
	mesh_free(m);
	expect_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", MESH_FMT_OFF, ERR_PARSE,
		     "vertex index 3 out of range [0, 3)", 6);
	expect_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", MESH_FMT_OFF, ERR_PARSE,
		     "vertex index -1", 6);
	expect_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1\n3 0 1 2\n", MESH_FMT_OFF, ERR_PARSE,
		     "vertex 2: expected 3 coordinates", 5);
	expect_error("OFF\n3 1 0\n0 0 0\n1 NaN 0\n0 1 0\n3 0 1 2\n", MESH_FMT_OFF, ERR_PARSE,
		     "vertex 1: coordinate is NaN", 4);
	expect_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", MESH_FMT_OFF, ERR_PARSE,
		     "2 corners", 6);
	expect_error("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", MESH_FMT_OFF, ERR_PARSE,
		     "face 1: expected the corner count", 0);
	expect_error("OFF\n9999999 1 0\n0 0 0\n", MESH_FMT_OFF, ERR_PARSE,
		     "more than a 22-byte file can hold", 0);
	expect_error("OFF\n999999999 1 0\n0 0 0\n", MESH_FMT_OFF, ERR_LIMIT,
		     "more than the limit of", 0);
	expect_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n", MESH_FMT_OFF,
		     ERR_PARSE, "more than the rest of the file", 6);
	expect_error("OFF\nx 1 0\n", MESH_FMT_OFF, ERR_PARSE, "expected the vertex count", 2);
	expect_error("4OFF\n1 1 0\n", MESH_FMT_AUTO, ERR_UNSUPPORTED, "4D", 0);
	expect_error("OFF BINARY\n", MESH_FMT_OFF, ERR_UNSUPPORTED, "binary OFF", 0);
}

/* Binary PLY builder: little or big endian values. */
struct bw {
	unsigned char b[4096];
	size_t n;
	int be;
};

static void bw_raw(struct bw *w, const void *p, size_t n)
{
	size_t i;

	for (i = 0; i < n; i++)
		w->b[w->n + i] = ((const unsigned char *)p)[w->be ? n - 1 - i : i];
	w->n += n;
}

static void bw_str(struct bw *w, const char *s)
{
	memcpy(w->b + w->n, s, strlen(s));
	w->n += strlen(s);
}

static void test_ply_binary(int be)
{
	struct bw w;
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;
	int16_t sx;
	double dy;
	float fz;
	uint8_t cnt;
	int32_t idx;
	uint16_t other;
	int i;
	/* x as int16, y as double, z as float; extra property and list in the
	 * vertex element; a face list with uchar count and int indices, a face
	 * flag property; an "edge" element after the faces. */
	static const int vx[4][3] = {{0, 0, 0}, {4, 0, 0}, {4, 2, 0}, {0, 2, 0}};

	memset(&w, 0, sizeof w);
	w.be = be;
	bw_str(&w, be ? "ply\nformat binary_big_endian 1.0\n" : "ply\nformat binary_little_endian 1.0\n");
	bw_str(&w, "comment test\nelement vertex 4\nproperty ushort flags\nproperty short x\n"
		   "property double y\nproperty list uchar int extra\nproperty float z\n"
		   "element face 1\nproperty list uchar int vertex_indices\nproperty ushort f\n"
		   "element edge 1\nproperty int a\nproperty int b\nend_header\n");
	for (i = 0; i < 4; i++) {
		other = 7;
		bw_raw(&w, &other, 2);
		sx = (int16_t)vx[i][0];
		bw_raw(&w, &sx, 2);
		dy = vx[i][1];
		bw_raw(&w, &dy, 8);
		cnt = 1;
		bw_raw(&w, &cnt, 1);
		idx = 99;
		bw_raw(&w, &idx, 4);
		fz = (float)vx[i][2];
		bw_raw(&w, &fz, 4);
	}
	cnt = 4;
	bw_raw(&w, &cnt, 1);
	for (i = 0; i < 4; i++) {
		idx = i;
		bw_raw(&w, &idx, 4);
	}
	other = 1;
	bw_raw(&w, &other, 2);
	idx = 0;
	bw_raw(&w, &idx, 4);
	bw_raw(&w, &idx, 4);
	err_clear(&e);
	REQUIRE_OK(mesh_read_buffer(w.b, w.n, MESH_FMT_AUTO, NULL, &m, &info, &e), &e);
	CHECK_EQ_INT(info.format, MESH_FMT_PLY);
	CHECK_EQ_INT(info.binary, 1);
	CHECK_EQ_INT(m->nv, 4);
	CHECK_EQ_INT(m->nt, 2);
	CHECK_NEAR(m->v[2].x, 4, 0);
	CHECK_NEAR(m->v[2].y, 2, 0);
	CHECK_NEAR(total_area(m), 8.0, 1e-15);
	mesh_free(m);
	/* truncated body: the element sizes no longer fit */
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_buffer(w.b, w.n - 20, MESH_FMT_PLY, NULL, &m, NULL, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "face 0: list length 4");
	CHECK_EQ_INT(e.offset, (long long)w.n - 27 + 1); /* just after the count byte */
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_buffer(w.b, w.n - 4, MESH_FMT_PLY, NULL, &m, NULL, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "truncated in edge 0");
	CHECK_EQ_INT(e.offset, (long long)w.n - 4); /* where edge.b would start */
}

static void test_ply_binary_le(void)
{
	test_ply_binary(0);
}

static void test_ply_binary_be(void)
{
	test_ply_binary(1);
}

static void test_ply_ascii(void)
{
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;
	const char *src = "ply\nformat ascii 1.0\nobj_info x\nelement vertex 3\nproperty float z\n"
			  "property float x\nproperty uchar red\nproperty float y\n"
			  "element face 1\nproperty list int uint vertex_index\nend_header\n"
			  "0 0 255 0\n0 1 255 0\n0 0 255 1\n3 0 1 2\n";

	REQUIRE_OK(fx_read_str(src, MESH_FMT_AUTO, &m, &info, &e), &e);
	CHECK_EQ_INT(info.binary, 0);
	CHECK_EQ_INT(m->nt, 1);
	CHECK_NEAR(m->v[1].x, 1, 0);
	CHECK_NEAR(m->v[2].y, 1, 0);
	CHECK_NEAR(total_area(m), 0.5, 1e-15);
	mesh_free(m);
	expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
		     "element face 1\nproperty list uchar int vertex_indices\nend_header\n",
		     MESH_FMT_PLY, ERR_PARSE, "lacks an x, y or z", 0);
	expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
		     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
		     "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n",
		     MESH_FMT_PLY, ERR_PARSE, "vertex index 5 out of range", 0);
	expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
		     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
		     "end_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
		     MESH_FMT_PLY, ERR_PARSE, "coordinate is NaN", 11);
	expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
		     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
		     "end_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
		     MESH_FMT_PLY, ERR_PARSE, "2 corners", 0);
	expect_error("ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
		     "property float y\nproperty float z\nend_header\n0 0 0\n",
		     MESH_FMT_PLY, ERR_LIMIT, "limit", 0);
	expect_error("ply\nformat ascii 1.0\nelement vertex 1000\nproperty float x\n"
		     "property float y\nproperty float z\nend_header\n0 0 0\n",
		     MESH_FMT_PLY, ERR_PARSE, "more than the", 0);
	expect_error("ply\nformat ascii 1.0\nelement vertex 3\nproperty quux x\nend_header\n",
		     MESH_FMT_PLY, ERR_PARSE, "unknown PLY property type 'quux'", 4);
	expect_error("ply\nformat xml 1.0\n", MESH_FMT_PLY, ERR_PARSE, "unknown PLY format", 2);
	expect_error("ply\nformat ascii 1.0\nelement vertex 1\n", MESH_FMT_PLY, ERR_PARSE,
		     "no end_header", 0);
}

static void test_stl_ascii_and_binary(void)
{
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct err e;
	unsigned char bin[84 + 50];
	float f[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
	int i;

	/* keywords in any case, several solids, numbers with exponents */
	REQUIRE_OK(fx_read_str("SOLID a\nFACET NORMAL 0 0 1\nOUTER LOOP\nVERTEX 0 0 0\n"
			       "VERTEX 1e0 0 0\nVERTEX 0 +1.0E+00 0\nENDLOOP\nENDFACET\nENDSOLID a\n"
			       "solid b\nfacet normal 0 0 1 outer loop vertex 0 0 1 vertex 1 0 1 "
			       "vertex 0 1 1 endloop endfacet endsolid b\n",
			       MESH_FMT_AUTO, &m, &info, &e),
		   &e);
	CHECK_EQ_INT(info.format, MESH_FMT_STL);
	CHECK_EQ_INT(info.binary, 0);
	CHECK_EQ_INT(m->nt, 2);
	CHECK_STR(info.name, "a");
	CHECK_NEAR(m->v[5].z, 1, 0);
	mesh_free(m);
	/* binary whose header starts with "solid" followed by a newline and "facet" */
	memset(bin, 0, sizeof bin);
	memcpy(bin, "solid x\nfacet normal", 20);
	bin[80] = 1;
	for (i = 0; i < 12; i++)
		memcpy(bin + 84 + 4 * i, &f[i], 4);
	err_clear(&e);
	REQUIRE_OK(mesh_read_buffer(bin, sizeof bin, MESH_FMT_AUTO, NULL, &m, &info, &e), &e);
	CHECK_EQ_INT(info.binary, 1);
	CHECK_EQ_INT(m->nt, 1);
	CHECK_NEAR(m->v[2].y, 1, 0);
	CHECK_CONTAINS(info.first_warning, "starts with \"solid\"");
	mesh_free(m);
	/* NaN vertex in binary: byte offset of the coordinate, facet index */
	f[4] = NAN;
	memcpy(bin + 84 + 16, &f[4], 4);
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_buffer(bin, sizeof bin, MESH_FMT_STL, NULL, &m, NULL, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "facet 0 vertex 0: coordinate is NaN");
	CHECK_EQ_INT(e.offset, 84 + 16);
	CHECK_EQ_INT(e.item, 0);
	/* absurd count: refused before allocating, by the size rule */
	bin[80] = 0xff;
	bin[81] = 0xff;
	bin[82] = 0xff;
	bin[83] = 0x7f;
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_buffer(bin, sizeof bin, MESH_FMT_STL, NULL, &m, NULL, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "declares 2147483647 triangles");
	CHECK_EQ_INT(e.offset, 80);
	expect_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
		     "vertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\n"
		     "vertex 0 0 0\nvertex 1 0 nan\n",
		     MESH_FMT_STL, ERR_PARSE, "facet 1 vertex 1: coordinate is NaN", 12);
	expect_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
		     MESH_FMT_STL, ERR_PARSE, "found the end of the file", 0);
	expect_error("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 zero\n",
		     MESH_FMT_STL, ERR_PARSE, "expected a vertex coordinate, found 'zero'", 5);
	expect_error("solid x\nbanana\n", MESH_FMT_STL, ERR_PARSE,
		     "expected facet or endsolid, found 'banana'", 2);
	expect_error("hello", MESH_FMT_STL, ERR_PARSE, "shorter than a binary STL header", 0);
	expect_error("random words without a known format", MESH_FMT_AUTO, ERR_PARSE,
		     "unrecognised mesh format", 0);
}

static void test_detect_by_name(void)
{
	struct mesh *m = NULL;
	struct err e;
	const char *obj = "# only a comment first\n\nmtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

	err_clear(&e);
	REQUIRE_OK(mesh_read_buffer(obj, strlen(obj), MESH_FMT_AUTO, "part.OBJ", &m, NULL, &e), &e);
	CHECK_EQ_INT(m->nt, 1);
	mesh_free(m);
	/* content that matches nothing, named .off: the OFF reader explains */
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_buffer("xyz\n", 4, MESH_FMT_AUTO, "a.off", &m, NULL, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "expected the OFF keyword");
	err_clear(&e);
	CHECK_EQ_INT(mesh_read_file("/nonexistent/file.stl", MESH_FMT_AUTO, &m, NULL, &e),
		     ERR_NOTFOUND);
}

static void test_numbers(void)
{
	/* Correct rounding on the fast path and the fallback path. */
	const char *src = "v 0.1 1e-300 123456789012345678901234567890\n"
			  "v 3.141592653589793238 -0 1.7976931348623157e308\n"
			  "v 4.9e-324 .5 5.\n"
			  "f 1 2 3\n";
	static const double want[] = {0.1, 1e-300, 123456789012345678901234567890.0,
				      3.141592653589793, -0.0, 1.7976931348623157e308,
				      4.9e-324, 0.5, 5.0};
	struct mesh_text t;
	double d;
	size_t i;

	/* The number parser itself (the readers then refuse coordinates
	 * beyond MESH_MAX_COORD). */
	mesh_text_init(&t, src, strlen(src));
	for (i = 0; i < 9; i++) {
		if (i % 3 == 0) {
			mesh_text_skip_blank(&t);
			t.p++; /* the "v" */
		}
		mesh_text_skip_blank(&t);
		CHECK_EQ_INT(mesh_text_number(&t, &d), 0);
		CHECK(d == want[i] && signbit(d) == signbit(want[i]));
		if (i % 3 == 2)
			mesh_text_next_line(&t);
	}
	expect_error("v 0 0 0\nv 1 0 0\nv 0 1.7976931348623157e308 0\nf 1 2 3\n", MESH_FMT_OBJ,
		     ERR_GEOMETRY, "vertex 2: coordinate 1.79769e+308 is not a finite number", 0);
	expect_error("v 1 2 1e999\n", MESH_FMT_OBJ, ERR_PARSE, "infinite", 1);
}

/* Fuzzer findings kept as regression cases (tests/data/mesh/). */
static void test_fuzz_regressions(void)
{
	static const struct {
		const char *file;
		enum mesh_format fmt;
		int code;
		const char *text;
	} cases[] = {
		/* NUL byte inside a keyword: the keyword compare ran off its string */
		{"stl-nul-in-keyword", MESH_FMT_STL, ERR_PARSE, "1 bytes after its 12 declared"},
		{"ply-nul-in-keyword", MESH_FMT_PLY, ERR_PARSE, "unknown PLY header keyword"},
		/* 20-digit counts: integer overflow in the parser and the size check */
		{"off-int-overflow", MESH_FMT_OFF, ERR_PARSE, "more than a 68-byte file can hold"},
		{"off-count-overflow", MESH_FMT_OFF, ERR_PARSE, "more than a 99-byte file can hold"},
		/* "element vertex 0": memset of a NULL vertex array (UBSan) */
		{"ply-zero-vertices", MESH_FMT_PLY, ERR_PARSE, "face 0 has 0 corners"},
		/* 1e300: extents and areas overflow to inf downstream */
		{"off-huge-coordinate", MESH_FMT_OFF, ERR_GEOMETRY, "vertex 1: coordinate 1e+300"},
		/* vertex_indices and vertex_index in one face element: the index
		 * buffer was grown for the second list alone (heap overflow) */
		{"ply-two-index-lists", MESH_FMT_PLY, ERR_PARSE, "has 2 vertex index lists"},
	};
	size_t i;

	for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		char path[256];
		struct mesh *m = NULL;
		struct err e;
		snprintf(path, sizeof path, "tests/data/mesh/%s", cases[i].file);
		err_clear(&e);
		CHECK_EQ_INT(mesh_read_file(path, cases[i].fmt, &m, NULL, &e), cases[i].code);
		CHECK_CONTAINS(e.msg, cases[i].text);
		mesh_free(m);
	}
}

int main(void)
{
	RUN(test_fuzz_regressions);
	RUN(test_obj_basic);
	RUN(test_obj_polygons);
	RUN(test_obj_forward_and_errors);
	RUN(test_off_variants);
	RUN(test_ply_binary_le);
	RUN(test_ply_binary_be);
	RUN(test_ply_ascii);
	RUN(test_stl_ascii_and_binary);
	RUN(test_detect_by_name);
	RUN(test_numbers);
	return harness_report();
}
