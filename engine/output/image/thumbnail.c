/* thumbnail.c - software-rendered part previews (see image.h).
 *
 * One orthographic camera for every preview: it looks from the
 * front-right-top (azimuth 45 degrees between +x and -y, elevation 30
 * degrees) at the part; triangles are filled with edge functions at
 * sample centres of a 2x2 supersampled canvas with a float z-buffer, and
 * shaded two-sided Lambert (ambient 0.25) in resin orange.
 */
#include "engine/output/image/image.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/path.h"
#include "engine/geom/raster.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <string.h>

#define THUMB_SS 2          /* supersampling per axis */
#define THUMB_MAX_PX 4096   /* largest thumbnail side */
#define THUMB_MARGIN 0.06   /* free border, fraction of each side */
#define ACC_CELLS 128       /* voxel cells along the longest part side */

static const double resin_rgb[3] = {255, 128, 64}; /* Prusa Orange (#FF8040) */

struct view {
	struct vec3 right, up, fwd; /* camera frame; fwd points into the scene */
	struct vec3 light;          /* unit, towards the light */
	double scale;               /* canvas samples per mm */
	double off_u, off_v;        /* canvas position of the projected origin */
};

struct canvas {
	int w, h; /* samples */
	float *depth;
	uint8_t *rgb; /* 3 per sample */
	uint8_t *hit; /* 1 where something was drawn */
};

static void view_init(struct view *v)
{
	const double el = 30.0 * M_PI / 180.0, az = 45.0 * M_PI / 180.0;
	struct vec3 to_cam = v3(cos(el) * sin(az), -cos(el) * cos(az), sin(el));

	v->fwd = v3_scale(to_cam, -1);
	v->right = v3_normalize(v3_cross(v->fwd, v3(0, 0, 1)));
	v->up = v3_cross(v->right, v->fwd);
	/* key light above and to the left of the camera */
	v->light = v3_normalize(v3_add(v3_add(to_cam, v3_scale(v->up, 0.8)),
				       v3_scale(v->right, -0.5)));
}

static void project(const struct view *v, struct vec3 p, double *u, double *w, double *d)
{
	*u = v3_dot(p, v->right) * v->scale + v->off_u;
	*w = -v3_dot(p, v->up) * v->scale + v->off_v;
	*d = v3_dot(p, v->fwd);
}

/* Scale and offsets so the projected extents u_lo..u_hi (along right)
 * and w_lo..w_hi (along up), in mm, fill the canvas inside the margin,
 * centred. */
static void view_fit(struct view *v, double u_lo, double u_hi, double w_lo, double w_hi, int cw,
		     int ch)
{
	double du = u_hi - u_lo, dw = w_hi - w_lo;
	double su = du > 0 ? cw * (1 - 2 * THUMB_MARGIN) / du : 1e9;
	double sw = dw > 0 ? ch * (1 - 2 * THUMB_MARGIN) / dw : 1e9;

	v->scale = su < sw ? su : sw;
	if (!(v->scale < 1e8))
		v->scale = 1;
	/* u = x.right * s + off_u with centre -> cw/2; v = -(x.up) s + off_v */
	v->off_u = cw * 0.5 - 0.5 * (u_lo + u_hi) * v->scale;
	v->off_v = ch * 0.5 + 0.5 * (w_lo + w_hi) * v->scale;
}

/* Projected extents (camera right/up, mm) accumulated point by point. */
struct extent2 {
	double u_lo, u_hi, w_lo, w_hi;
};

static void extent_init(struct extent2 *x)
{
	x->u_lo = x->w_lo = DBL_MAX;
	x->u_hi = x->w_hi = -DBL_MAX;
}

