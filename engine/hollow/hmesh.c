/* hmesh.c - the hollow engine's mesh output (hmesh.h): the part's surface
 * and the stepped surfaces of the void pixels of every print layer, built
 * by engine/mesh/layers.c.  Design and figures: docs/hollow.md "Mesh
 * output".
 */
#include "engine/hollow/hmesh.h"
#include "engine/hollow/repair.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"
#include "engine/mesh/layers.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"
#include "engine/verify/verify.h"

/* Most triangles the void surfaces may have (2 per pixel side). */
#define HL_MESH_MAX_TRIANGLES 40000000u

struct hm_src {
	const struct hl_fill *fill, *frag;
	const struct hl_repair *mend; /* NULL: none */
	const struct hl_fill *grid;   /* the grid the masks are drawn on */
	double layer_mm;
	struct slicer *part, *res;    /* NULL without optimised voids */
	struct raster *rp, *rr;       /* grid-sized images of both */
	struct raster_map gmap;       /* printer mm -> grid pixels */
	struct paths region;
};

/* Set (val 1) or clear (val 0) the pixels of runs drawn on grid f inside
 * the mask of grid g. */
static void paint_runs(const struct hl_fill *g, const struct hl_fill *f,
		       const struct hl_fill_layer *l, uint8_t *mask, uint8_t val)
{
	for (size_t i = 0; i < l->n; i++) {
		int y = f->v0 + l->run[i].y - g->v0;
		int a = f->u0 + l->run[i].x0 - g->u0, b = f->u0 + l->run[i].x1 - g->u0;
		if (y < 0 || y >= g->h)
			continue;
		a = a < 0 ? 0 : a;
		b = b >= g->w ? g->w - 1 : b;
		if (a <= b)
			memset(mask + (size_t)y * (size_t)g->w + (size_t)a, val, (size_t)(b - a + 1));
	}
}

static int hm_layer(void *ctx, int k, uint8_t *mask, struct err *e)
{
	struct hm_src *s = ctx;
	const struct hl_fill *g = s->grid;
	double z = (k + 0.5) * s->layer_mm;
	const struct hl_fill_layer *l;
	int rc;

	memset(mask, 0, (size_t)g->w * (size_t)g->h);
	if (s->part) {
		/* the optimised voids: pixel centres inside the part, not in res
		 * (the layer output reads them at the verifier's threshold) */
		raster_clear(s->rp);
		raster_clear(s->rr);
		if ((rc = slice_at(s->part, z, &s->region, NULL, e)) != 0 ||
		    (rc = slice_rasterize(&s->region, &s->gmap, 0, s->rp, e)) != 0 ||
		    (rc = slice_at(s->res, z, &s->region, NULL, e)) != 0 ||
		    (rc = slice_rasterize(&s->region, &s->gmap, 0, s->rr, e)) != 0)
			return rc;
		for (int y = 0; y < g->h; y++) {
			const uint8_t *a = s->rp->px + (size_t)y * s->rp->stride;
			const uint8_t *b = s->rr->px + (size_t)y * s->rr->stride;
			uint8_t *m = mask + (size_t)y * (size_t)g->w;
			for (int x = 0; x < g->w; x++)
				if (a[x] >= VERIFY_THRESHOLD && b[x] < VERIFY_THRESHOLD)
					m[x] = 1;
		}
	}
	/* in hl_layer_draw's order: beads solid, fill void, then the mended
	 * pixels (raised solid or carved void) */
	if (s->frag && (l = hl_fill_at(s->frag, z)) != NULL)
		paint_runs(g, s->frag, l, mask, 0);
	if ((l = hl_fill_at(s->fill, z)) != NULL)
		paint_runs(g, s->fill, l, mask, 1);
	if (s->mend && s->mend->layer && k < s->mend->n) {
		for (size_t i = 0; i < s->mend->layer[k].n; i++) {
			const struct hl_mend *q = &s->mend->layer[k].px[i];
			int x = q->x - g->u0, y = q->y - g->v0;
			if (x >= 0 && y >= 0 && x < g->w && y < g->h)
				mask[(size_t)y * (size_t)g->w + (size_t)x] = q->g < VERIFY_THRESHOLD;
		}
	}
	return 0;
}

