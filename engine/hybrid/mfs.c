/* mfs.c - the muscle-fibre structure's 2D section (paper 003 section 5.1),
 * extruded along an axis (hybrid.h).
 *
 * Voronoi pattern.  Sites: poisson2_sample with radius cell_mm over the
 * square of side 2 extent_mm centred on the origin's projection (plane
 * coordinates u = e1 . p, v = e2 . p).  A point q whose nearest site is s1
 * (distance d1) lies in s1's Voronoi cell, an intersection of half-planes;
 * its distance to the cell's boundary is the least distance to the
 * bisectors of s1 and each other site sj (distance dj):
 *     dist_j = (dj^2 - d1^2) / (2 |sj - s1|),
 * and q is wall when min_j dist_j < wall / 2, i.e. when for some j
 *     dj^2 - d1^2 < wall |sj - s1|   (no square root).
 * (The two nearest sites alone are not enough near a Voronoi vertex,
 * where a third site's bisector can be the closer one.)  Since
 * dj^2 - d1^2 = (dj - d1)(dj + d1) and |sj - s1| <= dj + d1, only sites
 * with dj < d1 + wall can matter.  O(1) queries: a grid of square cells
 * of edge g over the square lists, for each cell with centre c and half
 * diagonal h, the sites within d1(c) + 2 h + wall of c: for a q in the
 * cell d1(q) <= d1(c) + h and dj >= |sj - c| - h, so every site that can
 * be q's nearest or matter to its wall test is listed.  Cells whose
 * centre lies more than h inside or outside the wall band are marked
 * wholly void or wall at build time (classify_cells), so most queries
 * read one byte; the others scan about 3 listed sites (g = cell / 6).
 *
 * Template.  A PNG (out_png_read_gray_file) binarised at > 127 = material,
 * tiled with pixel pitch template_mm; walls thinner than wall_mm are
 * thickened once at load: the thin ridges (material pixels that are local
 * maxima of the distance to the void, less than half a wall from it) are
 * dilated by a disc so they end at least wall_mm wide; material pixels of
 * thicker walls are left as they are.  Both distance maps are
 * engine/geom/edt.h's, on the tile padded periodically.
 */
#include "engine/hybrid/structure.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"
#include "engine/geom/pointgrid.h"
#include "engine/geom/poisson.h"
#include "engine/geom/raster.h"
#include "engine/output/image/image.h"

#include <math.h>
#include <string.h>

/* Voronoi query cells per side of a site spacing (g = cell_mm / this). */
#define MFS_CELLS_PER_SITE 6
#define MFS_MAX_QUERY_CELLS (4u << 20)
#define MFS_MAX_SITES (16u << 20)
/* padded template pixels at most (the tile plus its periodic margin) */
#define MFS_MAX_TEMPLATE_PX (64u << 20)

enum mfs_kind { MFS_VORONOI, MFS_TEMPLATE };
/* A query cell wholly void, wholly wall, or to be tested point by point. */
enum mfs_cell { CELL_VOID = 0, CELL_WALL = 1, CELL_TEST = 2 };

struct hy_mfs {
	int kind;             /* enum mfs_kind */
	struct vec3 axis, e1, e2; /* unit; e1, e2 span the section plane */
	double u0, v0;        /* plane coordinates of the pattern's origin, mm */

	/* Voronoi: plane coordinates relative to the square's corner
	 * (u0 - extent, v0 - extent) */
	double side_mm;       /* 2 extent */
	double wall_mm, wall2_mm2;
	double *site;         /* nsite (u, v) pairs, relative */
	size_t nsite;
	double g_mm, inv_g;   /* query cell edge */
	int gn;               /* query cells per side */
	uint32_t *start;      /* gn * gn + 1 offsets into cand */
	double *cand;         /* (u, v) pairs of the listed sites, cell by cell */
	uint8_t *cls;         /* per query cell: CELL_VOID, CELL_WALL or CELL_TEST */

	/* template: pixel (i, row) covers u - u0 in [i, i + 1) pitch and
	 * v - v0 in [th - 1 - row, th - row) pitch, tiled */
	uint8_t *mask;        /* tw * th, 1 = material */
	int tw, th;
	double pitch_mm, inv_pitch;
	double wall_template_mm;
};

/* e1, e2: e1 the unit projection of the coordinate axis least aligned
 * with the axis (the first of the smallest |component|), e2 = axis x e1.
 * Axis z gives e1 = x, e2 = y. */
