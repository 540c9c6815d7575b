/* fuzz_mesh.h - the body shared by the mesh fuzz targets.
 *
 * Reads the input with a fixed format; on success runs analysis (which
 * must not fail), a tolerance weld and a placement on a copy, repair and
 * BVH closest/inside/ray queries, so every stage sees hostile-but-accepted
 * geometry.  Any crash, sanitizer report,
 * leak or abort is a finding.
 */
#ifndef INFILLD_FUZZ_MESH_H
#define INFILLD_FUZZ_MESH_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "engine/core/err.h"
#include "engine/mesh/mesh.h"

static inline int fuzz_mesh_one(const uint8_t *data, size_t size, enum mesh_format fmt)
{
	struct mesh *m = NULL;
	struct mesh_report r;
	struct mesh_bvh *b = NULL;
	struct err e;
	int rc;

	err_clear(&e);
	rc = mesh_read_buffer(data, size, fmt, NULL, &m, NULL, &e);
	if (rc != 0) {
		if (!(rc == ERR_PARSE || rc == ERR_GEOMETRY || rc == ERR_LIMIT ||
		      rc == ERR_UNSUPPORTED) || m != NULL || e.msg[0] == '\0')
			abort(); /* readers fail only with input errors, and say why */
		return 0;
	}
	if (m->nt == 0 || mesh_analyze(m, &r, &e) != 0)
		abort();
	{ /* tolerance weld and placement on a copy (errors allowed, crashes not) */
		struct mesh *c = mesh_clone(m);
		struct mesh_placement pl = {MESH_UNITS_MM, 1.0, 50.0, (int)(size % 6), 60, 30};
		if (!c)
			abort();
		(void)mesh_weld(c, 1e-3 * (1 + (double)(size % 7)), NULL, NULL, &e);
		(void)mesh_place(c, &pl, &e);
		mesh_free(c);
	}
	if (mesh_repair(m, &r, &e) != 0)
		abort();
	if (m->nt > 0 && mesh_bvh_new(m, &b, &e) == 0) {
		struct vec3 c = box3_center(r.bbox);
		(void)mesh_bvh_closest(b, c, NULL, NULL);
		(void)mesh_bvh_inside(b, c);
		(void)mesh_bvh_ray(b, c, v3(0, 0, 1), NULL);
		mesh_bvh_free(b);
	}
	mesh_free(m);
	return 0;
}

#endif
