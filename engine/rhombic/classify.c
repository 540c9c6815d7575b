/* classify.c - the part as a voxel grid with distances, and the initial
 * adaptive hierarchy (paper 001 section 4.3; docs/rhombic.md section 3).
 *
 * Voxels: the placed part is sliced at every voxel row's centre height and
 * the section rasterised with centre sampling, so a voxel is inside when
 * its centre is; the exact 3D Euclidean distance of each inside voxel to
 * the nearest outside voxel centre (edt3_sq) sorts it into near (<= tau)
 * or deep (> tau), tau = t_bnd + (sqrt 3 / 2) voxel.
 */
#include "engine/rhombic/rhombic.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/geom/edt.h"
#include "engine/geom/raster.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <string.h>

void rh_vox_fini(struct rh_vox *vx)
{
	mem_free(vx->code);
	memset(vx, 0, sizeof *vx);
}

int rh_vox_build(const struct mesh *m, double h_mm, double tau_mm, size_t max_voxels,
		 struct rh_vox *vx, struct err *e)
{
	struct box3 b = box3_empty();
	struct slicer *sl = NULL;
	struct raster *r = NULL;
	struct raster_map map;
	struct paths region;
	uint8_t *seed = NULL;
	float *d2 = NULL;
	double nxd, nyd, nzd, tau2;
	size_t plane, n;
	int rc;

	memset(vx, 0, sizeof *vx);
	paths_init(&region);
	for (size_t i = 0; i < m->nv; i++)
		box3_add(&b, m->v[i]);
	if (box3_is_empty(b) || !(h_mm > 0))
		return ERR_SET(e, ERR_GEOMETRY, "rhombic: empty part or voxel size %g mm", h_mm);
	nxd = ceil((b.hi.x - b.lo.x) / h_mm) + 4;
	nyd = ceil((b.hi.y - b.lo.y) / h_mm) + 4;
	nzd = ceil((b.hi.z - b.lo.z) / h_mm) + 4;
	if (nxd > 65535 || nyd > 65535 || nzd > 65535 || nxd * nyd * nzd > (double)max_voxels)
		return ERR_SET(e, ERR_LIMIT,
			       "rhombic: a %.0f x %.0f x %.0f classification grid of %g mm voxels is "
			       "over %zu voxels",
			       nxd, nyd, nzd, h_mm, max_voxels);
	vx->nx = (int)nxd;
	vx->ny = (int)nyd;
	vx->nz = (int)nzd;
	vx->h_mm = h_mm;
	vx->tau_mm = tau_mm;
	/* centred on the bbox: two voxels of outside all round */
	vx->lo = v3((b.lo.x + b.hi.x - nxd * h_mm) / 2, (b.lo.y + b.hi.y - nyd * h_mm) / 2,
		    (b.lo.z + b.hi.z - nzd * h_mm) / 2);
	plane = (size_t)vx->nx * (size_t)vx->ny;
	n = plane * (size_t)vx->nz;
	seed = mem_alloc(n);
	d2 = mem_alloc(n * sizeof *d2);
	vx->code = mem_alloc(n);
	r = raster_new(vx->nx, vx->ny);
	if (!seed || !d2 || !vx->code || !r) {
		rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for %zu voxels", n);
		goto out;
	}
	if ((rc = slice_new(m, &sl, e)) != 0)
		goto out;
	memset(&map, 0, sizeof map);
	map.a[0][0] = 1 / h_mm;
	map.a[1][1] = 1 / h_mm;
	map.b[0] = -vx->lo.x / h_mm;
	map.b[1] = -vx->lo.y / h_mm;
	for (int k = 0; k < vx->nz; k++) {
		uint8_t *sp = seed + (size_t)k * plane;
		if ((rc = slice_at(sl, vx->lo.z + (k + 0.5) * h_mm, &region, NULL, e)) != 0)
			goto out;
		raster_clear(r);
		if (region.n && (rc = slice_rasterize(&region, &map, 0, r, e)) != 0)
			goto out;
		for (int j = 0; j < vx->ny; j++)
			for (int i = 0; i < vx->nx; i++)
				sp[(size_t)j * (size_t)vx->nx + (size_t)i] =
					r->px[(size_t)j * r->stride + (size_t)i] < 128;
	}
	if ((rc = edt3_sq(seed, vx->nx, vx->ny, vx->nz, h_mm, d2, e)) != 0)
		goto out;
	tau2 = tau_mm * tau_mm;
	for (size_t i = 0; i < n; i++)
		vx->code[i] = seed[i] ? RH_VOX_OUT : d2[i] > tau2 ? RH_VOX_DEEP : RH_VOX_NEAR;
out:
	slice_free(sl);
	raster_free(r);
	paths_fini(&region);
	mem_free(seed);
	mem_free(d2);
	return rc;
}

