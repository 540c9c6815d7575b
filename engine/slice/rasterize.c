/* rasterize.c - regions -> pixels (slice_rasterize, slice_coverage).
 *
 * Exact-area anti-aliasing with signed cover/area cells, as font
 * rasterisers do: every edge deposits, in each pixel it crosses, the
 * signed area of the pixel to its right ("area") and its signed height
 * ("cover", carried to every pixel further right).  A row is then swept
 * left to right: between cells the coverage is the running cover, so
 * interior runs are memset, and the work is O(edge cells + rows) plus
 * the bytes written.  Binary mode deposits one +-1 event per edge and
 * pixel-centre row.  Maths and proofs: docs/slicing.md "Rasteriser".
 */
#include "engine/slice/slice.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct cell {
	int32_t x, y;
	double cover; /* signed height carried to pixels right of x */
	double area;  /* signed area of pixel x right of the edge pieces */
};

struct cells {
	struct cell *v;
	size_t n, cap;
	int w;        /* image width: cells at x >= w are dropped */
	int ylo, yhi; /* rows handled: [ylo, yhi) */
	int nomem;
};

struct target {
	uint8_t *u8;  /* one of u8 / f */
	float *f;
	size_t stride; /* elements per row */
	int binary;
};

static void cell_add(struct cells *cs, int x, int y, double cover, double area)
{
	struct cell *c;

	if (cs->n && cs->v[cs->n - 1].x == x && cs->v[cs->n - 1].y == y) {
		cs->v[cs->n - 1].cover += cover;
		cs->v[cs->n - 1].area += area;
		return;
	}
	if (cs->n == cs->cap) {
		void *arr = cs->v;
		if (mem_grow(&arr, &cs->cap, cs->n + 1, sizeof *cs->v)) {
			cs->nomem = 1;
			return;
		}
		cs->v = arr;
	}
	c = &cs->v[cs->n++];
	c->x = x;
	c->y = y;
	c->cover = cover;
	c->area = area;
}

/* The part of an edge inside row j: x from xa to xb (any order), signed
 * height dy.  Pieces left of the image act on every visible pixel of the
 * row (one cell at x = 0 with full area); pieces right of it on none. */
static void row_piece(struct cells *cs, int j, double xa, double xb, double dy)
{
	double w = cs->w, span, slope, left, done;
	int i, last;

	if (xa > xb) {
		double t = xa;
		xa = xb;
		xb = t;
	}
	if (xb <= 0) {
		cell_add(cs, 0, j, dy, dy);
		return;
	}
	if (xa >= w)
		return;
	span = xb - xa;
	if (xa < 0) { /* split off the part left of the image */
		double d = dy * (-xa / span);
		cell_add(cs, 0, j, d, d);
		dy -= d;
		span = xb;
		xa = 0;
	}
	if (xb > w) { /* drop the part right of it */
		dy -= dy * ((xb - w) / span);
		span = w - xa;
		xb = w;
	}
	i = (int)floor(xa);
	last = (int)ceil(xb) - 1;
	if (last < i)
		last = i; /* vertical piece on a pixel boundary */
	if (i == last) {
		cell_add(cs, i, j, dy, dy * (1.0 - ((xa - i) + (xb - i)) * 0.5));
		return;
	}
	slope = dy / span;
	left = (i + 1 - xa) * slope;
	cell_add(cs, i, j, left, left * (1.0 - (xa - i + 1.0) * 0.5));
	done = left;
	for (int c = i + 1; c < last; c++) {
		cell_add(cs, c, j, slope, slope * 0.5);
		done += slope;
	}
	left = dy - done; /* the rest, so the covers sum to dy exactly */
	cell_add(cs, last, j, left, left * (1.0 - (xb - last) * 0.5));
}

