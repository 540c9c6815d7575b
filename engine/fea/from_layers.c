/* from_layers.c - voxel densities from a layer stack's images (see
 * from_layers.h; docs/fea_cli.md, "Archive input").
 *
 * Pixel (i, j) covers [i, i+1) x [j, j+1) in pixel coordinates; with an
 * axis-aligned map, column i is an interval along one printer axis (x, or
 * y for a portrait display) and row j one along the other.  Each column
 * and row is split once into its pieces per voxel (index, length in mm);
 * a lit pixel then adds value/255 * column piece * row piece * layer piece
 * to at most a few voxels.
 */
#include "engine/fea/from_layers.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* Below this, a map coefficient counts as zero (pixels per mm). */
#define MAP_EPS 1e-12

/* One voxel a pixel column (or row, or layer) reaches, and how far. */
struct piece {
	int cell;
	double len_mm;
};

/* The pieces of every column (or row): pieces off[i] .. off[i+1]-1. */
struct split {
	struct piece *p;
	int *off; /* n + 1 entries */
	int lo, hi; /* first and one past the last index with a piece */
};

struct fea_layers {
	struct fea_layers_geom geo;
	int u_is_x;            /* columns run along printer x (else y) */
	int nx, ny, nz;
	double h_mm;
	struct vec3 lo_mm;
	struct box3 part;
	struct split col, row; /* columns / rows -> voxel index along x or y */
	double *acc;           /* nx * ny * nz material volumes (mm^3) */
};

/* Map coefficients: u = a*x + b*y + c.  Axis-aligned means one of a, b
 * is zero in each row. */
static int axis_aligned(const struct raster_map *m, int *u_is_x)
{
	int ux = fabs(m->a[0][0]) > MAP_EPS && fabs(m->a[0][1]) <= MAP_EPS &&
		 fabs(m->a[1][0]) <= MAP_EPS && fabs(m->a[1][1]) > MAP_EPS;
	int uy = fabs(m->a[0][1]) > MAP_EPS && fabs(m->a[0][0]) <= MAP_EPS &&
		 fabs(m->a[1][1]) <= MAP_EPS && fabs(m->a[1][0]) > MAP_EPS;

	*u_is_x = ux;
	return ux || uy;
}

int fea_layers_check(const struct fea_layers_geom *geo, struct err *e)
{
	int ux;

	if (!(geo->layer_mm > 0) || !isfinite(geo->layer_mm))
		return ERR_SET(e, ERR_PARSE, "the archive does not state its layer height");
	if (geo->width < 1 || geo->height < 1)
		return ERR_SET(e, ERR_PARSE, "the archive's layers have no pixels");
	if (!axis_aligned(&geo->map, &ux))
		return ERR_SET(e, ERR_UNSUPPORTED,
			       "the archive's pixel map is not aligned with the printer axes");
	return 0;
}

/* The printer-axis interval (mm) of pixel index i along u (along = 0) or
 * v (along = 1): u = a * t + c with t the one printer coordinate. */
static void pixel_interval(const struct raster_map *m, int along, int u_is_x, int i,
			   double *t0, double *t1)
{
	/* u row: coefficient on x (u_is_x) or y; v row: the other */
	double a = along == 0 ? (u_is_x ? m->a[0][0] : m->a[0][1])
			      : (u_is_x ? m->a[1][1] : m->a[1][0]);
	double c = m->b[along];
	double p = ((double)i - c) / a, q = ((double)i + 1 - c) / a;

	*t0 = fmin(p, q);
	*t1 = fmax(p, q);
}

void fea_layers_box(const struct fea_layers_geom *geo, int k, const struct raster *img,
		    struct box3 *box)
{
	int ux, ulo = img->w, uhi = -1, vlo = img->h, vhi = -1;
	double a0, a1, b0, b1, u0, u1, v0, v1;
	double z0 = k * geo->layer_mm, z1 = (k + 1) * geo->layer_mm;

	if (!axis_aligned(&geo->map, &ux))
		return;
	for (int j = 0; j < img->h; j++) {
		const uint8_t *r = img->px + (size_t)j * img->stride;
		int a = 0, b = img->w - 1;
		while (a < img->w && !r[a])
			a++;
		if (a == img->w)
			continue;
		while (!r[b])
			b--;
		ulo = a < ulo ? a : ulo;
		uhi = b > uhi ? b : uhi;
		vlo = j < vlo ? j : vlo;
		vhi = j;
	}
	if (uhi < 0)
		return;
	/* the outer edges of the extreme columns (along u's printer axis) and
	 * rows (along v's); a mirrored axis swaps which edge is lower */
	pixel_interval(&geo->map, 0, ux, ulo, &a0, &a1);
	pixel_interval(&geo->map, 0, ux, uhi, &b0, &b1);
	u0 = fmin(a0, b0);
	u1 = fmax(a1, b1);
	pixel_interval(&geo->map, 1, ux, vlo, &a0, &a1);
	pixel_interval(&geo->map, 1, ux, vhi, &b0, &b1);
	v0 = fmin(a0, b0);
	v1 = fmax(a1, b1);
	box3_add(box, ux ? v3(u0, v0, z0) : v3(v0, u0, z0));
	box3_add(box, ux ? v3(u1, v1, z1) : v3(v1, u1, z1));
}