static uint8_t vox_code(const struct rh_vox *vx, int i, int j, int k)
{
	if (i < 0 || j < 0 || k < 0 || i >= vx->nx || j >= vx->ny || k >= vx->nz)
		return RH_VOX_OUT;
	return vx->code[((size_t)k * (size_t)vx->ny + (size_t)j) * (size_t)vx->nx + (size_t)i];
}

enum rh_class rh_classify(const struct rh_frame *f, const struct rh_vox *vx,
			  const struct rh_cell *c)
{
	struct rh_geom g;
	double h = vx->h_mm;
	int notdeep = 0, notout = 0, covered = 0;
	int k0, k1;

	rh_cell_geom(f, c, &g);
	/* a vertex of the prism beyond the grid: the cell holds points of the
	 * outside (the grid is the part's box and two voxels more) */
	for (int q = 0; q < 8; q++) {
		double u = q < 4 ? g.cu + ((q & 1) ? g.a : -g.a) : g.cu;
		double z = q < 4 ? g.cz : g.cz + ((q & 1) ? g.b : -g.b);
		double v = (q & 2) ? g.vhi : g.vlo, x, y;
		rh_to_printer(f, u, v, &x, &y);
		if (x < vx->lo.x || y < vx->lo.y || z < vx->lo.z || x > vx->lo.x + vx->nx * h ||
		    y > vx->lo.y + vx->ny * h || z > vx->lo.z + vx->nz * h)
			notdeep = 1;
	}
	k0 = (int)ceil((g.cz - g.b - vx->lo.z) / h - 0.5);
	k1 = (int)floor((g.cz + g.b - vx->lo.z) / h - 0.5);
	k0 = k0 < 0 ? 0 : k0;
	k1 = k1 >= vx->nz ? vx->nz - 1 : k1;
	for (int k = k0; k <= k1 && !(notdeep && notout); k++) {
		double z = vx->lo.z + (k + 0.5) * h;
		double hw = g.a * (1 - fabs(z - g.cz) / g.b);
		double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
		int i0, i1, j0, j1;
		if (hw < 0)
			continue;
		for (int q = 0; q < 4; q++) {
			double x, y;
			rh_to_printer(f, g.cu + ((q & 1) ? hw : -hw), (q & 2) ? g.vhi : g.vlo, &x, &y);
			xlo = fmin(xlo, x);
			xhi = fmax(xhi, x);
			ylo = fmin(ylo, y);
			yhi = fmax(yhi, y);
		}
		i0 = (int)ceil((xlo - vx->lo.x) / h - 0.5);
		i1 = (int)floor((xhi - vx->lo.x) / h - 0.5);
		j0 = (int)ceil((ylo - vx->lo.y) / h - 0.5);
		j1 = (int)floor((yhi - vx->lo.y) / h - 0.5);
		i0 = i0 < 0 ? 0 : i0;
		j0 = j0 < 0 ? 0 : j0;
		i1 = i1 >= vx->nx ? vx->nx - 1 : i1;
		j1 = j1 >= vx->ny ? vx->ny - 1 : j1;
		for (int j = j0; j <= j1 && !(notdeep && notout); j++) {
			double y = vx->lo.y + (j + 0.5) * h;
			for (int i = i0; i <= i1; i++) {
				double x = vx->lo.x + (i + 0.5) * h, u, v;
				uint8_t code;
				rh_to_cell(f, x, y, &u, &v);
				if (fabs(u - g.cu) > hw || v < g.vlo || v > g.vhi)
					continue;
				covered = 1;
				code = vx->code[((size_t)k * (size_t)vx->ny + (size_t)j) *
							(size_t)vx->nx +
						(size_t)i];
				notdeep |= code != RH_VOX_DEEP;
				notout |= code != RH_VOX_OUT;
				if (notdeep && notout)
					break;
			}
		}
	}
	if (!covered) { /* smaller than a voxel: the voxel of its centre */
		double x, y;
		uint8_t code;
		rh_to_printer(f, g.cu, (g.vlo + g.vhi) / 2, &x, &y);
		code = vox_code(vx, (int)floor((x - vx->lo.x) / h), (int)floor((y - vx->lo.y) / h),
				(int)floor((g.cz - vx->lo.z) / h));
		notdeep |= code != RH_VOX_DEEP;
		notout |= code != RH_VOX_OUT;
	}
	return notdeep && notout ? RH_CLASS_BOUNDARY : notout ? RH_CLASS_IN : RH_CLASS_OUT;
}