/* Exact-area cells of the edge (u0, v0) -> (u1, v1), pixel units. */
static void edge_area(struct cells *cs, double u0, double v0, double u1, double v1)
{
	double sign = 1, dudv, vt, vb;
	int j0, j1;

	if (v0 == v1)
		return; /* horizontal edges cover nothing */
	if (v0 > v1) {
		double t = u0;
		u0 = u1, u1 = t;
		t = v0, v0 = v1, v1 = t;
		sign = -1;
	}
	if (v1 <= cs->ylo || v0 >= cs->yhi)
		return;
	dudv = (u1 - u0) / (v1 - v0);
	vt = v0 < cs->ylo ? cs->ylo : v0;
	vb = v1 > cs->yhi ? cs->yhi : v1;
	j0 = (int)floor(vt);
	j1 = (int)ceil(vb) - 1;
	for (int j = j0; j <= j1; j++) {
		double ya = j > vt ? j : vt, yb = j + 1 < vb ? j + 1 : vb;
		double xa = ya == v0 ? u0 : u0 + (ya - v0) * dudv;
		double xb = yb == v1 ? u1 : u0 + (yb - v0) * dudv;
		if (yb > ya)
			row_piece(cs, j, xa, xb, (yb - ya) * sign);
	}
}

/* Binary events: for every pixel-centre row v = j + 0.5 with
 * min(v0,v1) <= v < max(v0,v1) (half-open, so a vertex on a centre row
 * is counted once), +-1 from the first pixel whose centre lies right of
 * the crossing. */
static void edge_centre(struct cells *cs, double u0, double v0, double u1, double v1)
{
	double sign = 1, dudv;
	int j0, j1;

	if (v0 == v1)
		return;
	if (v0 > v1) {
		double t = u0;
		u0 = u1, u1 = t;
		t = v0, v0 = v1, v1 = t;
		sign = -1;
	}
	dudv = (u1 - u0) / (v1 - v0);
	j0 = (int)ceil(v0 - 0.5);
	j1 = (int)ceil(v1 - 0.5) - 1;
	if (j0 < cs->ylo)
		j0 = cs->ylo;
	if (j1 >= cs->yhi)
		j1 = cs->yhi - 1;
	for (int j = j0; j <= j1; j++) {
		double uc = u0 + (j + 0.5 - v0) * dudv;
		double xi = floor(uc - 0.5) + 1;
		if (xi >= cs->w)
			continue;
		cell_add(cs, xi < 0 ? 0 : (int)xi, j, sign, sign);
	}
}

static int cell_cmp_x(const void *a, const void *b)
{
	const struct cell *p = a, *q = b;
	return (p->x > q->x) - (p->x < q->x);
}

static void sort_row(struct cell *c, size_t n)
{
	if (n > 24) {
		qsort(c, n, sizeof *c, cell_cmp_x);
		return;
	}
	for (size_t i = 1; i < n; i++) {
		struct cell t = c[i];
		size_t k = i;
		while (k > 0 && c[k - 1].x > t.x) {
			c[k] = c[k - 1];
			k--;
		}
		c[k] = t;
	}
}

/* Write coverage |acc| (nonzero rule, clamped to 1) to pixels [x0, x1) of
 * row j, keeping the larger of old and new. */
static void put_span(const struct target *t, int j, int x0, int x1, double acc)
{
	double cov = fabs(acc);

	if (x1 <= x0)
		return;
	if (t->binary)
		cov = cov > 0.5 ? 1.0 : 0.0;
	else if (cov > 1.0)
		cov = 1.0;
	if (t->u8) {
		uint8_t v = (uint8_t)(cov * 255.0 + 0.5), *row = t->u8 + (size_t)j * t->stride;
		if (v == 0)
			return;
		if (v == 255) {
			memset(row + x0, 255, (size_t)(x1 - x0));
			return;
		}
		for (int x = x0; x < x1; x++)
			if (row[x] < v)
				row[x] = v;
	} else {
		float v = (float)cov, *row = t->f + (size_t)j * t->stride;
		if (v == 0)
			return;
		for (int x = x0; x < x1; x++)
			if (row[x] < v)
				row[x] = v;
	}
}

