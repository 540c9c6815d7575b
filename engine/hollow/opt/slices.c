/* slices.c - adaptive optimisation slices (paper 004, section 3 step 2:
 * "a uniform thickness or a curvature-dependent adaptive thickness",
 * ref. [30]; docs/hollow.md "Adaptive slices").
 *
 * The strips join consecutive slices by straight cross edges, so between
 * two slices the void's surface is ruled.  Where the offset surface bends
 * in z (curvature in a vertical plane) the layers in between bulge away
 * from that ruled surface by the sagitta, about h^2 kappa / 8; where it
 * is straight in z (a wall, a cone) any thickness follows it.  A slab
 * [lo, hi] is therefore measured by the layers between its ends: a layer
 * region M of a ruled (z-monotone) surface lies between the ends' union
 * and intersection, lo n hi <= M <= lo u hi, so
 *
 *   dev(lo, M, hi) = (area(M \ (lo u hi)) + area((lo n hi) \ M)) / perimeter(M)
 *
 * is the mean distance by which M leaves that band (mm): 0 on straight
 * walls, the sagitta on a bend of constant curvature.  Slices are chosen
 * bottom-up, greedily: from the current slice the next is the farthest
 * candidate, at most tmax candidates up, for which every candidate layer
 * in between has dev <= dev_mm (all t <= tmax are tried: a slab can fail
 * where a thicker one passes); the next candidate is always allowed.
 */
#include <math.h>

#include "engine/core/err.h"
#include "engine/geom/clip.h"
#include "engine/hollow/opt/opt_int.h"

static double perimeter_mm(const struct paths *r)
{
	double s = 0;

	for (size_t i = 0; i < r->n; i++)
		s += path_length_mm(&r->v[i], 1);
	return s;
}

/* The band between a slab's ends: their union u and intersection in. */
static int band(const struct paths *lo, const struct paths *hi, struct paths *u, struct paths *in,
		struct err *e)
{
	int rc = clip_boolean(CLIP_UNION, lo, hi, CLIP_FILL_NONZERO, u, e);

	return rc ? rc : clip_boolean(CLIP_INTERSECTION, lo, hi, CLIP_FILL_NONZERO, in, e);
}

/* dev of mid against the band (u, in) of the ends lo, hi; d is scratch. */
static int band_deviation(const struct paths *lo, const struct paths *mid, const struct paths *hi,
			  const struct paths *u, const struct paths *in, struct paths *d,
			  double *dev_mm, struct err *e)
{
	double out_mm2 = 0, L = perimeter_mm(mid);
	int rc;

	*dev_mm = 0;
	rc = clip_boolean(CLIP_DIFFERENCE, mid, u, CLIP_FILL_NONZERO, d, e);
	if (rc)
		return rc;
	out_mm2 += paths_area_mm2(d);
	rc = clip_boolean(CLIP_DIFFERENCE, in, mid, CLIP_FILL_NONZERO, d, e);
	if (rc)
		return rc;
	out_mm2 += paths_area_mm2(d);
	/* an empty middle between non-empty ends (a neck closing and
	 * reopening) has no perimeter of its own: use the ends' */
	if (!(L > 0))
		L = fmax(perimeter_mm(lo), perimeter_mm(hi));
	*dev_mm = out_mm2 > 0 ? (L > 0 ? out_mm2 / L : INFINITY) : 0;
	return 0;
}

int hl_slab_deviation_mm(const struct paths *lo, const struct paths *mid, const struct paths *hi,
			 double *dev_mm, struct err *e)
{
	struct paths u, in, d;
	int rc;

	paths_init(&u);
	paths_init(&in);
	paths_init(&d);
	*dev_mm = 0;
	rc = band(lo, hi, &u, &in, e);
	if (!rc)
		rc = band_deviation(lo, mid, hi, &u, &in, &d, dev_mm, e);
	paths_fini(&u);
	paths_fini(&in);
	paths_fini(&d);
	return rc;
}

int hl_slices_adaptive(const struct paths *reg, size_t nc, size_t tmax, double dev_mm,
		       size_t *pick, size_t *npick, struct err *e)
{
	struct paths u, in, d;
	size_t a = 0, n = 0;
	int rc = 0;

	*npick = 0;
	if (nc == 0)
		return 0;
	if (tmax < 1)
		tmax = 1;
	paths_init(&u);
	paths_init(&in);
	paths_init(&d);
	pick[n++] = 0;
	while (a + 1 < nc) {
		size_t best = 1;
		for (size_t t = 2; t <= tmax && a + t < nc; t++) {
			int ok = 1;
			/* the band of this slab's ends, once for all its layers */
			if ((rc = band(&reg[a], &reg[a + t], &u, &in, e)) != 0)
				goto out;
			for (size_t c = a + 1; c < a + t && ok; c++) {
				double dv;
				rc = band_deviation(&reg[a], &reg[c], &reg[a + t], &u, &in, &d, &dv, e);
				if (rc)
					goto out;
				ok = dv <= dev_mm;
			}
			if (ok)
				best = t;
		}
		a += best;
		pick[n++] = a;
	}
	*npick = n;
out:
	paths_fini(&u);
	paths_fini(&in);
	paths_fini(&d);
	return rc;
}