static void plane_basis(struct vec3 n, struct vec3 *e1, struct vec3 *e2)
{
	double ax = fabs(n.x), ay = fabs(n.y), az = fabs(n.z);
	struct vec3 h = ax <= ay && ax <= az ? v3(1, 0, 0) : ay <= az ? v3(0, 1, 0) : v3(0, 0, 1);

	*e1 = v3_normalize(v3_madd(h, n, -v3_dot(h, n)));
	*e2 = v3_cross(n, *e1);
}

static int mfs_alloc(struct vec3 axis, struct vec3 origin_mm, int kind, struct hy_mfs **out,
		     struct err *e)
{
	struct hy_mfs *f;
	double l = v3_len(axis);

	if (!(l > 0) || !isfinite(l))
		return ERR_FIELD(e, "axis", "MFS axis must be a nonzero finite vector");
	if (!isfinite(origin_mm.x) || !isfinite(origin_mm.y) || !isfinite(origin_mm.z))
		return ERR_SET(e, ERR_PARAM, "MFS origin is not finite");
	f = mem_calloc(1, sizeof *f);
	if (!f)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	f->kind = kind;
	f->axis = v3_scale(axis, 1 / l);
	plane_basis(f->axis, &f->e1, &f->e2);
	f->u0 = v3_dot(f->e1, origin_mm);
	f->v0 = v3_dot(f->e2, origin_mm);
	*out = f;
	return 0;
}

void hy_mfs_free(struct hy_mfs *f)
{
	if (!f)
		return;
	mem_free(f->site);
	mem_free(f->start);
	mem_free(f->cand);
	mem_free(f->cls);
	mem_free(f->mask);
	mem_free(f);
}

void hy_mfs_basis(const struct hy_mfs *f, struct vec3 *e1, struct vec3 *e2)
{
	*e1 = f->e1;
	*e2 = f->e2;
}

const double *hy_mfs_sites(const struct hy_mfs *f, size_t *n, double *u_lo, double *v_lo)
{
	*n = f->nsite;
	*u_lo = f->u0 - 0.5 * f->side_mm;
	*v_lo = f->v0 - 0.5 * f->side_mm;
	return f->site;
}

/* ---- Voronoi ---- */

struct nearest_ctx {
	const struct pointgrid *g;
	struct vec3 c;
	double best2;
};

static int nearest_visit(void *ctx, int32_t q)
{
	struct nearest_ctx *x = ctx;
	x->best2 = fmin(x->best2, v3_len2(v3_sub(x->g->pts[q], x->c)));
	return 0;
}

struct list_ctx {
	const struct pointgrid *g;
	struct vec3 c;
	double lim2;
	double *out; /* NULL: count only */
	size_t n;
};

static int list_visit(void *ctx, int32_t q)
{
	struct list_ctx *x = ctx;
	struct vec3 p = x->g->pts[q];

	if (v3_len2(v3_sub(p, x->c)) <= x->lim2) {
		if (x->out) {
			x->out[2 * x->n] = p.x;
			x->out[2 * x->n + 1] = p.y;
		}
		x->n++;
	}
	return 0;
}

/* Distance from c to the nearest site (sites exist). */
static double nearest_site(const struct pointgrid *g, struct vec3 c, double r0)
{
	struct nearest_ctx x = {g, c, INFINITY};

	for (double r = r0;; r *= 2) {
		pointgrid_visit(g, c, r, nearest_visit, &x);
		if (x.best2 <= r * r)
			return sqrt(x.best2);
	}
}

/* The per-cell candidate lists (file comment), counted then filled. */
static int build_lists(struct hy_mfs *f, const struct pointgrid *g, struct err *e)
{
	size_t nc = (size_t)f->gn * (size_t)f->gn, total = 0;
	double h = f->g_mm * sqrt(0.5);
	double *lim = mem_alloc(nc * sizeof *lim);
	int rc = 0;

	f->start = mem_calloc(nc + 1, sizeof *f->start);
	if (!lim || !f->start) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu MFS query cells", nc);
		goto out;
	}
	for (int pass = 0; pass < 2; pass++) {
		for (size_t k = 0; k < nc; k++) {
			struct vec3 c = v3(((double)(k % (size_t)f->gn) + 0.5) * f->g_mm,
					   ((double)(k / (size_t)f->gn) + 0.5) * f->g_mm, 0);
			struct list_ctx x;
			if (pass == 0)
				lim[k] = nearest_site(g, c, f->g_mm) + 2 * h + f->wall_mm;
			x.g = g;
			x.c = c;
			/* a hair more, so rounding never drops a site that matters */
			x.lim2 = lim[k] * lim[k] * (1 + 1e-9);
			x.out = pass ? f->cand + 2 * (size_t)f->start[k] : NULL;
			x.n = 0;
			pointgrid_visit(g, c, lim[k], list_visit, &x);
			if (pass == 0) {
				f->start[k + 1] = (uint32_t)x.n;
				total += x.n;
				if (total > UINT32_MAX / 2) {
					rc = ERR_SET(e, ERR_LIMIT, "MFS candidate lists too long");
					goto out;
				}
			}
		}
		if (pass == 0) {
			for (size_t k = 0; k < nc; k++)
				f->start[k + 1] += f->start[k];
			f->cand = mem_alloc((total ? total : 1) * 2 * sizeof *f->cand);
			if (!f->cand) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu MFS candidates",
					     total);
				goto out;
			}
		}
	}
