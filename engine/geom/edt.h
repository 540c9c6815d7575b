/* edt.h - exact Euclidean distance transform of a binary image.
 *
 * Felzenszwalb-Huttenlocher: squared distances by the lower envelope of
 * parabolas, one pass along rows then one along columns, O(w h).  Pixel
 * pitches may differ per axis (distances in mm between pixel centres).
 * Used by the layer verifier (engine/verify) for overhang reach and wall
 * thickness, and by the hollow engine's top-down fill.
 */
#ifndef INFILLD_EDT_H
#define INFILLD_EDT_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Reusable scratch for edt_sq(); edt_scratch_fini() frees. */
struct edt_scratch {
	float *f, *d;
	double *z;
	int *v, *a;
	size_t cap;
};

void edt_scratch_init(struct edt_scratch *s);
void edt_scratch_fini(struct edt_scratch *s);

/* out[y * w + x] = squared distance (mm^2) from pixel (x, y)'s centre to
 * the nearest pixel centre with seed[y * stride + x] != 0 (0 on seeds);
 * INFINITY when there is no seed.  px_mm, py_mm: pitch along x (columns)
 * and y (rows).  0 or ERR_NOMEM. */
int edt_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm, double py_mm,
	   float *out, struct edt_scratch *s, struct err *e);

/* As edt_sq, and near[y * w + x] = y' * w + x' for a nearest seed pixel
 * (x', y') (the feature transform; one of them on ties), -1 without
 * seeds.  near may be NULL (edt_sq).  The pitches
 * enter the distances only, so the seed found is exactly nearest in mm.
 * 0 or ERR_NOMEM. */
int edt_nearest_sq(const uint8_t *seed, size_t stride, int w, int h, double px_mm,
		   double py_mm, float *out, int32_t *near, struct edt_scratch *s, struct err *e);

#endif
