/* slopes.c - the optimised voids' slopes checked on their polygons
 * (slopes.h).
 */
#include "engine/hollow/slopes.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/geom/clip.h"
#include "engine/geom/path.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

/* Round joins within this of the true arc (nm; 1/500 of a 0.05 mm pixel):
 * the chords lie inside the arcs, so the check reads up to this band of
 * excess more than the exact rule (never less). */
#define ROUND_ARC_TOL_NM 100.0

int hl_slopes_check(const struct mesh *res, size_t part_nv, size_t part_nt, double layer_mm,
		    double reach_mm, struct hl_slopes *out, struct err *e)
{
	struct mesh part = {res->v, res->tri, part_nv, part_nt};
	struct slicer *sp = NULL, *sr = NULL;
	struct paths p, q, v, eroded, x;
	double zlo = INFINITY, zhi = -INFINITY, top = 0;
	int n, k0, k1, rc;

	memset(out, 0, sizeof *out);
	out->worst_layer = -1;
	for (size_t i = 0; i < res->nv; i++)
		top = fmax(top, res->v[i].z);
	for (size_t t = part_nt; t < res->nt; t++)
		for (int c = 0; c < 3; c++) {
			double z = res->v[res->tri[3 * t + c]].z;
			zlo = fmin(zlo, z);
			zhi = fmax(zhi, z);
		}
	n = layer_count_for(top, layer_mm);
	if (!(zhi > zlo) || n < 2)
		return 0; /* no optimised void */
	if (!(reach_mm > 0))
		return ERR_SET(e, ERR_PARAM, "hollow slopes check: reach %g mm", reach_mm);
	/* layers whose centre lies inside the voids' z range, and the one above */
	k0 = (int)floor(zlo / layer_mm - 0.5);
	k0 = k0 < 0 ? 0 : k0;
	k1 = (int)ceil(zhi / layer_mm - 0.5);
	k1 = k1 > n - 2 ? n - 2 : k1;

	paths_init(&p);
	paths_init(&q);
	paths_init(&v);
	paths_init(&eroded);
	paths_init(&x);
	if ((rc = slice_new(&part, &sp, e)) != 0 || (rc = slice_new(res, &sr, e)) != 0)
		goto out;
	/* q holds result(k) from one step to the next: slicers go upward only */
	rc = slice_at(sr, (k0 + 0.5) * layer_mm, &q, NULL, e);
	for (int k = k0; !rc && k <= k1; k++) {
		double a;
		if ((rc = slice_at(sp, (k + 0.5) * layer_mm, &p, NULL, e)) != 0 ||
		    (rc = clip_boolean(CLIP_DIFFERENCE, &p, &q, CLIP_FILL_NONZERO, &v, e)) != 0 ||
		    (rc = slice_at(sr, (k + 1.5) * layer_mm, &q, NULL, e)) != 0)
			break;
		if (v.n == 0)
			continue;
		out->layers_checked++;
		if ((rc = clip_offset(&v, -reach_mm * GEOM_NM_PER_MM, CLIP_JOIN_ROUND, 0,
				      ROUND_ARC_TOL_NM, &eroded, e)) != 0)
			break;
		if (eroded.n == 0)
			continue;
		if ((rc = clip_boolean(CLIP_INTERSECTION, &eroded, &q, CLIP_FILL_NONZERO, &x, e)) !=
		    0)
			break;
		a = paths_area_mm2(&x);
		if (!(a > HL_SLOPES_MIN_MM2))
			continue;
		out->excess_mm2 += a;
		out->layers_over++;
		if (a > out->worst_mm2) {
			out->worst_mm2 = a;
			out->worst_layer = k + 1;
		}
	}
out:
	slice_free(sp);
	slice_free(sr);
	paths_fini(&p);
	paths_fini(&q);
	paths_fini(&v);
	paths_fini(&eroded);
	paths_fini(&x);
	return rc;
}