out:
	mem_free(lim);
	return rc;
}

/* Distance from (u, v) to the Voronoi boundary by query cell k's list:
 * exact when it is below d1 + wall, else a value at least that. */
static double edge_distance(const struct hy_mfs *f, size_t k, double u, double v)
{
	const double *c = f->cand + 2 * (size_t)f->start[k];
	size_t n = f->start[k + 1] - f->start[k], best = 0;
	double d1 = INFINITY, m = INFINITY;

	for (size_t q = 0; q < n; q++) {
		double du = c[2 * q] - u, dv = c[2 * q + 1] - v, d2 = du * du + dv * dv;
		if (d2 < d1) {
			d1 = d2;
			best = q;
		}
	}
	for (size_t q = 0; q < n; q++) {
		double du = c[2 * q] - u, dv = c[2 * q + 1] - v;
		double sep = hypot(c[2 * q] - c[2 * best], c[2 * q + 1] - c[2 * best + 1]);
		if (q != best)
			m = fmin(m, (du * du + dv * dv - d1) / (2 * sep));
	}
	return m;
}

/* Cells whose centre is more than the half diagonal h inside or outside
 * the wall band are wholly void or wall (the distance to the Voronoi
 * boundary is 1-Lipschitz; an unlisted site's bisector is farther than
 * h + wall / 2 from the centre, so a list's overestimate is only ever
 * above that). */
static int classify_cells(struct hy_mfs *f, struct err *e)
{
	size_t nc = (size_t)f->gn * (size_t)f->gn;
	double h = f->g_mm * sqrt(0.5), half = 0.5 * f->wall_mm, eps = 1e-9 * f->side_mm;

	f->cls = mem_alloc(nc);
	if (!f->cls)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu MFS query cells", nc);
	for (size_t k = 0; k < nc; k++) {
		double d = edge_distance(f, k, ((double)(k % (size_t)f->gn) + 0.5) * f->g_mm,
					 ((double)(k / (size_t)f->gn) + 0.5) * f->g_mm);
		f->cls[k] = d - h > half + eps ? CELL_VOID : d + h < half - eps ? CELL_WALL
									 : CELL_TEST;
	}
	return 0;
}

int hy_mfs_new_voronoi(struct vec3 axis, struct vec3 origin_mm, double extent_mm,
		       double cell_mm, double wall_mm, uint64_t seed, struct hy_mfs **out,
		       struct err *e)
{
	struct hy_mfs *f = NULL;
	struct pointgrid g;
	double side;
	int rc;

	memset(&g, 0, sizeof g);
	if (!(cell_mm > 0) || !isfinite(cell_mm))
		return ERR_FIELD(e, "cell_mm", "MFS cell must be > 0 mm (got %g)", cell_mm);
	if (!(wall_mm >= 0) || !(wall_mm < cell_mm))
		return ERR_FIELD(e, "wall_mm", "MFS wall must be in [0, %g) mm (got %g)", cell_mm,
				 wall_mm);
	if (!(extent_mm > 0) || !isfinite(extent_mm))
		return ERR_FIELD(e, "extent_mm", "MFS extent must be > 0 mm (got %g)", extent_mm);
	if ((rc = mfs_alloc(axis, origin_mm, MFS_VORONOI, &f, e)) != 0)
		return rc;
	side = 2 * extent_mm;
	f->side_mm = side;
	f->wall_mm = wall_mm;
	f->wall2_mm2 = wall_mm * wall_mm;
	if ((rc = poisson2_sample(0, 0, side, side, cell_mm, NULL, NULL, seed, MFS_MAX_SITES,
				  &f->site, &f->nsite, e)) != 0) {
		err_prefix(e, "MFS sites");
		goto out;
	}
	if (f->nsite == 0) { /* a non-empty square always takes its first dart */
		rc = ERR_SET(e, ERR_INTERNAL, "no MFS sites");
		goto out;
	}
	/* query cells: cell / 3, coarser if the square needs too many */
	f->g_mm = cell_mm / MFS_CELLS_PER_SITE;
	if (side / f->g_mm > sqrt((double)MFS_MAX_QUERY_CELLS))
		f->g_mm = side / sqrt((double)MFS_MAX_QUERY_CELLS);
	f->gn = (int)ceil(side / f->g_mm);
	if (f->gn < 1)
		f->gn = 1;
	f->inv_g = 1 / f->g_mm;
	{
		struct box3 b = {{0, 0, 0}, {side, side, 0}};
		if ((rc = pointgrid_init(&g, b, cell_mm, MFS_MAX_QUERY_CELLS, e)) != 0)
			goto out;
		for (size_t i = 0; i < f->nsite; i++) {
			struct vec3 s = v3(f->site[2 * i], f->site[2 * i + 1], 0);
			if ((rc = pointgrid_insert(&g, s, e)) != 0)
				goto out;
		}
	}
	if ((rc = build_lists(f, &g, e)) != 0 || (rc = classify_cells(f, e)) != 0)
		goto out;
	*out = f;
	f = NULL;
out:
	pointgrid_fini(&g);
	hy_mfs_free(f);
	return rc;
}

