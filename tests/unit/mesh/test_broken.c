/* test_broken.c - every file in ../shared/meshes/broken and misc, table-driven.
 *
 * Each row is the decision documented in docs/mesh.md: an error (code,
 * message substring, place) or a successful read (triangles, quirk
 * warning substring, and after mesh_repair the volume known from the
 * file's coordinates and whether it is watertight).
 */
#include "harness.h"

#include "mesh_fixtures.h"

struct case_row {
	const char *file;
	int code;         /* expected return */
	const char *text; /* substring of the error message, or of the first warning ("" = none) */
	long line;        /* expected error line (0 = not checked) */
	long long offset; /* expected error byte offset (-1 = not checked) */
	size_t triangles; /* on success */
	size_t vertices;  /* on success, after repair (welded) */
	double volume;    /* on success, after repair (NAN: open, origin-dependent) */
	int watertight;   /* on success, after repair */
	const char *name; /* on success: solid name, NULL = not checked */
};

static const struct case_row rows[] = {
	{"broken/empty.stl", ERR_PARSE, "empty file", 0, 0, 0, 0, 0, 0, NULL},
	{"broken/fourVertices.ascii.stl", ERR_PARSE, "facet 0 has more than 3 vertices", 7, -1, 0,
	 0, 0, 0, NULL},
	{"broken/incorrectFaceCounter.bin.stl", ERR_PARSE,
	 "declares 66 triangles (3384 bytes) but the file has 284 bytes", 0, 80, 0, 0, 0, 0, NULL},
	{"broken/missingEndsolid.ascii.stl", 0, "missing endsolid", 0, -1, 4, 4, 1.0 / 6, 1,
	 "tetrahedron"},
	{"broken/missingFace.ascii.stl", 0, "", 0, -1, 3, 4, NAN, 0, "tetrahedron"},
	{"broken/missingNormal.ascii.stl", 0, "facet 3: normal has 0 of 3 coordinates", 0, -1, 4, 4,
	 1.0 / 6, 1, "tetrahedron"},
	{"broken/notANumberNormal.ascii.stl", 0, "facet 1: normal is NaN", 0, -1, 4, 4, 1.0 / 6, 1,
	 "notANumberNormal"},
	{"broken/quad.ascii.stl", ERR_PARSE, "facet 0 has more than 3 vertices", 7, -1, 0, 0, 0, 0,
	 NULL},
	{"broken/singleFace.ascii.stl", 0, "", 0, -1, 1, 3, 0, 0, "faceOnly"},
	{"broken/solidNameMismatch.ascii.stl", 0, "differs from solid name 'tetrahedron'", 0, -1, 4,
	 4, 1.0 / 6, 1, "tetrahedron"},
	{"broken/twoVertices.ascii.stl", ERR_PARSE, "facet 0 has only 2 vertices", 6, -1, 0, 0, 0,
	 0, NULL},
	{"broken/wrongHeader.bin.stl", 0, "header starts with \"solid\"", 0, -1, 12, 8, 1e6, 1,
	 "solid"},
	{"broken/wrongNormal.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"broken/wrongNormals.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"misc/cube.ascii.stl", 0, "", 0, -1, 12, 8, 8, 1, "cube"},
	{"misc/cube.bin.stl", 0, "", 0, -1, 12, 8, 8, 1, "cube"},
	{"misc/cubeLarge.ascii.stl", 0, "", 0, -1, 12, 8, 1e6, 1, "unit cube"},
	{"misc/faceless.ascii.stl", ERR_GEOMETRY, "contains no triangles", 0, -1, 0, 0, 0, 0, NULL},
	{"misc/multiWordName.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1,
	 "Model with a multi word name"},
	{"misc/multiWordName.bin.stl", ERR_PARSE, "49 bytes after its 4 declared triangles", 0, 284,
	 0, 0, 0, 0, NULL},
	{"misc/namelessSolid.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, ""},
	{"misc/tetrahedron.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"misc/tetrahedron.bin.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"misc/tetrahedron.min.ascii.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"misc/tetrahedronIrregular.ascii.stl", 0, "differs from solid name", 0, -1, 4, 4, 1, 1,
	 "tetrahedron irregular"},
	{"misc/tetrahedronIrregular.bin.stl", 0, "", 0, -1, 4, 4, 1, 1, "tetrahedron irregular"},
	{"misc/tetrahedronMinusZero.bin.stl", 0, "", 0, -1, 4, 4, 1.0 / 6, 1, "tetrahedron"},
	{"misc/triangle.ascii.stl", 0, "", 0, -1, 1, 3, 0, 0, "triangle"},
	{"misc/triangle.bin.stl", 0, "", 0, -1, 1, 3, 0, 0, "triangle"},
	{"misc/unitCube.ascii.stl", 0, "", 0, -1, 12, 8, 1, 1, "unit cube"},
	{"misc/unitCube.binary.stl", 0, "", 0, -1, 12, 8, 1, 1, "unit cube"},
};

static void run_row(const struct case_row *c)
{
	char rel[256];
	struct mesh *m = NULL;
	struct mesh_read_info info;
	struct mesh_report r;
	struct err e;
	int rc;

	snprintf(rel, sizeof rel, "meshes/%s", c->file);
	err_clear(&e);
	memset(&info, 0, sizeof info);
	rc = mesh_read_file(shared_path(rel), MESH_FMT_AUTO, &m, &info, &e);
	if (rc != c->code)
		fprintf(stderr, "%s: rc %d (%s), expected %d\n", c->file, rc, e.msg, c->code);
	CHECK_EQ_INT(rc, c->code);
	if (c->code != 0) {
		CHECK(m == NULL);
		CHECK_CONTAINS(e.msg, c->text);
		if (c->line)
			CHECK_EQ_INT(e.line, c->line);
		if (c->offset >= 0)
			CHECK_EQ_INT(e.offset, c->offset);
		return;
	}
	if (!m)
		return;
	CHECK_EQ_INT(m->nt, c->triangles);
	if (c->text[0]) {
		CHECK_INT(info.warnings, >=, 1);
		CHECK_CONTAINS(info.first_warning, c->text);
	} else {
		CHECK_EQ_INT(info.warnings, 0);
	}
	if (c->name)
		CHECK_STR(info.name, c->name);
	REQUIRE_OK(mesh_repair(m, &r, &e), &e);
	CHECK_EQ_INT(r.vertices, c->vertices);
	if (!isnan(c->volume))
		CHECK_NEAR(r.volume_mm3, c->volume, 1e-12 * (1 + c->volume));
	CHECK_EQ_INT(r.watertight, c->watertight);
	mesh_free(m);
}

static void test_all_rows(void)
{
	size_t i;

	for (i = 0; i < sizeof rows / sizeof rows[0]; i++)
		run_row(&rows[i]);
}

int main(void)
{
	RUN(test_all_rows);
	return harness_report();
}
