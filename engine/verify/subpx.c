/* subpx.c - sub-pixel layer regions and overhang distances (subpx.h). */
#include "engine/verify/subpx.h"

#include <math.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/verify/corner.h"

int verify_subpx_fits_size(struct verify_subpx_fits *f, size_t pixels, size_t grey)
{
	if (pixels > f->at_cap) {
		mem_free(f->at);
		f->at = mem_alloc(pixels * sizeof *f->at);
		f->at_cap = f->at ? pixels : 0;
		f->n = 0;
		if (!f->at)
			return ERR_NOMEM;
		for (size_t i = 0; i < pixels; i++)
			atomic_init(&f->at[i], -1);
	}
	/* a pixel two threads fit at once takes two slots: room for a few */
	return mem_grow((void **)&f->fit, &f->cap, grey + grey / 16 + 64, sizeof *f->fit);
}

void verify_subpx_fits_reset(struct verify_subpx_fits *f)
{
	size_t n = atomic_load(&f->n);

	for (size_t k = 0; k < n && k < f->cap; k++)
		atomic_store_explicit(&f->at[f->fit[k].px], -1, memory_order_relaxed);
	atomic_store(&f->n, 0);
}

void verify_subpx_fits_fini(struct verify_subpx_fits *f)
{
	mem_free(f->at);
	mem_free(f->fit);
	memset(f, 0, sizeof *f);
}

/* The corner fit of grey pixel (x, y), from im's fits when it holds it
 * (storing it there when made).  Safe on several threads: a slot is
 * filled before its index is published (release), read after (acquire);
 * a pixel fitted by two threads at once keeps the first index stored. */
static void corner_of(const struct verify_subpx_img *im, int x, int y, struct verify_corner *k)
{
	struct verify_subpx_fits *f = im->fits;
	size_t px, slot;
	int32_t at, none = -1;

	if (!f) {
		verify_corner_fit(im, x, y, k);
		return;
	}
	px = (size_t)(y - im->y0) * (size_t)im->w + (size_t)(x - im->x0);
	at = atomic_load_explicit(&f->at[px], memory_order_acquire);
	if (at >= 0) {
		*k = f->fit[at].k;
		return;
	}
	verify_corner_fit(im, x, y, k);
	slot = atomic_fetch_add_explicit(&f->n, 1, memory_order_relaxed);
	if (slot < f->cap) {
		f->fit[slot].px = px;
		f->fit[slot].k = *k;
		atomic_compare_exchange_strong_explicit(&f->at[px], &none, (int32_t)slot,
							memory_order_release, memory_order_relaxed);
	}
}

int verify_subpx_gray(const struct verify_subpx_img *im, int x, int y)
{
	int cx = x - im->x0, cy = y - im->y0;

	if (cx < 0 || cy < 0 || cx >= im->w || cy >= im->h)
		return 0;
	return im->gray[(size_t)cy * (size_t)im->w + (size_t)cx];
}

/* Offset d (pixels) of the line n.u = d from the centre such that the
 * part n.u <= d of the unit square around the centre has area c; n is a
 * unit vector.  With a >= b the absolute components and s = (a + b) / 2,
 * the area is (d + s)^2 / (2ab) while the line cuts one corner off
 * (d <= b - s), 1/2 + d/a across the middle, and symmetric at the far
 * corner: invert piecewise. */
static double edge_offset(double nx, double ny, double c)
{
	double a = fabs(nx), b = fabs(ny), s, t;

	if (b > a) {
		double tmp = a;
		a = b;
		b = tmp;
	}
	s = (a + b) / 2;
	t = a > 0 ? b / (2 * a) : 0;
	if (b > 1e-12 && c < t)
		return -s + sqrt(2 * a * b * c);
	if (b > 1e-12 && c > 1 - t)
		return s - sqrt(2 * a * b * (1 - c));
	return a * (c - 0.5);
}