static void extent_add(struct extent2 *x, const struct view *v, struct vec3 p)
{
	double pu = v3_dot(p, v->right), pw = v3_dot(p, v->up);

	x->u_lo = pu < x->u_lo ? pu : x->u_lo;
	x->u_hi = pu > x->u_hi ? pu : x->u_hi;
	x->w_lo = pw < x->w_lo ? pw : x->w_lo;
	x->w_hi = pw > x->w_hi ? pw : x->w_hi;
}

/* Add the 8 corners of box b. */
static void extent_add_box(struct extent2 *x, const struct view *v, struct box3 b)
{
	for (int k = 0; k < 8; k++)
		extent_add(x, v,
			   v3(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y,
			      k & 4 ? b.hi.z : b.lo.z));
}

static int canvas_init(struct canvas *c, int w, int h, struct err *e)
{
	size_t n = (size_t)w * (size_t)h;

	memset(c, 0, sizeof *c);
	c->w = w;
	c->h = h;
	c->depth = mem_alloc(n * sizeof *c->depth);
	c->rgb = mem_calloc(n, 3);
	c->hit = mem_calloc(n, 1);
	if (!c->depth || !c->rgb || !c->hit) {
		mem_free(c->depth);
		mem_free(c->rgb);
		mem_free(c->hit);
		return ERR_SET(e, ERR_NOMEM, "out of memory rendering a %d x %d thumbnail", w, h);
	}
	for (size_t i = 0; i < n; i++)
		c->depth[i] = FLT_MAX;
	return 0;
}

static void canvas_fini(struct canvas *c)
{
	mem_free(c->depth);
	mem_free(c->rgb);
	mem_free(c->hit);
}

static inline double min3(double a, double b, double c)
{
	double m = a < b ? a : b;
	return m < c ? m : c;
}

static inline double max3(double a, double b, double c)
{
	double m = a > b ? a : b;
	return m > c ? m : c;
}

/* Fill triangle abc (mm) with flat Lambert shading from its normal n
 * (any length; flipped towards the camera: two-sided). */
static void draw_triangle(struct canvas *c, const struct view *v, struct vec3 a, struct vec3 b,
			  struct vec3 p3, struct vec3 n)
{
	double ua, va, da, ub, vb, db, uc, vc, dc, area, shade;
	int x0, x1, y0, y1;
	uint8_t rgb[3];

	project(v, a, &ua, &va, &da);
	project(v, b, &ub, &vb, &db);
	project(v, p3, &uc, &vc, &dc);
	area = (ub - ua) * (vc - va) - (uc - ua) * (vb - va);
	if (area == 0 || !isfinite(area))
		return;
	n = v3_normalize(n);
	if (v3_dot(n, v->fwd) > 0)
		n = v3_scale(n, -1);
	shade = 0.25 + 0.75 * fmax(0.0, v3_dot(n, v->light));
	for (int k = 0; k < 3; k++)
		rgb[k] = (uint8_t)lround(fmin(255.0, resin_rgb[k] * shade));
	x0 = (int)floor(min3(ua, ub, uc));
	x1 = (int)ceil(max3(ua, ub, uc));
	y0 = (int)floor(min3(va, vb, vc));
	y1 = (int)ceil(max3(va, vb, vc));
	x0 = x0 < 0 ? 0 : x0;
	y0 = y0 < 0 ? 0 : y0;
	x1 = x1 > c->w - 1 ? c->w - 1 : x1;
	y1 = y1 > c->h - 1 ? c->h - 1 : y1;
	for (int y = y0; y <= y1; y++) {
		double py = y + 0.5;
		for (int x = x0; x <= x1; x++) {
			double px = x + 0.5;
			/* barycentric weights, positive inside for either winding */
			double w0 = ((ub - px) * (vc - py) - (uc - px) * (vb - py)) / area;
			double w1 = ((uc - px) * (va - py) - (ua - px) * (vc - py)) / area;
			double w2 = 1.0 - w0 - w1;
			size_t i;
			float d;
			if (w0 < 0 || w1 < 0 || w2 < 0)
				continue;
			d = (float)(w0 * da + w1 * db + w2 * dc);
			i = (size_t)y * (size_t)c->w + (size_t)x;
			if (d >= c->depth[i])
				continue;
			c->depth[i] = d;
			c->hit[i] = 1;
			memcpy(c->rgb + 3 * i, rgb, 3);
		}
	}
}

