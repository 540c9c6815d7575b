/* fragments.c - pieces the print layers split off the optimised voids
 * (docs/hollow.md "Fragments").
 *
 * An optimised void is one closed surface, but where it is thinner than a
 * pixel (the ridge under a ceiling that eq. 6 collapsed, the tip of a
 * spur of a loop) its rasterised layers can break into beads: small 3D
 * void components a pixel or two from the rest of the void.  Printed,
 * such a bead is a separate cavity behind a wall of a pixel or two: thin
 * walls between cavities that the design never had (measured on the
 * camel: 25 voxels, 0.10 mm from its void).  The paper drops voids under
 * min_void_mm3; the same rule applied to what is printed drops the beads.
 *
 * So: every print layer that cuts a void is rasterised exactly as the
 * layer pass does (same map, same antialiasing, the verifier's threshold),
 * the pixels that are void there and covered by a void surface's region
 * are grouped into 3D components with the verifier's connectivity, and
 * the components under min_void_mm3 are kept, to be painted solid.
 *
 * Painting a whole 3D component solid never makes an interior overhang:
 * a pixel above a painted one is solid (no overhang: there is solid
 * under it now) or void, and then it is in the same component (linked
 * vertically) and painted too.  Walls only grow.
 */

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/hollow/fill/fill_int.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

int hl_fragments_find(const struct mesh *out, size_t void_v0, size_t void_t0,
		      const struct raster_map *map, int antialias, int threshold, double layer_mm,
		      double min_mm3, struct hl_fill *f, struct err *e)
{
	struct mesh vm;
	struct slicer *so = NULL, *sv = NULL;
	struct raster *ro = NULL, *rv = NULL;
	struct raster_map gm;
	struct paths reg;
	uint8_t *mask = NULL;
	double px, py, zlo = INFINITY, zhi = -INFINITY;
	int rc, k0, k1;

	hl_fill_fini(f);
	if (void_t0 >= out->nt || void_v0 >= out->nv || !(layer_mm > 0))
		return 0;
	for (size_t i = void_v0; i < out->nv; i++) {
		zlo = fmin(zlo, out->v[i].z);
		zhi = fmax(zhi, out->v[i].z);
	}
	rc = hl_fill_grid(out->v + void_v0, out->nv - void_v0, map, f, &px, &py, e);
	if (rc)
		return rc;
	/* print layer k has its mid-plane at (k + 1/2) layer_mm (layer.h) */
	k0 = (int)fmax(0, floor(zlo / layer_mm - 0.5));
	k1 = (int)ceil(zhi / layer_mm - 0.5);
	f->n = k1 + 1;
	f->layer_mm = layer_mm;
	f->map = *map;
	gm = *map;
	gm.b[0] -= f->u0;
	gm.b[1] -= f->v0;
	/* the void surfaces alone (their normals point into the voids: the
	 * nonzero rule fills them all the same) */
	vm.v = out->v;
	vm.nv = out->nv;
	vm.tri = out->tri + 3 * void_t0;
	vm.nt = out->nt - void_t0;
	paths_init(&reg);
	f->layer = mem_calloc((size_t)f->n, sizeof *f->layer);
	ro = raster_new(f->w, f->h);
	rv = raster_new(f->w, f->h);
	mask = mem_alloc((size_t)f->w * (size_t)f->h);
	if (!f->layer || !ro || !rv || !mask) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fragments)");
		goto out;
	}
	rc = slice_new(out, &so, e);
	if (!rc)
		rc = slice_new(&vm, &sv, e);
	for (int k = k0; !rc && k <= k1; k++) {
		double z = ((double)k + 0.5) * layer_mm;
		size_t cap = 0;
		raster_clear(ro);
		raster_clear(rv);
		rc = slice_at(so, z, &reg, NULL, e);
		if (!rc)
			rc = slice_rasterize(&reg, &gm, antialias, ro, e);
		if (!rc)
			rc = slice_at(sv, z, &reg, NULL, e);
		/* any coverage by a void's region marks a void pixel as one of
		 * the optimised voids' (the outside is >= wall_mm away) */
		if (!rc)
			rc = slice_rasterize(&reg, &gm, 1, rv, e);
		if (rc)
			break;
		for (int y = 0; y < f->h; y++) {
			const uint8_t *a = ro->px + (size_t)y * ro->stride, *b = rv->px + (size_t)y * rv->stride;
			uint8_t *m = mask + (size_t)y * (size_t)f->w;
			for (int x = 0; x < f->w; x++)
				m[x] = a[x] < threshold && b[x] > 0;
		}
		rc = hl_grid_runs(mask, f->w, 0, 0, f->w, f->h, &f->layer[k].run, &f->layer[k].n, &cap,
				  e);
	}
	if (!rc)
		rc = hl_fill_components(f, min_mm3, px * py, 1, e);
out:
	if (rc)
		hl_fill_fini(f);
	slice_free(so);
	slice_free(sv);
	raster_free(ro);
	raster_free(rv);
	mem_free(mask);
	paths_fini(&reg);
	return rc;
}