void verify_subpx_clip(double *ux, double *uy, int *n, double nx, double ny, double d)
{
	double ox[8], oy[8];
	int m = 0;

	for (int i = 0; i < *n; i++) {
		int j = (i + 1) % *n;
		double fi = nx * ux[i] + ny * uy[i] - d, fj = nx * ux[j] + ny * uy[j] - d;
		if (fi <= 0 && m < 8) {
			ox[m] = ux[i];
			oy[m++] = uy[i];
		}
		if (((fi < 0 && fj > 0) || (fi > 0 && fj < 0)) && m < 8) {
			double t = fi / (fi - fj);
			ox[m] = ux[i] + t * (ux[j] - ux[i]);
			oy[m++] = uy[i] + t * (uy[j] - uy[i]);
		}
	}
	for (int i = 0; i < m; i++) {
		ux[i] = ox[i];
		uy[i] = oy[i];
	}
	*n = m;
}

/* Unit normal from solid to void of pixel (x, y) by the isotropic Sobel
 * gradient; 0 when the gradient vanishes. */
static int sobel_normal(const struct verify_subpx_img *im, int x, int y, double *nx, double *ny)
{
	const double r2 = 1.4142135623730951;
	double cw[3][3], gx, gy, gl;

	for (int j = -1; j <= 1; j++)
		for (int i = -1; i <= 1; i++)
			cw[j + 1][i + 1] = verify_subpx_gray(im, x + i, y + j) / 255.0;
	gx = (cw[0][2] + r2 * cw[1][2] + cw[2][2]) - (cw[0][0] + r2 * cw[1][0] + cw[2][0]);
	gy = (cw[2][0] + r2 * cw[2][1] + cw[2][2]) - (cw[0][0] + r2 * cw[0][1] + cw[0][2]);
	gl = sqrt(gx * gx + gy * gy);
	if (gl < 1e-9)
		return 0;
	*nx = -gx / gl;
	*ny = -gy / gl;
	return 1;
}

int verify_subpx_line(const struct verify_subpx_img *im, int x, int y, double *nx, double *ny,
		      double *d)
{
	int g = verify_subpx_gray(im, x, y);

	if (g == 0 || g == 255 || !sobel_normal(im, x, y, nx, ny))
		return 0;
	*d = edge_offset(*nx, *ny, g / 255.0);
	return 1;
}

/* The unit square centred on the origin clipped to n.u <= d for each of
 * the nh half-planes, to mm at pixel (x, y); 0 when empty. */
static int square_part(const struct verify_subpx_img *im, int x, int y, const double *nx,
		       const double *ny, const double *d, int nh, struct verify_subpx_poly *out)
{
	double ux[8] = {-0.5, 0.5, 0.5, -0.5}, uy[8] = {-0.5, -0.5, 0.5, 0.5};
	int n = 4;

	for (int k = 0; k < nh && n; k++)
		verify_subpx_clip(ux, uy, &n, nx[k], ny[k], d[k]);
	out->n = n;
	for (int i = 0; i < n; i++) {
		out->x[i] = (x + ux[i]) * im->px_mm;
		out->y[i] = (y + uy[i]) * im->py_mm;
	}
	return n > 0;
}

void verify_subpx_region(const struct verify_subpx_img *im, int x, int y,
			 struct verify_subpx_region *out)
{
	struct verify_corner k;
	double nx, ny, d;
	int g = verify_subpx_gray(im, x, y);