/* Average 2x2 samples into straight-alpha RGBA and encode. */
static int canvas_png(const struct canvas *c, int w, int h, struct buf *png, struct err *e)
{
	uint8_t *rgba = mem_alloc((size_t)w * (size_t)h * 4);
	int rc;

	if (!rgba)
		return ERR_SET(e, ERR_NOMEM, "out of memory rendering a %d x %d thumbnail", w, h);
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			unsigned sum[3] = {0, 0, 0}, hits = 0;
			uint8_t *o = rgba + 4 * ((size_t)y * (size_t)w + (size_t)x);
			for (int sy = 0; sy < THUMB_SS; sy++)
				for (int sx = 0; sx < THUMB_SS; sx++) {
					size_t i = (size_t)(y * THUMB_SS + sy) * (size_t)c->w +
						   (size_t)(x * THUMB_SS + sx);
					if (!c->hit[i])
						continue;
					hits++;
					for (int k = 0; k < 3; k++)
						sum[k] += c->rgb[3 * i + (size_t)k];
				}
			for (int k = 0; k < 3; k++)
				o[k] = hits ? (uint8_t)((sum[k] + hits / 2) / hits) : 0;
			o[3] = (uint8_t)((255 * hits + THUMB_SS * THUMB_SS / 2) /
					 (THUMB_SS * THUMB_SS));
		}
	rc = out_png_rgba(rgba, w, h, png, e);
	mem_free(rgba);
	return rc;
}

static int check_size(int w, int h, struct err *e)
{
	if (w < 1 || h < 1 || w > THUMB_MAX_PX || h > THUMB_MAX_PX)
		return ERR_SET(e, ERR_INTERNAL, "thumbnail size %d x %d outside 1..%d", w, h,
			       THUMB_MAX_PX);
	return 0;
}

/* Start a w x h rendering: size check, supersampled canvas, camera. */
static int render_begin(struct canvas *c, struct view *v, int w, int h, struct err *e)
{
	int rc = check_size(w, h, e);

	if (rc)
		return rc;
	rc = canvas_init(c, w * THUMB_SS, h * THUMB_SS, e);
	if (rc)
		return rc;
	view_init(v);
	return 0;
}

/* Finish it: downsample, encode into png, release the canvas. */
static int render_end(struct canvas *c, int w, int h, struct buf *png, struct err *e)
{
	int rc = canvas_png(c, w, h, png, e);

	canvas_fini(c);
	return rc;
}

int thumbnail_png_from_mesh(const struct mesh *m, int w, int h, struct buf *png, struct err *e)
{
	struct canvas c;
	struct view v;
	struct extent2 ext;
	struct box3 b = box3_empty();
	int rc = render_begin(&c, &v, w, h, e);

	if (rc)
		return rc;
	extent_init(&ext);
	/* fit the projected vertices, not their box: a tighter frame */
	for (size_t i = 0; i < m->nt; i++)
		for (int k = 0; k < 3; k++)
			if (m->tri[3 * i + (size_t)k] < m->nv) {
				box3_add(&b, m->v[m->tri[3 * i + (size_t)k]]);
				extent_add(&ext, &v, m->v[m->tri[3 * i + (size_t)k]]);
			}
	if (!box3_is_empty(b)) {
		view_fit(&v, ext.u_lo, ext.u_hi, ext.w_lo, ext.w_hi, c.w, c.h);
		for (size_t i = 0; i < m->nt; i++) {
			const uint32_t *t = m->tri + 3 * i;
			struct vec3 a, bb, cc;
			if (t[0] >= m->nv || t[1] >= m->nv || t[2] >= m->nv)
				continue;
			a = m->v[t[0]];
			bb = m->v[t[1]];
			cc = m->v[t[2]];
			draw_triangle(&c, &v, a, bb, cc, v3_cross(v3_sub(bb, a), v3_sub(cc, a)));
		}
	}
	return render_end(&c, w, h, png, e);
}

