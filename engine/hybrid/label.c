/* label.c - the volumetric partition (paper 003, section 4.1): a part
 * label for every point of the interior.  Voxels inside the mesh (the
 * fea voxeliser's solid fractions) take the part of their nearest facet;
 * a Col part's base plane then cuts it from its neighbour at query time.
 * docs/hybrid.md, "Partition".
 */
#include "engine/hybrid/hybrid.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/fea/fea.h"
#include "engine/mesh/mesh.h"

/* A voxel is inside when half of its mid-height section is (the centre
 * test, blurred by at most half a voxel at the wall). */
#define LABEL_INSIDE_FRACTION 0.5f

/* What hy_label_at needs of a part. */
struct cut {
	int cls, neighbour;
	struct vec3 axis, base_mm;
	double radius_mm, length_mm;
};

struct hy_labeler {
	int nx, ny, nz;
	double h_mm;
	struct vec3 lo_mm;  /* min corner of voxel (0, 0, 0) */
	int32_t *vox;       /* nx ny nz, x fastest: part of the nearest facet, -1 outside; owned */
	struct cut *cut;    /* ncut parts, owned */
	size_t ncut, cap;
};

struct label_ctx {
	struct hy_labeler *l;
	const float *rho;
	const struct mesh_bvh *b;
	const uint32_t *facet_part;
};

static void label_layer(void *vctx, size_t k, int tid)
{
	struct label_ctx *c = vctx;
	struct hy_labeler *l = c->l;
	size_t plane = (size_t)l->nx * (size_t)l->ny;

	(void)tid;
	for (size_t j = 0; j < (size_t)l->ny; j++)
		for (size_t i = 0; i < (size_t)l->nx; i++) {
			size_t v = k * plane + j * (size_t)l->nx + i, tri = 0;
			struct vec3 p;
			if (!(c->rho[v] >= LABEL_INSIDE_FRACTION)) {
				l->vox[v] = -1;
				continue;
			}
			p = v3(l->lo_mm.x + ((double)i + 0.5) * l->h_mm,
			       l->lo_mm.y + ((double)j + 0.5) * l->h_mm,
			       l->lo_mm.z + ((double)k + 0.5) * l->h_mm);
			(void)mesh_bvh_closest(c->b, p, NULL, &tri);
			l->vox[v] = (int32_t)c->facet_part[tri];
		}
}

static void read_cuts(struct hy_labeler *l, const struct hy_parts *ps)
{
	l->ncut = ps->n < l->cap ? ps->n : l->cap;
	for (size_t i = 0; i < l->ncut; i++) {
		const struct hy_part *p = &ps->p[i];
		struct cut *c = &l->cut[i];
		c->cls = p->cls;
		c->neighbour = p->neighbour;
		c->axis = p->axis;
		c->base_mm = p->base_mm;
		c->radius_mm = p->radius_mm;
		c->length_mm = p->length_mm;
	}
}

int hy_labeler_new(const struct mesh *m, const struct mesh_bvh *b, const struct hy_parts *ps,
		   double vox_mm, int threads, struct hy_labeler **out, struct err *e)
{
	struct fea_grid g;
	struct hy_labeler *l = NULL;
	struct label_ctx c;
	size_t nvox;
	int rc;

	if (!(vox_mm > 0) || !isfinite(vox_mm))
		return ERR_FIELD(e, "vox_mm", "label voxel must be a finite number > 0, not %g",
				 vox_mm);
	memset(&g, 0, sizeof g);
	if ((rc = fea_voxelize_mesh(m, vox_mm, 1, (size_t)HY_LABEL_MAX_VOXELS, threads, &g, e))) {
		if (e && rc == ERR_LIMIT)
			snprintf(e->field, sizeof e->field, "vox_mm");
		return rc;
	}
	nvox = (size_t)g.nx * (size_t)g.ny * (size_t)g.nz;
	l = mem_calloc(1, sizeof *l);
	if (l) {
		l->vox = mem_alloc(nvox * sizeof *l->vox);
		l->cut = mem_alloc((ps->n ? ps->n : 1) * sizeof *l->cut);
	}
	if (!l || !l->vox || !l->cut) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu label voxels", nvox);
		goto out;
	}
	l->nx = g.nx;
	l->ny = g.ny;
	l->nz = g.nz;
	l->h_mm = g.h_mm;
	l->lo_mm = g.lo_mm;
	l->cap = ps->n;
	read_cuts(l, ps);
	c.l = l;
	c.rho = g.rho;
	c.b = b;
	c.facet_part = ps->facet_part;
	parfor_run((size_t)l->nz, threads, 1, label_layer, &c);
	*out = l;
	l = NULL;
out:
	hy_labeler_free(l);
	fea_grid_fini(&g);
	return rc;
}

int hy_label_at(const struct hy_labeler *l, struct vec3 p)
{
	double fx = floor((p.x - l->lo_mm.x) / l->h_mm), fy = floor((p.y - l->lo_mm.y) / l->h_mm),
	       fz = floor((p.z - l->lo_mm.z) / l->h_mm);
	int32_t lab;
	const struct cut *c;

	/* the negated tests also send NaN outside */
	if (!(fx >= 0 && fx < l->nx && fy >= 0 && fy < l->ny && fz >= 0 && fz < l->nz))
		return -1;
	lab = l->vox[((size_t)fz * (size_t)l->ny + (size_t)fy) * (size_t)l->nx + (size_t)fx];
	if (lab < 0 || (size_t)lab >= l->ncut)
		return lab < 0 ? -1 : lab;
	c = &l->cut[lab];
	/* points of a Col part on the far side of its own base plane */
	if (c->cls != HY_NCOL && c->neighbour >= 0 &&
	    v3_dot(c->axis, v3_sub(p, c->base_mm)) < 0)
		return c->neighbour;
	/* points of lab on the near side of a Col neighbour's base plane,
	 * within its radius and reach */
	for (size_t i = 0; i < l->ncut; i++) {
		const struct cut *d = &l->cut[i];
		struct vec3 r;
		double t;
		if (d->cls == HY_NCOL || d->neighbour != lab)
			continue;
		r = v3_sub(p, d->base_mm);
		t = v3_dot(d->axis, r);
		if (t >= 0 && t <= d->length_mm &&
		    v3_len2(v3_madd(r, d->axis, -t)) <= d->radius_mm * d->radius_mm)
			return (int)i;
	}
	return lab;
}

void hy_labeler_remap(struct hy_labeler *l, const struct hy_parts *ps, const int *remap)
{
	size_t nvox = (size_t)l->nx * (size_t)l->ny * (size_t)l->nz, n_old = l->ncut;

	for (size_t v = 0; v < nvox; v++)
		if (l->vox[v] >= 0 && (size_t)l->vox[v] < n_old)
			l->vox[v] = remap[l->vox[v]] < 0 ? -1 : remap[l->vox[v]];
	read_cuts(l, ps);
}

void hy_labeler_free(struct hy_labeler *l)
{
	if (!l)
		return;
	mem_free(l->vox);
	mem_free(l->cut);
	mem_free(l);
}