	out->parts = 0;
	out->has_tip = 0;
	out->corner = 0;
	if (g == 0)
		return;
	if (g == 255) {
		out->parts = square_part(im, x, y, NULL, NULL, NULL, 0, &out->part[0]);
		return;
	}
	k.n = 0;
	if (!im->one_edge)
		corner_of(im, x, y, &k);
	if (k.n) {
		out->corner = 1;
		if (k.convex) {
			out->parts = square_part(im, x, y, k.nx, k.ny, k.d, k.n, &out->part[0]);
		} else {
			/* the union of the square's parts in each half-plane */
			for (int e = 0; e < k.n; e++)
				out->parts += square_part(im, x, y, &k.nx[e], &k.ny[e], &k.d[e], 1,
							  &out->part[out->parts]);
		}
		/* the corner itself, inside the pixel */
		{
			double det = k.nx[0] * k.ny[1] - k.ny[0] * k.nx[1], tx, ty;
			if (fabs(det) > 1e-9) {
				tx = (k.d[0] * k.ny[1] - k.d[1] * k.ny[0]) / det;
				ty = (k.nx[0] * k.d[1] - k.nx[1] * k.d[0]) / det;
				if (fabs(tx) <= 0.5 && fabs(ty) <= 0.5) {
					out->has_tip = 1;
					out->tip_x = (x + tx) * im->px_mm;
					out->tip_y = (y + ty) * im->py_mm;
				}
			}
		}
		return;
	}
	if (verify_subpx_line(im, x, y, &nx, &ny, &d)) {
		out->parts = square_part(im, x, y, &nx, &ny, &d, 1, &out->part[0]);
		return;
	}
	/* no direction: a centred square of the same area */
	{
		double h = 0.5 * sqrt(g / 255.0);
		double sx[4] = {-h, h, h, -h}, sy[4] = {-h, -h, h, h};
		out->parts = 1;
		out->part[0].n = 4;
		for (int i = 0; i < 4; i++) {
			out->part[0].x[i] = (x + sx[i]) * im->px_mm;
			out->part[0].y[i] = (y + sy[i]) * im->py_mm;
		}
	}
}

static double seg_dist2(double px, double py, double ax, double ay, double bx, double by)
{
	double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy, t = 0;

	if (l2 > 0) {
		t = ((px - ax) * dx + (py - ay) * dy) / l2;
		t = t < 0 ? 0 : t > 1 ? 1 : t;
	}
	dx = ax + t * dx - px;
	dy = ay + t * dy - py;
	return dx * dx + dy * dy;
}

double verify_subpx_poly_dist(const struct verify_subpx_poly *p, double x_mm, double y_mm)
{
	double area = 0, best = INFINITY;
	int inside = 1;

	if (p->n == 0)
		return INFINITY;
	if (p->n < 3) {
		for (int i = 0; i < p->n; i++)
			best = fmin(best, hypot(p->x[i] - x_mm, p->y[i] - y_mm));
		return best;
	}
	for (int i = 0; i < p->n; i++) {
		int j = (i + 1) % p->n;
		area += p->x[i] * p->y[j] - p->x[j] * p->y[i];
	}
	for (int i = 0; i < p->n; i++) {
		int j = (i + 1) % p->n;
		double cr = (p->x[j] - p->x[i]) * (y_mm - p->y[i]) -
			    (p->y[j] - p->y[i]) * (x_mm - p->x[i]);
		if ((area > 0 && cr < 0) || (area < 0 && cr > 0))
			inside = 0;
		best = fmin(best, seg_dist2(x_mm, y_mm, p->x[i], p->y[i], p->x[j], p->y[j]));
	}
	return inside ? 0 : sqrt(best);
}

double verify_subpx_region_dist(const struct verify_subpx_region *r, double x_mm, double y_mm)
{
	double best = INFINITY;

	for (int k = 0; k < r->parts && best > 0; k++)
		best = fmin(best, verify_subpx_poly_dist(&r->part[k], x_mm, y_mm));
	return best;
}