/* ---- Layer-based fallback: a coarse voxel grid ---- */

struct thumb_acc {
	struct box3 box; /* grid origin box.lo; cell size `cell` */
	double cell;     /* mm */
	int nx, ny, nz;
	uint8_t *vox;    /* nx * ny * nz, index (k * ny + j) * nx + i */
};

int thumb_acc_new(struct box3 part_bbox, struct thumb_acc **out, struct err *e)
{
	struct vec3 size = box3_size(part_bbox);
	double longest = fmax(size.x, fmax(size.y, size.z));
	struct thumb_acc *t;

	if (box3_is_empty(part_bbox) || !(longest > 0) || !isfinite(longest))
		return ERR_SET(e, ERR_INTERNAL, "thumbnail box is empty");
	t = mem_calloc(1, sizeof *t);
	if (!t)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the thumbnail grid");
	t->box = part_bbox;
	t->cell = longest / ACC_CELLS;
	t->nx = (int)ceil(size.x / t->cell - 1e-9);
	t->ny = (int)ceil(size.y / t->cell - 1e-9);
	t->nz = (int)ceil(size.z / t->cell - 1e-9);
	t->nx = t->nx < 1 ? 1 : t->nx;
	t->ny = t->ny < 1 ? 1 : t->ny;
	t->nz = t->nz < 1 ? 1 : t->nz;
	t->vox = mem_calloc((size_t)t->nx * (size_t)t->ny, (size_t)t->nz);
	if (!t->vox) {
		mem_free(t);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the thumbnail grid");
	}
	*out = t;
	return 0;
}

void thumb_acc_free(struct thumb_acc *t)
{
	if (!t)
		return;
	mem_free(t->vox);
	mem_free(t);
}

size_t thumb_acc_mask_bytes(const struct thumb_acc *t)
{
	return (size_t)t->nx * (size_t)t->ny;
}

/* Sample height of cell row k: the middle of its part inside the box
 * (the top row may stick out above the part). */
static double z_sample(const struct thumb_acc *t, int k)
{
	double lo = t->box.lo.z + k * t->cell, hi = fmin(lo + t->cell, t->box.hi.z);
	return 0.5 * (lo + hi);
}

/* Cell rows k0..k1-1 whose sample height lies in [z_lo, z_hi). */
static void z_cells(const struct thumb_acc *t, double z_lo, double z_hi, int *k0, int *k1)
{
	int k = (int)floor((z_lo - t->box.lo.z) / t->cell) - 1;

	if (k < 0)
		k = 0;
	while (k < t->nz && z_sample(t, k) < z_lo)
		k++;
	*k0 = k;
	while (k < t->nz && z_sample(t, k) < z_hi)
		k++;
	*k1 = k;
}

int thumb_acc_wants(const struct thumb_acc *t, double z_lo_mm, double z_hi_mm)
{
	int k0, k1;

	z_cells(t, z_lo_mm, z_hi_mm, &k0, &k1);
	return k0 < k1;
}

/* Region -> mask: rasterise it onto the cell grid itself (binary, cell
 * centres) through a map whose pixels are the cells. */
static int reduce_region(const struct thumb_acc *t, const struct paths *region, uint8_t *mask,
			 struct err *e)
{
	struct raster r;
	struct raster_map map;
	int rc;