int hl_mesh_build(const struct mesh *res, size_t part_nv, size_t part_nt,
		  const struct hl_fill *fill, const struct hl_fill *frag,
		  const struct hl_repair *mend, const struct raster_map *map, double layer_mm,
		  struct mesh **out, size_t *void_triangles, struct err *e)
{
	struct mesh part = {res->v, res->tri, part_nv, part_nt};
	struct mesh *surf = NULL, *m = NULL;
	struct hl_fill own;
	struct hm_src s;
	struct mesh_layers_grid g;
	struct mesh_layers_src src = {hm_layer, &s};
	struct box3 bb = box3_empty();
	const struct raster_map *fm;
	double det, px, py;
	int rc = 0, voids = res->nt > part_nt;

	memset(&s, 0, sizeof s);
	memset(&own, 0, sizeof own);
	paths_init(&s.region);
	s.fill = fill;
	s.frag = frag && frag->voids ? frag : NULL;
	s.mend = mend && mend->pixels > 0 ? mend : NULL;
	s.layer_mm = layer_mm;
	/* the grid: the fill's, or one over the part on map */
	if (fill->w > 0 && fill->h > 0) {
		s.grid = fill;
	} else {
		own.map = *map;
		rc = hl_fill_grid(part.v, part.nv, map, &own, &px, &py, e);
		if (rc)
			goto out;
		s.grid = &own;
	}
	fm = &s.grid->map;
	for (size_t i = 0; i < part.nv; i++)
		box3_add(&bb, part.v[i]);
	if (voids || fill->voids || s.frag) {
		if (voids) {
			s.gmap = *fm;
			s.gmap.b[0] -= s.grid->u0;
			s.gmap.b[1] -= s.grid->v0;
			if ((rc = slice_new(&part, &s.part, e)) != 0 ||
			    (rc = slice_new(res, &s.res, e)) != 0)
				goto out;
			s.rp = raster_new(s.grid->w, s.grid->h);
			s.rr = raster_new(s.grid->w, s.grid->h);
			if (!s.rp || !s.rr) {
				rc = ERR_SET(e, ERR_NOMEM, "hollow mesh: out of memory");
				goto out;
			}
		}
		/* lattice point (I, J) is image corner (u0 + I, v0 + J) */
		det = fm->a[0][0] * fm->a[1][1] - fm->a[0][1] * fm->a[1][0];
		memset(&g, 0, sizeof g);
		g.nx = s.grid->w;
		g.ny = s.grid->h;
		g.nz = layer_count_for(bb.hi.z, layer_mm);
		g.m[0][0] = fm->a[1][1] / det;
		g.m[0][1] = -fm->a[0][1] / det;
		g.m[1][0] = -fm->a[1][0] / det;
		g.m[1][1] = fm->a[0][0] / det;
		{
			double du = s.grid->u0 - fm->b[0], dv = s.grid->v0 - fm->b[1];
			g.o[0] = g.m[0][0] * du + g.m[0][1] * dv;
			g.o[1] = g.m[1][0] * du + g.m[1][1] * dv;
		}
		g.layer_mm = layer_mm;
		if (g.nz < 1) {
			rc = ERR_SET(e, ERR_GEOMETRY, "hollow mesh: the part has no layers");
			goto out;
		}
		rc = mesh_layers_surface(&g, &src, HL_MESH_MAX_TRIANGLES, &surf, e);
		if (rc)
			goto out;
	}
	m = mesh_new();
	if (!m || mesh_reserve(m, part.nv + (surf ? surf->nv : 0),
			       part.nt + (surf ? surf->nt : 0))) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow mesh: out of memory");
		goto out;
	}
	for (size_t i = 0; i < part.nv; i++)
		mesh_add_vertex(m, part.v[i]);
	for (size_t t = 0; t < part.nt; t++)
		mesh_add_triangle(m, part.tri[3 * t], part.tri[3 * t + 1], part.tri[3 * t + 2]);
	for (size_t i = 0; surf && i < surf->nv; i++)
		mesh_add_vertex(m, surf->v[i]);
	/* the voids' surfaces face into the voids: turned */
	for (size_t t = 0; surf && t < surf->nt; t++)
		mesh_add_triangle(m, (uint32_t)part.nv + surf->tri[3 * t],
				  (uint32_t)part.nv + surf->tri[3 * t + 2],
				  (uint32_t)part.nv + surf->tri[3 * t + 1]);
	*void_triangles = surf ? surf->nt : 0;
	*out = m;
	m = NULL;
out:
	mesh_free(m);
	mesh_free(surf);
	raster_free(s.rp);
	raster_free(s.rr);
	slice_free(s.part);
	slice_free(s.res);
	paths_fini(&s.region);
	return rc;
}
