/* test_loads.c - the JSON load case -> the FEA engine's text form
 * (api_loads_text): the documented defaults, presets and boxes in the
 * text, and every malformed case refused with the JSON path of the
 * offending value in e.field. */
#include "harness.h"

#include "api/api_json.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

/* Convert JSON text; returns the code, *text owned by the caller. */
static int conv(const char *json, char **text, struct err *e)
{
	json_error_t je;
	json_t *j = json_loads(json, 0, &je);
	int rc;

	err_clear(e);
	*text = NULL;
	if (!j) {
		fprintf(stderr, "bad test JSON %s: %s\n", json, je.text);
		return -100;
	}
	rc = api_loads_text(j, text, e);
	json_decref(j);
	return rc;
}

static void expect_text(const char *json, const char *want)
{
	char *t;
	struct err e;

	CHECK_EQ_INT(conv(json, &t, &e), 0);
	if (t)
		CHECK_STR(t, want);
	else
		fprintf(stderr, "  %s: %s\n", json, e.msg);
	mem_free(t);
}

static void expect_error(const char *json, const char *field, const char *needle)
{
	char *t;
	struct err e;

	CHECK_EQ_INT(conv(json, &t, &e), ERR_PARAM);
	CHECK(t == NULL);
	CHECK_STR(e.field, field);
	CHECK_CONTAINS(e.msg, needle);
	CHECK(strchr(e.msg, '\n') == NULL);
	mem_free(t);
}

static void test_forms(void)
{
	expect_text("{}", "");
	expect_text("{\"material\": {\"E_mpa\": 3500, \"nu\": 0.36}}",
		    "material E_mpa=3500 nu=0.36; fixed plate axes=xyz; "
		    "force top n=0,0,-1000");
	expect_text("{\"forces\": [{\"preset\": \"top\", \"force_n\": [0, 0, -10]}]}",
		    "fixed plate axes=xyz; force top n=0,0,-10");
	expect_text("{\"fixed\": [\"top\"]}", "fixed top axes=xyz; force top n=0,0,-1000");
	expect_text("{\"fixed\": [{\"box_mm\": [0, 0, 0, 1, 4, 4], \"axes\": \"zx\"}, "
		    "{\"preset\": \"plate\", \"axes\": \"y\"}],"
		    " \"forces\": [{\"box_mm\": [39, 0, 0, 40, 4, 4], \"force_n\": [0, 0, -2.5]}]}",
		    "fixed box=0,0,0,1,4,4 axes=zx; fixed plate axes=y; "
		    "force box=39,0,0,40,4,4 n=0,0,-2.5");
}

static void test_errors(void)
{
	expect_error("[]", "loads", "load-case object");
	expect_error("{\"force\": []}", "loads.force", "unknown key 'force'");
	expect_error("{\"material\": {\"E_mpa\": 3500}}", "loads.material.nu", "Poisson");
	expect_error("{\"material\": {\"E_mpa\": -1, \"nu\": 0.3}}", "loads.material.E_mpa",
		     "0 < E_mpa");
	expect_error("{\"material\": {\"E_mpa\": 1, \"nu\": 0.3, \"rho\": 1}}",
		     "loads.material.rho", "unknown key");
	expect_error("{\"fixed\": \"plate\"}", "loads.fixed", "expected an array");
	expect_error("{\"fixed\": [\"floor\"]}", "loads.fixed[0]", "preset");
	expect_error("{\"fixed\": [{\"box_mm\": [0, 0, 0, 1, 1]}]}", "loads.fixed[0].box_mm",
		     "expected 6 numbers");
	expect_error("{\"fixed\": [{\"box_mm\": [2, 0, 0, 1, 1, 1]}]}", "loads.fixed[0].box_mm",
		     "min x 2 is above max x 1");
	expect_error("{\"fixed\": [{\"box_mm\": [0, 0, 0, 1, 1, 1], \"axes\": \"xx\"}]}",
		     "loads.fixed[0].axes", "at most once");
	expect_error("{\"fixed\": [{\"box_mm\": [0, 0, 0, 1, 1, 1], \"axes\": \"w\"}]}",
		     "loads.fixed[0].axes", "x, y, z");
	expect_error("{\"fixed\": [{\"axes\": \"z\"}]}", "loads.fixed[0]", "box_mm");
	expect_error("{\"fixed\": [{\"preset\": \"top\", \"box_mm\": [0, 0, 0, 1, 1, 1]}]}",
		     "loads.fixed[0]", "not both");
	expect_error("{\"forces\": [{\"preset\": \"top\", \"force_n\": [0, 0, -1]},"
		     " {\"preset\": \"top\", \"force_n\": [1, 2]}]}",
		     "loads.forces[1].force_n", "expected 3 numbers");
	expect_error("{\"forces\": [{\"preset\": \"top\", \"force_n\": [0, \"a\", 1]}]}",
		     "loads.forces[0].force_n", "not a number");
	expect_error("{\"forces\": [{\"preset\": \"top\"}]}", "loads.forces[0].force_n",
		     "required");
	expect_error("{\"forces\": [{\"preset\": \"top\", \"force_n\": [0, 0, 0]}]}",
		     "loads.forces[0].force_n", "zero");
	expect_error("{\"forces\": [\"top\"]}", "loads.forces[0]", "expected an object");
	expect_error("{\"forces\": [{\"preset\": \"side\", \"force_n\": [0, 0, 1]}]}",
		     "loads.forces[0].preset", "\"plate\" or \"top\"");
	expect_error("{\"forces\": [{\"preset\": \"top\", \"force_n\": [0, 0, 1], \"at\": 1}]}",
		     "loads.forces[0].at", "unknown key");
}

static void test_limits(void)
{
	char json[8192], *t;
	size_t n = 0;
	struct err e;

	n += (size_t)snprintf(json + n, sizeof json - n, "{\"fixed\": [");
	for (int i = 0; i < 65; i++)
		n += (size_t)snprintf(json + n, sizeof json - n, "%s\"plate\"", i ? ", " : "");
	snprintf(json + n, sizeof json - n, "]}");
	CHECK_EQ_INT(conv(json, &t, &e), ERR_PARAM);
	CHECK_STR(e.field, "loads.fixed");
	CHECK_CONTAINS(e.msg, "at most 64");
	mem_free(t);
}

int main(void)
{
	RUN(test_forms);
	RUN(test_errors);
	RUN(test_limits);
	return harness_report();
}
