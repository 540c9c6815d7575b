/* cli_verify.c - `infilld verify ARCHIVE [--alpha-deg A] [--layer-mm H]
 * [--pixel-mm P] [--tolerance-px T] [--solid SOLID_ARCHIVE] [--strict |
 * --strict-all] [--threads N]`: check a written
 * SL1/SL1S/zip layer stack for interior overhangs, floating islands and
 * wall thickness (engine/verify/, docs/verify.md) and print the report as
 * JSON.  Works on any producer's archive; it knows nothing of the engine
 * that made it.  --solid names the solid engine's archive of the same part
 * and printer: islands the part itself does not have are reported as
 * islands_added.  `printable` asks what the interior adds: no interior
 * overhang and no island over an enclosed void (islands_interior; with
 * --solid, islands_added); the part's own islands (islands_part) need
 * external supports whatever fills it and are reported apart
 * (`part_needs_supports`).  --threads: threads for the distance
 * transforms (more than 8 act as 8) and the overhang readings (1 by
 * default, 1..64 accepted; the report does not depend on it).  Exit 0 when checked (--strict: 3 when not
 * printable; --strict-all: 3 also when the part needs supports), 1 on
 * errors, 2 on usage errors. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_json.h"
#include "engine/engine.h"
#include "engine/verify/verify.h"
#include "service/commands.h"

static int number_arg(const char *opt, const char *s, double lo, double hi, double *out)
{
	char *end;
	double v;

	errno = 0;
	v = strtod(s, &end);
	if (*end || errno || !isfinite(v) || v <= lo || v >= hi) {
		fprintf(stderr, "infilld verify: %s wants a number in (%g, %g), not '%s'\n", opt, lo,
			hi, s);
		return 2;
	}
	*out = v;
	return 0;
}

int cmd_verify(int argc, char **argv)
{
	struct verify_params vp;
	struct verify_report rep;
	struct metrics m;
	struct err e;
	const char *path = NULL, *solid = NULL;
	int strict = 0, rc, bad, part;
	json_t *j;

	memset(&vp, 0, sizeof vp);
	vp.alpha_deg = 45;
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i];
		double *slot = NULL, lo = 0, hi = 1e6;

		if (!strcmp(a, "--strict")) {
			strict = 1;
			continue;
		} else if (!strcmp(a, "--strict-all")) {
			strict = 2;
			continue;
		} else if (!strcmp(a, "--solid")) {
			if (++i >= argc) {
				fprintf(stderr, "infilld verify: %s needs a value\n", a);
				return 2;
			}
			solid = argv[i];
			continue;
		} else if (!strcmp(a, "--alpha-deg")) {
			slot = &vp.alpha_deg;
			hi = 90;
		} else if (!strcmp(a, "--layer-mm")) {
			slot = &vp.layer_mm;
			hi = 10;
		} else if (!strcmp(a, "--pixel-mm")) {
			slot = &vp.pixel_x_mm;
			hi = 10;
		} else if (!strcmp(a, "--tolerance-px")) {
			slot = &vp.tolerance_px;
			hi = 10;
		} else if (!strcmp(a, "--threads")) {
			if (++i >= argc) {
				fprintf(stderr, "infilld verify: %s needs a value\n", a);
				return 2;
			}
			if (!(vp.threads = cmd_threads_arg(argv[i], 64))) {
				fprintf(stderr,
					"infilld verify: --threads wants a whole number 1..64, not '%s'\n",
					argv[i]);
				return 2;
			}
			continue;
		} else if (a[0] == '-') {
			fprintf(stderr, "infilld verify: unknown option '%s'\n", a);
			return 2;
		} else if (!path) {
			path = a;
			continue;
		} else {
			fprintf(stderr, "infilld verify: unexpected argument '%s'\n", a);
			return 2;
		}
		if (++i >= argc) {
			fprintf(stderr, "infilld verify: %s needs a value\n", a);
			return 2;
		}
		if (number_arg(a, argv[i], lo, hi, slot))
			return 2;
	}
	if (!path) {
		fprintf(stderr, "infilld verify: missing the ARCHIVE (.sl1, .sl1s or .zip)\n");
		return 2;
	}
	vp.pixel_y_mm = vp.pixel_x_mm;
	err_clear(&e);
	memset(&rep, 0, sizeof rep);
	rc = verify_archive_ref(path, solid, &vp, &rep, &e);
	if (rc) {
		char line[ERR_MSG_MAX + 256];
		fprintf(stderr, "infilld: %s\n", err_format(&e, line, sizeof line));
		return 1;
	}
	/* the part's own islands (first contacts it needs supports for
	 * anyway) do not make the interior unprintable: islands over enclosed
	 * voids do (with the solid part to compare with: islands it lacks) */
	bad = rep.interior_overhang_px > 0 ||
	      (solid ? rep.islands_added > 0 : rep.islands_interior > 0);
	part = rep.islands > rep.islands_interior;
	metrics_init(&m);
	rc = verify_report_metrics(&rep, "verify", &m, &e);
	if (!rc)
		rc = metrics_bool(&m, "verify.printable", !bad);
	if (!rc)
		rc = metrics_bool(&m, "verify.part_needs_supports", part);
	j = rc ? NULL : api_metrics_json(&m);
	if (j) {
		json_dumpf(json_object_get(j, "verify"), stdout,
			   JSON_INDENT(2) | JSON_REAL_PRECISION(10));
		fputc('\n', stdout);
		json_decref(j);
	} else {
		fprintf(stderr, "infilld: out of memory reporting\n");
		rc = 1;
	}
	metrics_fini(&m);
	if (!rc && strict && (bad || (strict == 2 && part)))
		rc = 3;
	verify_report_fini(&rep);
	return rc;
}
