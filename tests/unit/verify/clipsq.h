/* clipsq.h - the unit tests' exact pixel coverage: a pixel's square
 * clipped by half-planes (Sutherland-Hodgman), written apart from the
 * verifier's own geometry.  Pixel (i, j) is [i, i+1] x [j, j+1] in pixel
 * units; a disc as a polygon of up to CLIPSQ_MAX_EDGES half-planes. */
#ifndef INFILLD_TESTS_VERIFY_CLIPSQ_H
#define INFILLD_TESTS_VERIFY_CLIPSQ_H

#include <math.h>

#define CLIPSQ_MAX_EDGES 2048

struct hp {
	double a, b, c; /* a x + b y <= c: the clipped side (pixels) */
};

/* Area of pixel (i, j)'s square [i, i+1] x [j, j+1] inside every half-plane. */
static double clip_area(int i, int j, const struct hp *h, int nh)
{
	/* a disc smaller than the pixel leaves every one of its edges in it */
	static double x[CLIPSQ_MAX_EDGES + 8], y[CLIPSQ_MAX_EDGES + 8], ox[CLIPSQ_MAX_EDGES + 8], oy[CLIPSQ_MAX_EDGES + 8];
	double a = 0;
	int n = 4;

	x[0] = x[3] = i;
	x[1] = x[2] = i + 1;
	y[0] = y[1] = j;
	y[2] = y[3] = j + 1;

	for (int k = 0; k < nh && n > 0; k++) {
		int m = 0;
		for (int p = 0; p < n; p++) {
			int q = (p + 1) % n;
			double fp = h[k].a * x[p] + h[k].b * y[p] - h[k].c;
			double fq = h[k].a * x[q] + h[k].b * y[q] - h[k].c;
			if (m > CLIPSQ_MAX_EDGES + 6)
				break; /* cannot happen: at most 4 + one per half-plane */
			if (fp <= 0) {
				ox[m] = x[p];
				oy[m++] = y[p];
			}
			if ((fp < 0 && fq > 0) || (fp > 0 && fq < 0)) {
				double t = fp / (fp - fq);
				ox[m] = x[p] + t * (x[q] - x[p]);
				oy[m++] = y[p] + t * (y[q] - y[p]);
			}
		}
		n = m;
		for (int p = 0; p < n; p++) {
			x[p] = ox[p];
			y[p] = oy[p];
		}
	}
	for (int p = 0; p < n; p++) {
		int q = (p + 1) % n;
		a += x[p] * y[q] - x[q] * y[p];
	}
	return fabs(a) / 2;
}

#endif
