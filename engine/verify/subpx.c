/* subpx.c - sub-pixel layer regions and overhang distances (subpx.h). */
#include "engine/verify/subpx.h"

#include <math.h>
#include <stddef.h>

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

/* Clip polygon (pixel units) to n.u <= d (Sutherland-Hodgman, one plane). */
static void clip_half(double *ux, double *uy, int *n, double nx, double ny, double d)
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

void verify_subpx_region(const struct verify_subpx_img *im, int x, int y,
			 struct verify_subpx_poly *out)
{
	static const double sq_x[4] = {-0.5, 0.5, 0.5, -0.5};
	static const double sq_y[4] = {-0.5, -0.5, 0.5, 0.5};
	double ux[8], uy[8], c, nx, ny;
	int g = verify_subpx_gray(im, x, y), n = 4;

	out->n = 0;
	if (g == 0)
		return;
	for (int i = 0; i < 4; i++) {
		ux[i] = sq_x[i];
		uy[i] = sq_y[i];
	}
	c = g / 255.0;
	if (g < 255) {
		if (!sobel_normal(im, x, y, &nx, &ny)) {
			/* no direction: a centred square of the same area */
			for (int i = 0; i < 4; i++) {
				ux[i] = sq_x[i] * sqrt(c);
				uy[i] = sq_y[i] * sqrt(c);
			}
		} else {
			clip_half(ux, uy, &n, nx, ny, edge_offset(nx, ny, c));
		}
	}
	out->n = n;
	for (int i = 0; i < n; i++) {
		out->x[i] = (x + ux[i]) * im->px_mm;
		out->y[i] = (y + uy[i]) * im->py_mm;
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

double verify_subpx_gap_mm(const struct verify_subpx_img *im, int x, int y)
{
	struct verify_subpx_poly p;
	double gap = 0;
	int g = verify_subpx_gray(im, x, y);

	if (g == 255)
		return 0;
	if (g == 0)
		return INFINITY;
	verify_subpx_region(im, x, y, &p);
	/* distance to a convex set is convex: its maximum over the square
	 * is at a corner */
	for (int j = -1; j <= 1; j += 2)
		for (int i = -1; i <= 1; i += 2)
			gap = fmax(gap, verify_subpx_poly_dist(&p, (x + i * 0.5) * im->px_mm,
								(y + j * 0.5) * im->py_mm));
	return gap;
}

/* Distance (mm) from a point to the solid of `below` within the window. */
static double dist_below(const struct verify_subpx_img *below, int x, int y, int win,
			 double sx, double sy)
{
	double px = below->px_mm, py = below->py_mm, best = INFINITY;
	double half_diag = 0.5 * hypot(px, py);

	for (int j = y - win; j <= y + win; j++)
		for (int i = x - win; i <= x + win; i++) {
			int g = verify_subpx_gray(below, i, j);
			double cx = i * px, cy = j * py, d;
			struct verify_subpx_poly p;
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
				verify_subpx_region(below, i, j, &p);
				d = verify_subpx_poly_dist(&p, sx, sy);
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

double verify_subpx_far_mm(const struct verify_subpx_img *below,
			   const struct verify_subpx_img *above, int x, int y, int win_px)
{
	struct verify_subpx_poly q;
	double far = -INFINITY, px = above->px_mm, py = above->py_mm;
	int g = verify_subpx_gray(above, x, y);

	if (g == 0)
		return -INFINITY;
	if (g < 255 && valley(above, x, y, g)) {
		/* the square less a disc holding the void of the 3 x 3
		 * neighbourhood, at that void's centroid: a closing cavity's
		 * last hole */
		double m = 0, mx = 0, my = 0, rho;
		for (int j = -1; j <= 1; j++)
			for (int i = -1; i <= 1; i++) {
				double w = 1 - verify_subpx_gray(above, x + i, y + j) / 255.0;
				m += w;
				mx += w * i;
				my += w * j;
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
			far = fmax(far, dist_below(below, x, y, win_px, (x + u) * px, (y + v) * py));
		}
		return far;
	}
	verify_subpx_region(above, x, y, &q);
	for (int k = 0; k < q.n; k++)
		far = fmax(far, dist_below(below, x, y, win_px, q.x[k], q.y[k]));
	for (int j = 0; j <= 4; j++)
		for (int i = 0; i <= 4; i++) {
			double sx = (x - 0.5 + i * 0.25) * above->px_mm;
			double sy = (y - 0.5 + j * 0.25) * above->py_mm;
			if (verify_subpx_poly_dist(&q, sx, sy) > 0)
				continue;
			far = fmax(far, dist_below(below, x, y, win_px, sx, sy));
		}
	return far;
}