double verify_subpx_gap_mm(const struct verify_subpx_img *im, int x, int y)
{
	struct verify_subpx_region r;
	double gap = 0;
	int g = verify_subpx_gray(im, x, y);

	if (g == 255)
		return 0;
	if (g == 0)
		return INFINITY;
	verify_subpx_region(im, x, y, &r);
	if (r.parts <= 1) {
		/* distance to a convex set is convex: its maximum over the
		 * square is at a corner */
		for (int j = -1; j <= 1; j += 2)
			for (int i = -1; i <= 1; i += 2)
				gap = fmax(gap, verify_subpx_poly_dist(&r.part[0], (x + i * 0.5) * im->px_mm,
									(y + j * 0.5) * im->py_mm));
		return gap;
	}
	/* the union of two (a concave corner): the farthest point of the
	 * square lies in the void's wedge, where the distance to the region
	 * is the smaller of the distances to the wedge's two sides, neither
	 * surrounding a point inside: on the square's boundary.  Sampled
	 * there every 1/16 pixel, plus the 1/32 pixel the samples may miss
	 * (distance is 1-Lipschitz) */
	for (int s = 0; s < 64; s++) {
		double t = (s % 16) / 16.0 - 0.5, u, v;
		switch (s / 16) {
		case 0: u = t; v = -0.5; break;
		case 1: u = 0.5; v = t; break;
		case 2: u = -t; v = 0.5; break;
		default: u = -0.5; v = -t; break;
		}
		gap = fmax(gap, verify_subpx_region_dist(&r, (x + u) * im->px_mm, (y + v) * im->py_mm));
	}
	return gap + fmax(im->px_mm, im->py_mm) / 32;
}

/* Distance (mm) from a point to the solid of `below` within the window. */
static double dist_below(const struct verify_subpx_img *below, int x, int y, int win, double sx,
			 double sy)
{
	double px = below->px_mm, py = below->py_mm, best = INFINITY;
	double half_diag = 0.5 * hypot(px, py);

	for (int j = y - win; j <= y + win; j++)
		for (int i = x - win; i <= x + win; i++) {
			int g = verify_subpx_gray(below, i, j);
			double cx = i * px, cy = j * py, d;
			if (g == 0)
				continue;
			if (hypot(sx - cx, sy - cy) - half_diag >= best)
				continue; /* its square is no nearer */
			if (g == 255) {
				/* the square: distance per axis beyond its half pitch */
				double ex = fmax(fabs(sx - cx) - px / 2, 0);
				double ey = fmax(fabs(sy - cy) - py / 2, 0);
				d = hypot(ex, ey);
			} else {
				struct verify_subpx_region r;
				verify_subpx_region(below, i, j, &r);
				d = verify_subpx_region_dist(&r, sx, sy);
			}
			if (d < best)
				best = d;
		}
	return best;
}

/* A valley: a grey pixel darker than both of its neighbours along a row,
 * a column or a diagonal: it holds a void thinner than the pixel (the
 * last of a closing cavity), which one straight edge cannot describe. */
static int valley(const struct verify_subpx_img *im, int x, int y, int g)
{
	static const int dx[4] = {1, 0, 1, 1}, dy[4] = {0, 1, 1, -1};

	for (int k = 0; k < 4; k++)
		if (g < verify_subpx_gray(im, x + dx[k], y + dy[k]) &&
		    g < verify_subpx_gray(im, x - dx[k], y - dy[k]))
			return 1;
	return 0;
}

/* The last hole of a closing roof: grey pixel (x, y) of `above` in a
 * small void of `above` that closes (its 8-connected pixels below 255 fit
 * a HOLE_MAX_PX square).  Its few grey pixels do not determine its shape
 * (a square hole and a disc of its area have nearly the same coverage),
 * so it is read as the roof closing evenly: the solid of `above` there
 * is the solid of `below` grown by t, t such that the void this leaves
 * in the hole's window (its bounding box and one pixel more) has the
 * window's void area, by HOLE_SAMPLES^2 points a pixel.  Taken only when
 * it gives every pixel of the window its coverage within HOLE_TOL (a hole
 * off the middle of the hole below, or of another shape, is not this);
 * then *far (mm) is t where the hole's edge crosses pixel (x, y), else
 * the largest distance of its points.  Returns 0 when not taken.  Cost:
 * HOLE_SAMPLES^2 distances (dist_below) per pixel of the window. */