struct classify_job {
	const struct rh_tree *t;
	const struct rh_vox *vx;
	const int32_t *cells;
	uint8_t *cls;
};

static void classify_one(void *ctx, size_t i, int tid)
{
	struct classify_job *j = ctx;

	(void)tid;
	j->cls[i] = (uint8_t)rh_classify(&j->t->f, j->vx, &j->t->c[j->cells[i]]);
}

int rh_tree_build(struct rh_tree *t, const struct rh_vox *vx, int threads, struct err *e)
{
	int32_t *front = NULL, *next = NULL;
	uint8_t *cls = NULL;
	size_t nf = 0, capf = 0, nn = 0, capn = 0, capc = 0;
	int rc = 0;

	if (t->f.max_level < 0)
		return 0; /* not even the root can hold a cavity: all solid */
	if ((rc = rh_tree_roots(t, e)) != 0)
		return rc;
	if (mem_grow((void **)&front, &capf, (size_t)t->nroots, sizeof *front)) {
		rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
		goto out;
	}
	for (int32_t k = 0; k < t->nroots; k++)
		front[nf++] = k;
	while (nf) {
		struct classify_job job;
		if (mem_grow((void **)&cls, &capc, nf, 1)) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
			goto out;
		}
		job.t = t;
		job.vx = vx;
		job.cells = front;
		job.cls = cls;
		parfor_run(nf, threads, 16, classify_one, &job);
		nn = 0;
		for (size_t q = 0; q < nf; q++) {
			int32_t idx = front[q];
			if (cls[q] == RH_CLASS_IN) {
				t->c[idx].state = RH_CAVITY;
			} else if (cls[q] == RH_CLASS_OUT) {
				t->c[idx].state = RH_OUT;
			} else if (!rh_tree_can_split(t, idx)) {
				t->c[idx].state = RH_SOLID;
			} else {
				if ((rc = rh_tree_split(t, idx, e)) != 0)
					goto out;
				if (mem_grow((void **)&next, &capn, nn + 8, sizeof *next)) {
					rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
					goto out;
				}
				for (int k = 0; k < t->c[idx].nchild; k++)
					next[nn++] = t->c[idx].child + k;
			}
		}
		{
			int32_t *sw = front;
			size_t sc = capf;
			front = next;
			capf = capn;
			next = sw;
			capn = sc;
			nf = nn;
		}
	}
	rh_tree_recount(t);
out:
	mem_free(front);
	mem_free(next);
	mem_free(cls);
	return rc;
}