static int voronoi_solid(const struct hy_mfs *f, struct vec3 p)
{
	double u = v3_dot(f->e1, p) - f->u0 + 0.5 * f->side_mm;
	double v = v3_dot(f->e2, p) - f->v0 + 0.5 * f->side_mm;
	const double *c;
	double d1 = INFINITY, s1u = 0, s1v = 0;
	size_t n, k, best = 0;
	int i, j;

	if (!(u >= 0 && u < f->side_mm && v >= 0 && v < f->side_mm))
		return 1; /* beyond the sampled square (also NaN) */
	i = (int)(u * f->inv_g);
	j = (int)(v * f->inv_g);
	if (i >= f->gn)
		i = f->gn - 1;
	if (j >= f->gn)
		j = f->gn - 1;
	k = (size_t)j * (size_t)f->gn + (size_t)i;
	if (f->cls[k] != CELL_TEST)
		return f->cls[k] == CELL_WALL;
	c = f->cand + 2 * (size_t)f->start[k];
	n = f->start[k + 1] - f->start[k];
	for (size_t q = 0; q < n; q++) {
		double du = c[2 * q] - u, dv = c[2 * q + 1] - v, d2 = du * du + dv * dv;
		if (d2 < d1) {
			d1 = d2;
			best = q;
		}
	}
	s1u = c[2 * best];
	s1v = c[2 * best + 1];
	for (size_t q = 0; q < n; q++) {
		double du = c[2 * q] - u, dv = c[2 * q + 1] - v, gap, su, sv;
		if (q == best)
			continue;
		gap = du * du + dv * dv - d1; /* dj^2 - d1^2 >= 0 */
		su = c[2 * q] - s1u;
		sv = c[2 * q + 1] - s1v;
		/* gap / (2 |sj - s1|) < wall / 2 */
		if (gap * gap < f->wall2_mm2 * (su * su + sv * sv))
			return 1;
	}
	return 0;
}

/* ---- template ---- */

static int positive_mod(long long a, int m)
{
	long long r = a % m;
	return (int)(r < 0 ? r + m : r);
}

