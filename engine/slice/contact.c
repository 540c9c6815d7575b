/* contact.c - where a part touches the build plate: the convex hull of
 * its first layer's section, for the engines that make parts stand
 * (hollow and rhombic, objective=stability). */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/hull.h"
#include "engine/slice/slice.h"

int slice_contact_hull(const struct mesh *part, double layer_mm, struct hull_pt **h, size_t *n,
		       struct err *e)
{
	struct slicer *s = NULL;
	struct paths reg;
	struct pt2 *pts = NULL;
	size_t np, k = 0;
	int rc;

	*h = NULL;
	*n = 0;
	paths_init(&reg);
	rc = slice_new(part, &s, e);
	if (!rc)
		rc = slice_at(s, 0.5 * layer_mm, &reg, NULL, e);
	if (rc)
		goto out;
	np = paths_point_count(&reg);
	pts = mem_alloc((np ? np : 1) * sizeof *pts);
	if (!pts) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for the contact hull");
		goto out;
	}
	for (size_t i = 0; i < reg.n; i++)
		for (size_t j = 0; j < reg.v[i].n; j++)
			pts[k++] = reg.v[i].pts[j];
	rc = hull_convex(pts, k, h, n, e);
	if (!rc && *n < 3) {
		mem_free(*h);
		*h = NULL;
		*n = 0;
	}
out:
	slice_free(s);
	paths_fini(&reg);
	mem_free(pts);
	return rc;
}