/* Pieces of [t0, t1] over cells [lo + c h, lo + (c+1) h), c in 0..n-1,
 * appended to *p (count *np, capacity *cap). */
static int add_pieces(double t0, double t1, double lo, double h, int n, struct piece **p,
		      size_t *np, size_t *cap)
{
	int c0 = (int)floor((t0 - lo) / h), c1 = (int)floor((t1 - lo) / h);

	if (c0 < 0)
		c0 = 0;
	if (c1 > n - 1)
		c1 = n - 1;
	for (int c = c0; c <= c1; c++) {
		double a = fmax(t0, lo + c * h), b = fmin(t1, lo + (c + 1) * h);
		void *arr = *p;
		if (!(b > a))
			continue;
		if (mem_grow(&arr, cap, *np + 1, sizeof **p))
			return ERR_NOMEM;
		*p = arr;
		(*p)[*np].cell = c;
		(*p)[*np].len_mm = b - a;
		(*np)++;
	}
	return 0;
}

/* Split every pixel index 0..count-1 along u (along 0) or v (1) into
 * cells of the grid axis (lo, h, n). */
static int split_axis(struct fea_layers *L, int along, int count, double lo, int n,
		      struct split *s, struct err *e)
{
	size_t np = 0, cap = 0;

	memset(s, 0, sizeof *s);
	s->off = mem_alloc(((size_t)count + 1) * sizeof *s->off);
	if (!s->off)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the pixel map");
	s->lo = count;
	s->hi = 0;
	for (int i = 0; i < count; i++) {
		double t0, t1;
		size_t before = np;
		s->off[i] = (int)np;
		pixel_interval(&L->geo.map, along, L->u_is_x, i, &t0, &t1);
		if (add_pieces(t0, t1, lo, L->h_mm, n, &s->p, &np, &cap))
			return ERR_SET(e, ERR_NOMEM, "out of memory for the pixel map");
		if (np > before) {
			s->lo = i < s->lo ? i : s->lo;
			s->hi = i + 1;
		}
		if (np > (size_t)1 << 30)
			return ERR_SET(e, ERR_LIMIT, "the pixel map splits into too many pieces");
	}
	s->off[count] = (int)np;
	return 0;
}

static void split_fini(struct split *s)
{
	mem_free(s->p);
	mem_free(s->off);
	memset(s, 0, sizeof *s);
}

void fea_layers_free(struct fea_layers *L)
{
	if (!L)
		return;
	split_fini(&L->col);
	split_fini(&L->row);
	mem_free(L->acc);
	mem_free(L);
}

int fea_layers_new(const struct fea_layers_geom *geo, const struct box3 *part, double h_mm,
		   size_t max_elements, struct fea_layers **out, struct err *e)
{
	struct fea_layers *L;
	struct vec3 size = box3_size(*part);
	double n[3];
	int rc;

	if ((rc = fea_layers_check(geo, e)) != 0)
		return rc;
	if (box3_is_empty(*part))
		return ERR_SET(e, ERR_GEOMETRY, "the layers hold no material");
	if (!(h_mm > 0) || !isfinite(h_mm))
		return ERR_FIELD(e, "fea_voxel_mm", "fea_voxel_mm must be above 0");
	for (int a = 0; a < 3; a++) {
		/* one voxel of padding each side, as fea_voxelize_mesh */
		n[a] = ceil(v3_comp(size, a) / h_mm - 1e-9) + 2;
		if (n[a] < 3)
			n[a] = 3;
	}
	if (n[0] * n[1] * n[2] > (double)max_elements) {
		rc = ERR_SET(e, ERR_LIMIT,
			     "fea_voxel_mm = %g mm gives %.0f x %.0f x %.0f = %.0f voxels (at most "
			     "%zu): choose a larger fea_voxel_mm",
			     h_mm, n[0], n[1], n[2], n[0] * n[1] * n[2], max_elements);
		if (e)
			snprintf(e->field, sizeof e->field, "fea_voxel_mm");
		return rc;
	}
	L = mem_calloc(1, sizeof *L);
	if (!L)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the voxel model");
	L->geo = *geo;
	axis_aligned(&geo->map, &L->u_is_x);
	L->nx = (int)n[0];
	L->ny = (int)n[1];
	L->nz = (int)n[2];
	L->h_mm = h_mm;
	L->lo_mm = v3_sub(part->lo, v3(h_mm, h_mm, h_mm));
	L->part = *part;
	L->acc = mem_calloc((size_t)L->nx * L->ny * L->nz, sizeof *L->acc);
	if (!L->acc) {
		fea_layers_free(L);
		return ERR_SET(e, ERR_NOMEM, "out of memory for %d x %d x %d voxels", (int)n[0],
			       (int)n[1], (int)n[2]);
	}
	/* columns along x or y, rows along the other */
	rc = split_axis(L, 0, geo->width, L->u_is_x ? L->lo_mm.x : L->lo_mm.y,
			L->u_is_x ? L->nx : L->ny, &L->col, e);
	if (!rc)
		rc = split_axis(L, 1, geo->height, L->u_is_x ? L->lo_mm.y : L->lo_mm.x,
				L->u_is_x ? L->ny : L->nx, &L->row, e);
	if (rc) {
		fea_layers_free(L);
		return rc;
	}
	*out = L;
	return 0;
}