/* Thicken the walls of f->mask thinner than wall_mm (file comment). */
static int thicken(struct hy_mfs *f, double wall_mm, struct err *e)
{
	double p = f->pitch_mm;
	/* dilation radius: (2 k + 1) pixels >= wall */
	int k = (int)ceil((wall_mm / p - 1) / 2 - 1e-9);
	int m = k + 2, pw, ph;
	size_t np;
	uint8_t *pad = NULL, *ridge = NULL;
	float *dv = NULL, *ds = NULL;
	struct edt_scratch es;
	double thin2 = (0.5 * wall_mm + 0.5 * p) * (0.5 * wall_mm + 0.5 * p);
	double grow2 = (k * p) * (k * p) * (1 + 1e-6);
	int rc = 0;

	if (k < 1)
		return 0; /* every wall is at least one pixel, already wall_mm */
	pw = f->tw + 2 * m;
	ph = f->th + 2 * m;
	np = (size_t)pw * (size_t)ph;
	if ((double)pw * ph > MFS_MAX_TEMPLATE_PX)
		return ERR_SET(e, ERR_LIMIT,
			       "MFS template of %dx%d pixels with a %g mm wall is too large", f->tw,
			       f->th, wall_mm);
	edt_scratch_init(&es);
	pad = mem_alloc(np);
	ridge = mem_calloc(np, 1);
	dv = mem_alloc(np * sizeof *dv);
	ds = mem_alloc(np * sizeof *ds);
	if (!pad || !ridge || !dv || !ds) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for the MFS template");
		goto out;
	}
	/* the tile with a periodic margin of m pixels; seeds = void */
	for (int y = 0; y < ph; y++)
		for (int x = 0; x < pw; x++)
			pad[(size_t)y * pw + x] =
				!f->mask[(size_t)positive_mod(y - m, f->th) * f->tw +
					 positive_mod(x - m, f->tw)];
	if ((rc = edt_sq(pad, (size_t)pw, pw, ph, p, p, dv, &es, e)) != 0)
		goto out;
	/* thin ridges: material, a local maximum of the distance to the void
	 * among its material 8-neighbours, less than half a wall deep */
	for (int y = 1; y < ph - 1; y++)
		for (int x = 1; x < pw - 1; x++) {
			size_t q = (size_t)y * pw + x;
			int top = 1;
			if (pad[q] || !(dv[q] < thin2))
				continue;
			for (int dy = -1; dy <= 1 && top; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					size_t o = (size_t)(y + dy) * pw + (x + dx);
					if (!pad[o] && dv[o] > dv[q]) {
						top = 0;
						break;
					}
				}
			ridge[q] = (uint8_t)top;
		}
	if ((rc = edt_sq(ridge, (size_t)pw, pw, ph, p, p, ds, &es, e)) != 0)
		goto out;
	for (int y = 0; y < f->th; y++)
		for (int x = 0; x < f->tw; x++)
			if (ds[(size_t)(y + m) * pw + (x + m)] <= grow2)
				f->mask[(size_t)y * f->tw + x] = 1;
out:
	edt_scratch_fini(&es);
	mem_free(pad);
	mem_free(ridge);
	mem_free(dv);
	mem_free(ds);
	return rc;
}

int hy_mfs_new_template(struct vec3 axis, struct vec3 origin_mm, const char *png_path,
			double template_mm, double wall_mm, struct hy_mfs **out,
			struct err *e)
{
	struct hy_mfs *f = NULL;
	struct raster *img = NULL;
	int rc;

	if (!(template_mm > 0) || !isfinite(template_mm))
		return ERR_FIELD(e, "template_mm", "MFS template pixel must be > 0 mm (got %g)",
				 template_mm);
	if (!(wall_mm >= 0) || !isfinite(wall_mm))
		return ERR_FIELD(e, "wall_mm", "MFS wall must be >= 0 mm (got %g)", wall_mm);
	if ((rc = mfs_alloc(axis, origin_mm, MFS_TEMPLATE, &f, e)) != 0)
		return rc;
	if ((rc = out_png_read_gray_file(png_path, &img, e)) != 0) {
		err_prefix(e, "MFS template");
		goto out;
	}
	f->tw = img->w;
	f->th = img->h;
	f->pitch_mm = template_mm;
	f->inv_pitch = 1 / template_mm;
	f->wall_template_mm = wall_mm;
	f->mask = mem_alloc((size_t)f->tw * (size_t)f->th);
	if (!f->mask) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a %dx%d MFS template", f->tw, f->th);
		goto out;
	}
	for (int y = 0; y < f->th; y++)
		for (int x = 0; x < f->tw; x++)
			f->mask[(size_t)y * f->tw + x] = img->px[(size_t)y * img->stride + x] > 127;
	if ((rc = thicken(f, wall_mm, e)) != 0)
		goto out;
	*out = f;
	f = NULL;
out:
	raster_free(img);
	hy_mfs_free(f);
	return rc;
}

static int template_solid(const struct hy_mfs *f, struct vec3 p)
{
	double u = (v3_dot(f->e1, p) - f->u0) * f->inv_pitch;
	double v = (v3_dot(f->e2, p) - f->v0) * f->inv_pitch;
	double fi = floor(u), fj = floor(v);
	int i, j;

	if (!(fabs(fi) < 1e15 && fabs(fj) < 1e15))
		return 1; /* not finite, or beyond any sensible tiling */
	i = positive_mod((long long)fi, f->tw);
	j = positive_mod((long long)fj, f->th);
	return f->mask[(size_t)(f->th - 1 - j) * f->tw + i];
}

int hy_mfs_solid(const struct hy_mfs *f, struct vec3 p)
{
	return f->kind == MFS_VORONOI ? voronoi_solid(f, p) : template_solid(f, p);
}
