/* stability.c - static stability by refinement (paper 001 section 5.2,
 * eq. 14-16; docs/rhombic.md section 6).
 *
 * Mass properties are analytic: the part's volume and centroid from its
 * closed mesh (divergence theorem) less every cavity's (a rhombic prism's
 * centroid is its centre).  Splitting a leaf adds the material between
 * its cavity and its children's, which is symmetric about the cell's
 * centre, so that mass enters at the cell's centre c_c.  No FEA.
 */
#include "engine/rhombic/optimize.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/hull.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Cell centre in the printer frame. */
static struct vec3 cell_center(const struct rh_frame *f, const struct rh_cell *c)
{
	struct rh_geom g;
	double x, y;

	rh_cell_geom(f, c, &g);
	rh_to_printer(f, g.cu, (g.vlo + g.vhi) / 2, &x, &y);
	return v3(x, y, g.cz);
}

void rh_tree_mass(const struct rh_tree *t, double part_vol, struct vec3 part_moment, double *vol,
		  struct vec3 *com)
{
	double V = part_vol;
	struct vec3 M = part_moment;

	for (size_t i = 0; i < t->n; i++)
		if (t->c[i].state == RH_CAVITY) {
			struct rh_cavity cv;
			rh_cell_cavity(&t->f, &t->c[i], &cv);
			V -= cv.volume_mm3;
			M = v3_madd(M, cell_center(&t->f, &t->c[i]), -cv.volume_mm3);
		}
	*vol = V;
	*com = V > 0 ? v3_scale(M, 1 / V) : v3(0, 0, 0);
}

struct stab_key {
	double d;
	int32_t idx;
};

static int cmp_key(const void *pa, const void *pb)
{
	const struct stab_key *a = pa, *b = pb;

	if (a->d != b->d)
		return a->d < b->d ? -1 : 1;
	return a->idx < b->idx ? -1 : a->idx > b->idx;
}

static struct hull_pt hull_centroid(const struct hull_pt *h, size_t n)
{
	double A = 0, cx = 0, cy = 0;
	struct hull_pt c = {0, 0};

	for (size_t i = 0; i < n; i++) {
		const struct hull_pt *p = &h[i], *q = &h[(i + 1) % n];
		double cr = p->x * q->y - q->x * p->y;
		A += cr;
		cx += (p->x + q->x) * cr;
		cy += (p->y + q->y) * cr;
	}
	if (A != 0) {
		c.x = cx / (3 * A);
		c.y = cy / (3 * A);
	}
	return c;
}

int rh_stability(struct rh_tree *t, const struct mesh *part, double layer_mm, double max_fraction,
		 struct rh_stab_report *r, struct err *e)
{
	struct hull_pt *hull = NULL, ch, q;
	struct stab_key *keys = NULL;
	size_t nhull = 0, capk = 0;
	double pv, mg;
	struct vec3 pm, cg;
	int rc;

	memset(r, 0, sizeof *r);
	mesh_mass(part, &pv, &pm);
	if (!(pv > 0))
		return ERR_SET(e, ERR_GEOMETRY, "rhombic: the part has no volume");
	r->com_solid = v3_scale(pm, 1 / pv);
	if ((rc = slice_contact_hull(part, layer_mm, &hull, &nhull, e)) != 0)
		goto out;
	if (nhull < 3) {
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "rhombic: no contact area on the first layer (z = %g mm): nothing to "
			     "stand on",
			     0.5 * layer_mm);
		goto out;
	}
	ch = hull_centroid(hull, nhull);
	r->hull_center = v3(ch.x, ch.y, 0);
	r->hull_points = nhull;
	q.x = r->com_solid.x;
	q.y = r->com_solid.y;
	r->solid_inside = hull_signed_distance_mm(hull, nhull, q) > 0;
	rh_tree_mass(t, pv, pm, &mg, &cg);
	r->com_initial = cg;
	for (;;) {
		size_t nk = 0, batch;
		q.x = cg.x;
		q.y = cg.y;
		if (hull_signed_distance_mm(hull, nhull, q) > 0) {
			r->inside = 1;
			break;
		}
		if (t->cavities == 0 || (max_fraction > 0 && mg / pv >= max_fraction))
			break;
		/* eq. 16 for every leaf, sorted ascending (delayed update: the
		 * order is kept for 2 % of the leaves) */
		if (mem_grow((void **)&keys, &capk, t->cavities, sizeof *keys)) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
			goto out;
		}
		for (size_t i = 0; i < t->n; i++)
			if (t->c[i].state == RH_CAVITY && nk < capk) {
				struct vec3 cc = cell_center(&t->f, &t->c[i]);
				double mc = rh_tree_refine_gain(t, (int32_t)i);
				keys[nk].d = 2 * mc / (mc + mg) *
					     ((cg.x - ch.x) * (cc.x - cg.x) + (cg.y - ch.y) * (cc.y - cg.y));
				keys[nk++].idx = (int32_t)i;
			}
		qsort(keys, nk, sizeof *keys, cmp_key);
		batch = (size_t)ceil(0.02 * (double)nk);
		batch = batch < 1 ? 1 : batch;
		r->updates++;
		for (size_t k = 0; k < batch && k < nk; k++) {
			struct vec3 cc = cell_center(&t->f, &t->c[keys[k].idx]);
			double add;
			if ((rc = rh_tree_refine(t, keys[k].idx, &add, e)) != 0)
				goto out;
			/* the added material's centroid is the cell's centre */
			cg = v3_scale(v3_madd(v3_scale(cg, mg), cc, add), 1 / (mg + add));
			mg += add;
			r->splits++;
			q.x = cg.x;
			q.y = cg.y;
			if (hull_signed_distance_mm(hull, nhull, q) > 0)
				break;
		}
	}
	r->com_after = cg;
	r->hull_distance_mm = hull_signed_distance_mm(hull, nhull, q);
out:
	mem_free(hull);
	mem_free(keys);
	return rc;
}