	memset(&map, 0, sizeof map);
	map.a[0][0] = map.a[1][1] = 1.0 / t->cell;
	map.b[0] = -t->box.lo.x / t->cell;
	map.b[1] = -t->box.lo.y / t->cell;
	r.w = t->nx;
	r.h = t->ny;
	r.stride = (size_t)t->nx;
	r.px = mask;
	memset(mask, 0, thumb_acc_mask_bytes(t));
	rc = slice_rasterize(region, &map, 0, &r, e);
	if (rc)
		return rc;
	for (size_t i = 0; i < thumb_acc_mask_bytes(t); i++)
		mask[i] = mask[i] >= 128;
	return 0;
}

/* Raster -> mask: sample pixels at about half a cell's spacing. */
static void reduce_raster(const struct thumb_acc *t, const struct raster *r,
			  const struct raster_map *map, uint8_t *mask)
{
	double px_mm = sqrt(raster_map_pixel_area_mm2(map));
	int step = px_mm > 0 ? (int)floor(0.5 * t->cell / px_mm) : 1;

	memset(mask, 0, thumb_acc_mask_bytes(t));
	if (step < 1)
		step = 1;
	for (int y = step / 2; y < r->h; y += step) {
		const uint8_t *row = r->px + (size_t)y * r->stride;
		for (int x = step / 2; x < r->w; x += step) {
			double xm, ym;
			int i, j;
			if (row[x] < 128 || raster_map_invert(map, x + 0.5, y + 0.5, &xm, &ym))
				continue;
			i = (int)floor((xm - t->box.lo.x) / t->cell);
			j = (int)floor((ym - t->box.lo.y) / t->cell);
			if (i >= 0 && i < t->nx && j >= 0 && j < t->ny)
				mask[(size_t)j * (size_t)t->nx + (size_t)i] = 1;
		}
	}
}

int thumb_acc_reduce(const struct thumb_acc *t, const struct layer *ly, const struct raster *r,
		     const struct raster_map *map, uint8_t *mask, struct err *e)
{
	if (ly && ly->region.n > 0)
		return reduce_region(t, &ly->region, mask, e);
	if (r && map) {
		reduce_raster(t, r, map, mask);
		return 0;
	}
	memset(mask, 0, thumb_acc_mask_bytes(t));
	return 0;
}

void thumb_acc_merge(struct thumb_acc *t, double z_lo_mm, double z_hi_mm, const uint8_t *mask)
{
	size_t n = thumb_acc_mask_bytes(t);
	int k0, k1;

	z_cells(t, z_lo_mm, z_hi_mm, &k0, &k1);
	for (int k = k0; k < k1; k++) {
		uint8_t *dst = t->vox + (size_t)k * n;
		for (size_t i = 0; i < n; i++)
			dst[i] |= mask[i];
	}
}

int thumb_acc_layer(struct thumb_acc *t, const struct layer *ly, const struct raster_map *map,
		    struct err *e)
{
	double z_lo = ly->z_top_mm - ly->height_mm;
	uint8_t *mask;
	int rc;

	if (!thumb_acc_wants(t, z_lo, ly->z_top_mm))
		return 0;
	mask = mem_alloc(thumb_acc_mask_bytes(t));
	if (!mask)
		return ERR_SET(e, ERR_NOMEM, "out of memory for the thumbnail grid");
	rc = thumb_acc_reduce(t, ly, ly->raster, map, mask, e);
	if (!rc)
		thumb_acc_merge(t, z_lo, ly->z_top_mm, mask);
	mem_free(mask);
	return rc;
}

static int filled(const struct thumb_acc *t, int i, int j, int k)
{
	if (i < 0 || j < 0 || k < 0 || i >= t->nx || j >= t->ny || k >= t->nz)
		return 0;
	return t->vox[((size_t)k * (size_t)t->ny + (size_t)j) * (size_t)t->nx + (size_t)i];
}

/* Draw the face of cell (i,j,k) on the side `axis` (0 x, 1 y, 2 z) at
 * offset `side` (0 low, 1 high). */
