/* voxelize.c - a mesh -> solid fraction per voxel (fea_voxelize_mesh).
 * Each voxel layer is sliced at `ss` heights inside it (slice_at) and
 * each cut's exact area coverage on a grid of pitch h (slice_coverage)
 * is averaged: exact in x-y, a midpoint rule of ss points in z.  Layers
 * run in parallel, one slicer per thread (a slicer sweeps upwards, and
 * parfor hands each thread increasing layers).  docs/fea.md, "Voxels".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"

#define VOX_MAX_THREADS 64

void fea_grid_fini(struct fea_grid *g)
{
	if (!g)
		return;
	mem_free(g->rho);
	g->rho = NULL;
}

struct vox_thread {
	struct slicer *sl;
	struct paths region;
	float *cov;
	int rc;
	struct err e;
};

struct vox_ctx {
	struct fea_grid *g;
	int ss;
	struct raster_map map;
	struct vox_thread *th;
};

static void vox_layer(void *vctx, size_t k, int tid)
{
	struct vox_ctx *c = vctx;
	struct vox_thread *t = &c->th[tid];
	struct fea_grid *g = c->g;
	size_t plane = (size_t)g->nx * (size_t)g->ny;
	float *rho = g->rho + k * plane;

	if (t->rc)
		return;
	memset(rho, 0, plane * sizeof *rho);
	for (int q = 0; q < c->ss; q++) {
		double z = g->lo_mm.z + ((double)k + (q + 0.5) / c->ss) * g->h_mm;
		if ((t->rc = slice_at(t->sl, z, &t->region, NULL, &t->e)))
			return;
		if (t->region.n == 0)
			continue;
		memset(t->cov, 0, plane * sizeof *t->cov);
		if ((t->rc = slice_coverage(&t->region, &c->map, t->cov, g->nx, g->ny,
					    (size_t)g->nx, &t->e)))
			return;
		for (size_t i = 0; i < plane; i++)
			rho[i] += t->cov[i];
	}
	for (size_t i = 0; i < plane; i++) {
		float v = rho[i] / (float)c->ss;
		rho[i] = v > 1 ? 1 : v < 1e-7f ? 0 : v; /* coverage rounding dust is no element */
	}
}

int fea_voxelize_mesh(const struct mesh *m, double h_mm, int supersample, size_t max_elements,
		      int threads, struct fea_grid *g, struct err *e)
{
	struct box3 bb = box3_empty();
	struct fea_grid t;
	struct vox_thread th[VOX_MAX_THREADS];
	struct vox_ctx c;
	double n[3], total;
	int rc = 0;

	if (!(h_mm > 0) || !isfinite(h_mm))
		return ERR_FIELD(e, "fea_voxel_mm", "voxel edge must be a finite number > 0, not %g",
				 h_mm);
	if (supersample < 1 || supersample > 64)
		return ERR_FIELD(e, "supersample", "supersample must be in 1..64, not %d",
				 supersample);
	for (size_t i = 0; i < m->nv; i++)
		box3_add(&bb, m->v[i]);
	if (m->nt == 0 || box3_is_empty(bb))
		return ERR_SET(e, ERR_GEOMETRY, "empty mesh: nothing to voxelize");
	n[0] = ceil((bb.hi.x - bb.lo.x) / h_mm - 1e-9) + 2;
	n[1] = ceil((bb.hi.y - bb.lo.y) / h_mm - 1e-9) + 2;
	n[2] = ceil((bb.hi.z - bb.lo.z) / h_mm - 1e-9) + 2;
	total = n[0] * n[1] * n[2];
	if (!(total <= (double)max_elements) || n[0] > 65535 || n[1] > 65535 || n[2] > 65535) {
		rc = ERR_SET(e, ERR_LIMIT,
			     "fea voxel grid %.0f x %.0f x %.0f = %.0f elements exceeds the limit of "
			     "%zu; use a larger fea_voxel_mm",
			     n[0], n[1], n[2], total, max_elements);
		if (e)
			snprintf(e->field, sizeof e->field, "fea_voxel_mm");
		return rc;
	}
	memset(&t, 0, sizeof t);
	t.nx = (int)n[0];
	t.ny = (int)n[1];
	t.nz = (int)n[2];
	t.h_mm = h_mm;
	t.part_lo_mm = bb.lo;
	t.part_hi_mm = bb.hi;
	t.lo_mm = (struct vec3){bb.lo.x - h_mm, bb.lo.y - h_mm, bb.lo.z - h_mm};
	t.rho = mem_alloc((size_t)total * sizeof *t.rho);
	if (!t.rho)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the fea voxel grid");

	if (threads < 1)
		threads = 1;
	if (threads > VOX_MAX_THREADS)
		threads = VOX_MAX_THREADS;
	if (threads > t.nz)
		threads = t.nz;
	memset(th, 0, sizeof th);
	for (int i = 0; i < threads; i++) {
		paths_init(&th[i].region);
		err_clear(&th[i].e);
		th[i].cov = mem_alloc((size_t)t.nx * (size_t)t.ny * sizeof *th[i].cov);
		if (!th[i].cov) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory for the fea voxel grid");
			goto out;
		}
		if ((rc = slice_new(m, &th[i].sl, e)))
			goto out;
	}
	/* pixel (i, j) of the coverage image = voxel column (i, j) */
	c.g = &t;
	c.ss = supersample;
	c.th = th;
	c.map.a[0][0] = 1 / h_mm;
	c.map.a[0][1] = 0;
	c.map.a[1][0] = 0;
	c.map.a[1][1] = 1 / h_mm;
	c.map.b[0] = -t.lo_mm.x / h_mm;
	c.map.b[1] = -t.lo_mm.y / h_mm;
	parfor_run((size_t)t.nz, threads, 1, vox_layer, &c);
	for (int i = 0; i < threads; i++)
		if (th[i].rc && !rc) {
			rc = th[i].rc;
			if (e)
				*e = th[i].e;
		}
out:
	for (int i = 0; i < threads; i++) {
		slice_free(th[i].sl);
		paths_fini(&th[i].region);
		mem_free(th[i].cov);
	}
	if (rc) {
		mem_free(t.rho);
		return rc;
	}
	*g = t;
	return 0;
}