#define HOLE_MAX_PX 8
#define HOLE_SAMPLES 6
#define HOLE_TOL 0.1
#define HOLE_WIN (HOLE_MAX_PX + 2)
#define HOLE_N (HOLE_WIN * HOLE_WIN * HOLE_SAMPLES * HOLE_SAMPLES)

static int cmp_desc(const void *a, const void *b)
{
	float u = *(const float *)a, v = *(const float *)b;

	return (u < v) - (u > v);
}

static int closing_hole(const struct verify_subpx_img *below, const struct verify_subpx_img *above,
			int x, int y, int win_px, double *far)
{
	int stack[HOLE_MAX_PX * HOLE_MAX_PX + 1], sp = 0, seen = 0, wx0, wy0, ww, wh;
	int x0 = x, y0 = y, x1 = x, y1 = y, gx[HOLE_MAX_PX * HOLE_MAX_PX], gy[HOLE_MAX_PX * HOLE_MAX_PX];
	float d[HOLE_N], sorted[HOLE_N]; /* mm; 29 KB of stack */
	double v = 0, t, best = -INFINITY;
	const int ss = HOLE_SAMPLES * HOLE_SAMPLES;
	int n = 0, nv, cross = 0;

	/* the hole: flood of the pixels below 255, capped */
	gx[seen] = x;
	gy[seen++] = y;
	stack[sp++] = 0;
	while (sp) {
		int q = stack[--sp];
		for (int j = -1; j <= 1; j++)
			for (int i = -1; i <= 1; i++) {
				int ax = gx[q] + i, ay = gy[q] + j, dup = 0;
				if (verify_subpx_gray(above, ax, ay) == 255)
					continue;
				for (int k = 0; k < seen && !dup; k++)
					dup = gx[k] == ax && gy[k] == ay;
				if (dup)
					continue;
				x0 = ax < x0 ? ax : x0;
				x1 = ax > x1 ? ax : x1;
				y0 = ay < y0 ? ay : y0;
				y1 = ay > y1 ? ay : y1;
				if (x1 - x0 >= HOLE_MAX_PX || y1 - y0 >= HOLE_MAX_PX ||
				    seen == HOLE_MAX_PX * HOLE_MAX_PX)
					return 0; /* not small: an edge, not a hole */
				gx[seen] = ax;
				gy[seen] = ay;
				stack[sp++] = seen++;
			}
	}
	wx0 = x0 - 1;
	wy0 = y0 - 1;
	ww = x1 - x0 + 3;
	wh = y1 - y0 + 3;
	for (int py = 0; py < wh; py++)
		for (int px = 0; px < ww; px++) {
			int cx = wx0 + px, cy = wy0 + py;
			v += 1 - verify_subpx_gray(above, cx, cy) / 255.0;
			for (int s = 0; s < ss; s++) {
				double u = (s % HOLE_SAMPLES + 0.5) / HOLE_SAMPLES - 0.5;
				double w = (s / HOLE_SAMPLES + 0.5) / HOLE_SAMPLES - 0.5;
				d[n++] = (float)dist_below(below, cx, cy, win_px + 1,
							   (cx + u) * above->px_mm,
							   (cy + w) * above->py_mm);
			}
		}
	memcpy(sorted, d, (size_t)n * sizeof *d);
	qsort(sorted, (size_t)n, sizeof *sorted, cmp_desc);
	nv = (int)lround(v * ss);
	if (nv <= 0 || nv >= n || !isfinite(sorted[nv]))
		return 0;
	/* between the void's nearest point and the solid's farthest, at most
	 * half a sample's diagonal past the latter (deep in the hole the
	 * window may miss the nearest solid and read a void point farther) */
	t = sorted[nv] + fmin(sorted[nv - 1] - sorted[nv],
			      M_SQRT2 * fmax(above->px_mm, above->py_mm) / HOLE_SAMPLES) / 2;
	for (int p = 0; p < ww * wh; p++) {
		int cx = wx0 + p % ww, cy = wy0 + p / ww, in = 0;
		for (int s = 0; s < ss; s++)
			in += d[p * ss + s] <= t;
		if (fabs((double)in / ss - verify_subpx_gray(above, cx, cy) / 255.0) > HOLE_TOL)
			return 0;
		if (cx == x && cy == y)
			for (int s = 0; s < ss; s++) {
				if (d[p * ss + s] > t)
					cross = 1;
				else
					best = fmax(best, d[p * ss + s]);
			}
	}
	*far = cross ? t : best;
	return 1;
}