int fea_layers_slabs(const struct fea_layers *L)
{
	return L->nz;
}

void fea_layers_slab_range(const struct fea_layers *L, int iz, int *k0, int *k1)
{
	double z0 = L->lo_mm.z + iz * L->h_mm, z1 = z0 + L->h_mm;
	int a = (int)floor(z0 / L->geo.layer_mm), b = (int)ceil(z1 / L->geo.layer_mm);

	*k0 = a < 0 ? 0 : a;
	*k1 = b < *k0 ? *k0 : b;
}

int fea_layers_add(struct fea_layers *L, int k, int iz, const struct raster *img,
		   struct err *e)
{
	struct piece zp[64];
	size_t nzp = 0, zcap = 0;
	struct piece *zps = NULL;
	double z0 = k * L->geo.layer_mm, z1 = (k + 1) * L->geo.layer_mm;
	size_t sx = 1, sy = (size_t)L->nx, sz = (size_t)L->nx * L->ny;
	size_t su = L->u_is_x ? sx : sy, sv = L->u_is_x ? sy : sx;

	if (img->w != L->geo.width || img->h != L->geo.height)
		return ERR_SET(e, ERR_PARSE, "layer %d is %dx%d pixels, the stack %dx%d", k, img->w,
			       img->h, L->geo.width, L->geo.height);
	if (add_pieces(z0, z1, L->lo_mm.z, L->h_mm, L->nz, &zps, &nzp, &zcap))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	if (nzp > sizeof zp / sizeof zp[0]) {
		mem_free(zps);
		return ERR_SET(e, ERR_LIMIT, "layer %d spans more than 64 voxels", k);
	}
	if (nzp)
		memcpy(zp, zps, nzp * sizeof *zp);
	mem_free(zps);
	if (iz >= 0) {
		/* only slab iz: keep its piece */
		size_t keep = 0;
		for (size_t c = 0; c < nzp; c++)
			if (zp[c].cell == iz)
				zp[keep++] = zp[c];
		nzp = keep;
	}
	for (int j = L->row.lo; nzp && j < L->row.hi; j++) {
		const uint8_t *r = img->px + (size_t)j * img->stride;
		const struct piece *rp = L->row.p + L->row.off[j];
		int nrp = L->row.off[j + 1] - L->row.off[j];
		for (int i = L->col.lo; nrp && i < L->col.hi; i++) {
			double f;
			if (!r[i])
				continue;
			f = r[i] / 255.0;
			for (int a = L->col.off[i]; a < L->col.off[i + 1]; a++) {
				const struct piece *cp = &L->col.p[a];
				for (int b = 0; b < nrp; b++) {
					double area = f * cp->len_mm * rp[b].len_mm;
					size_t base = (size_t)cp->cell * su + (size_t)rp[b].cell * sv;
					for (size_t c = 0; c < nzp; c++)
						L->acc[base + (size_t)zp[c].cell * sz] +=
							area * zp[c].len_mm;
				}
			}
		}
	}
	return 0;
}

int fea_layers_finish(struct fea_layers *L, struct fea_grid *g, struct err *e)
{
	size_t n = (size_t)L->nx * L->ny * L->nz, present = 0;
	double v = L->h_mm * L->h_mm * L->h_mm;
	float *rho = mem_alloc(n * sizeof *rho);

	if (!rho)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu densities", n);
	for (size_t i = 0; i < n; i++) {
		double f = L->acc[i] / v;
		rho[i] = f < FEA_LAYERS_MIN_FRACTION ? 0.0f : f > 1 ? 1.0f : (float)f;
		present += rho[i] > 0;
	}
	if (!present) {
		mem_free(rho);
		return ERR_SET(e, ERR_GEOMETRY, "no voxel of %g mm holds material", L->h_mm);
	}
	memset(g, 0, sizeof *g);
	g->nx = L->nx;
	g->ny = L->ny;
	g->nz = L->nz;
	g->h_mm = L->h_mm;
	g->lo_mm = L->lo_mm;
	g->part_lo_mm = L->part.lo;
	g->part_hi_mm = L->part.hi;
	g->rho = rho;
	return 0;
}