static void draw_face(struct canvas *c, const struct view *v, const struct thumb_acc *t, int i,
		      int j, int k, int axis, int side)
{
	struct vec3 lo = v3(t->box.lo.x + i * t->cell, t->box.lo.y + j * t->cell,
			    t->box.lo.z + k * t->cell);
	struct vec3 q[4], n = v3(0, 0, 0), du = v3(0, 0, 0), dv = v3(0, 0, 0);
	double s = t->cell;

	if (axis == 0) {
		lo.x += side * s;
		n.x = side ? 1 : -1;
		du.y = s;
		dv.z = s;
	} else if (axis == 1) {
		lo.y += side * s;
		n.y = side ? 1 : -1;
		du.x = s;
		dv.z = s;
	} else {
		lo.z += side * s;
		n.z = side ? 1 : -1;
		du.x = s;
		dv.y = s;
	}
	q[0] = lo;
	q[1] = v3_add(lo, du);
	q[2] = v3_add(q[1], dv);
	q[3] = v3_add(lo, dv);
	draw_triangle(c, v, q[0], q[1], q[2], n);
	draw_triangle(c, v, q[0], q[2], q[3], n);
}

int thumb_acc_png(const struct thumb_acc *t, int w, int h, struct buf *png, struct err *e)
{
	struct canvas c;
	struct view v;
	struct extent2 ext;
	int rc = render_begin(&c, &v, w, h, e), dir[3];
	int lo[3] = {INT_MAX, INT_MAX, INT_MAX}, hi[3] = {-1, -1, -1};

	if (rc)
		return rc;
	extent_init(&ext);
	/* fit the box of the filled cells (one pass, then 8 corners) */
	for (int k = 0; k < t->nz; k++)
		for (int j = 0; j < t->ny; j++)
			for (int i = 0; i < t->nx; i++)
				if (filled(t, i, j, k)) {
					lo[0] = i < lo[0] ? i : lo[0];
					lo[1] = j < lo[1] ? j : lo[1];
					lo[2] = k < lo[2] ? k : lo[2];
					hi[0] = i > hi[0] ? i : hi[0];
					hi[1] = j > hi[1] ? j : hi[1];
					hi[2] = k > hi[2] ? k : hi[2];
				}
	if (hi[0] >= 0) {
		struct box3 fb;
		fb.lo = v3(t->box.lo.x + lo[0] * t->cell, t->box.lo.y + lo[1] * t->cell,
			   t->box.lo.z + lo[2] * t->cell);
		fb.hi = v3(t->box.lo.x + (hi[0] + 1) * t->cell, t->box.lo.y + (hi[1] + 1) * t->cell,
			   t->box.lo.z + (hi[2] + 1) * t->cell);
		extent_add_box(&ext, &v, fb);
	} else {
		extent_add_box(&ext, &v, t->box); /* nothing filled */
	}
	view_fit(&v, ext.u_lo, ext.u_hi, ext.w_lo, ext.w_hi, c.w, c.h);
	/* only faces turned towards the camera can be seen */
	dir[0] = v.fwd.x < 0 ? 1 : 0;
	dir[1] = v.fwd.y < 0 ? 1 : 0;
	dir[2] = v.fwd.z < 0 ? 1 : 0;
	for (int k = 0; k < t->nz; k++)
		for (int j = 0; j < t->ny; j++)
			for (int i = 0; i < t->nx; i++) {
				if (!filled(t, i, j, k))
					continue;
				if (!filled(t, i + (dir[0] ? 1 : -1), j, k))
					draw_face(&c, &v, t, i, j, k, 0, dir[0]);
				if (!filled(t, i, j + (dir[1] ? 1 : -1), k))
					draw_face(&c, &v, t, i, j, k, 1, dir[1]);
				if (!filled(t, i, j, k + (dir[2] ? 1 : -1)))
					draw_face(&c, &v, t, i, j, k, 2, dir[2]);
			}
	return render_end(&c, w, h, png, e);
}