double verify_subpx_far_mm(const struct verify_subpx_img *below,
			   const struct verify_subpx_img *above, int x, int y, int win_px)
{
	struct verify_subpx_region q;
	double far = -INFINITY, px = above->px_mm, py = above->py_mm;
	int g = verify_subpx_gray(above, x, y);

	if (g == 0)
		return -INFINITY;
	if (g < 255 && !above->one_edge && closing_hole(below, above, x, y, win_px, &far))
		return far;
	verify_subpx_region(above, x, y, &q);
	if (g < 255 && !q.corner && valley(above, x, y, g)) {
		/* the square less a disc holding the void of the 3 x 3
		 * neighbourhood, at that void's centroid: a closing cavity's
		 * last hole */
		double m = 0, mx = 0, my = 0, rho;
		for (int j = -1; j <= 1; j++)
			for (int i = -1; i <= 1; i++) {
				double wt = 1 - verify_subpx_gray(above, x + i, y + j) / 255.0;
				m += wt;
				mx += wt * i;
				my += wt * j;
			}
		mx /= m;
		my /= m;
		rho = sqrt(m / M_PI);
		for (int j = 0; j <= 4; j++)
			for (int i = 0; i <= 4; i++) {
				double u = -0.5 + i * 0.25, v = -0.5 + j * 0.25;
				if (hypot(u - mx, v - my) < rho)
					continue;
				far = fmax(far, dist_below(below, x, y, win_px, (x + u) * px,
							   (y + v) * py));
			}
		for (int k = 0; k < 16; k++) {
			double u = mx + rho * cos(k * M_PI / 8), v = my + rho * sin(k * M_PI / 8);
			if (fabs(u) > 0.5 || fabs(v) > 0.5)
				continue;
			far = fmax(far,
				   dist_below(below, x, y, win_px, (x + u) * px, (y + v) * py));
		}
		return far;
	}
	for (int p = 0; p < q.parts; p++)
		for (int k = 0; k < q.part[p].n; k++)
			far = fmax(far, dist_below(below, x, y, win_px, q.part[p].x[k],
						   q.part[p].y[k]));
	if (q.has_tip)
		far = fmax(far, dist_below(below, x, y, win_px, q.tip_x, q.tip_y));
	for (int j = 0; j <= 4; j++)
		for (int i = 0; i <= 4; i++) {
			double sx = (x - 0.5 + i * 0.25) * above->px_mm;
			double sy = (y - 0.5 + j * 0.25) * above->py_mm;
			if (verify_subpx_region_dist(&q, sx, sy) > 0)
				continue;
			far = fmax(far, dist_below(below, x, y, win_px, sx, sy));
		}
	return far;
}

double verify_subpx_far_bounded_mm(const struct verify_subpx_img *below,
				   const struct verify_subpx_img *above, int x, int y, int gray,
				   double u_mm, double any_mm, double reach_mm)
{
	double hd = 0.5 * hypot(above->px_mm, above->py_mm);
	double lo = any_mm - (gray >= 128 ? hd : 2 * hd), wmm;

	if (lo > reach_mm)
		return lo; /* a lower bound: beyond the reach anyway */
	wmm = fmin(u_mm, any_mm + 2 * hd) + 2 * hd;
	return verify_subpx_far_mm(below, above, x, y,
				   (int)ceil(wmm / fmin(above->px_mm, above->py_mm)));
}