static int render(const struct paths *region, const struct raster_map *map, int w, int h,
		  const struct target *t, struct err *e)
{
	struct cells cs;
	struct cell *sorted = NULL;
	double *uv = NULL, umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
	double a00 = map->a[0][0] / GEOM_NM_PER_MM, a01 = map->a[0][1] / GEOM_NM_PER_MM;
	double a10 = map->a[1][0] / GEOM_NM_PER_MM, a11 = map->a[1][1] / GEOM_NM_PER_MM;
	double det = map->a[0][0] * map->a[1][1] - map->a[0][1] * map->a[1][0];
	size_t npts = paths_point_count(region), *start = NULL;
	int xlo, xhi, rc = 0;

	memset(&cs, 0, sizeof cs);
	if (!(det != 0) || !isfinite(det) || !isfinite(map->b[0]) || !isfinite(map->b[1]))
		return ERR_SET(e, ERR_PARAM, "raster map is singular or not finite");
	if (npts == 0)
		return 0;
	uv = mem_alloc(2 * npts * sizeof *uv);
	if (!uv) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory rasterising %zu points", npts);
		goto out;
	}
	for (size_t k = 0, n = 0; k < region->n; k++) {
		for (size_t i = 0; i < region->v[k].n; i++, n++) {
			double x = (double)region->v[k].pts[i].x, y = (double)region->v[k].pts[i].y;
			double u = a00 * x + a01 * y + map->b[0], v = a10 * x + a11 * y + map->b[1];
			uv[2 * n] = u;
			uv[2 * n + 1] = v;
			umin = fmin(umin, u), umax = fmax(umax, u);
			vmin = fmin(vmin, v), vmax = fmax(vmax, v);
		}
	}
	/* Work only on the region's bbox rows and columns. */
	if (!(umax > 0 && vmax > 0 && umin < w && vmin < h))
		goto out;
	cs.w = w;
	cs.ylo = vmin <= 0 ? 0 : (int)floor(vmin);
	cs.yhi = vmax >= h ? h : (int)ceil(vmax);
	xlo = umin <= 0 ? 0 : (int)floor(umin);
	xhi = umax >= w ? w : (int)ceil(umax);
	for (size_t k = 0, n = 0; k < region->n; k++) {
		size_t m = region->v[k].n;
		const double *p = uv + 2 * n;
		if (m >= 2) {
			for (size_t i = 0, j = m - 1; i < m; j = i++) {
				if (t->binary)
					edge_centre(&cs, p[2 * j], p[2 * j + 1], p[2 * i], p[2 * i + 1]);
				else
					edge_area(&cs, p[2 * j], p[2 * j + 1], p[2 * i], p[2 * i + 1]);
			}
		}
		n += m;
	}
	if (cs.nomem) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory rasterising (%zu cells)", cs.n);
		goto out;
	}
	/* Counting sort by row, then by x within each row. */
	start = mem_calloc((size_t)(cs.yhi - cs.ylo) + 2, sizeof *start);
	sorted = mem_alloc((cs.n ? cs.n : 1) * sizeof *sorted);
	if (!start || !sorted) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory sorting %zu raster cells", cs.n);
		goto out;
	}
	for (size_t i = 0; i < cs.n; i++)
		start[cs.v[i].y - cs.ylo + 1]++;
	for (int j = 0; j <= cs.yhi - cs.ylo; j++)
		start[j + 1] += start[j];
	for (size_t i = 0; i < cs.n; i++)
		sorted[start[cs.v[i].y - cs.ylo]++] = cs.v[i];
	/* start[r] now holds the end of row r; rows are consecutive. */
	for (int j = cs.ylo, r = 0; j < cs.yhi; j++, r++) {
		size_t b = r ? start[r - 1] : 0, n = start[r] - b;
		struct cell *c = sorted + b;
		double acc = 0;
		int x = xlo;

		sort_row(c, n);
		for (size_t i = 0; i < n;) {
			int cx = c[i].x;
			double cover = 0, area = 0;
			for (; i < n && c[i].x == cx; i++) {
				cover += c[i].cover;
				area += c[i].area;
			}
			put_span(t, j, x, cx, acc);
			put_span(t, j, cx, cx + 1, acc + area);
			acc += cover;
			x = cx + 1;
		}
		put_span(t, j, x, xhi, acc);
	}
out:
	mem_free(uv);
	mem_free(cs.v);
	mem_free(sorted);
	mem_free(start);
	return rc;
}

int slice_rasterize(const struct paths *region, const struct raster_map *map, int antialias,
		    struct raster *r, struct err *e)
{
	struct target t = {r->px, NULL, r->stride, !antialias};

	return render(region, map, r->w, r->h, &t, e);
}

int slice_coverage(const struct paths *region, const struct raster_map *map, float *cov, int w,
		   int h, size_t stride, struct err *e)
{
	struct target t = {NULL, cov, stride, 0};

	if (w < 1 || h < 1 || stride < (size_t)w)
		return ERR_SET(e, ERR_PARAM, "coverage image %dx%d (stride %zu) is invalid", w, h,
			       stride);
	return render(region, map, w, h, &t, e);
}
