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

/* Most threads one transform runs on (edt_scratch.threads). */
#define EDT_LANES 8

/* One thread's buffers: a line (f, d, z, v, a; cap samples) and the
 * column pass's tiles (EDT_BLOCK columns copied column-major, tile[b * h
 * + y], so the image is read and written a row at a time; tcap entries
 * in each of tf, td, ta, tn). */
struct edt_lane {
	float *f, *d;
	double *z, *g;
	int *v, *a;
	size_t cap;
	float *tf, *td;
	int32_t *ta, *tn;
	size_t tcap;
};

/* Reusable scratch for edt_sq(); edt_scratch_fini() frees.  threads: how
 * many threads edt_sq() and edt_nearest_sq() may use (0 or 1 after
 * edt_scratch_init: the caller's alone; at most EDT_LANES): rows, then
 * blocks of columns, are shared out, and every output is computed as on
 * one thread, so the result does not depend on it. */
struct edt_scratch {
	struct edt_lane lane[EDT_LANES];
	int threads;
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

/* 3D: out[(z * h + y) * w + x] = squared distance (mm^2) from voxel
 * (x, y, z)'s centre to the nearest voxel centre with
 * seed[(z * h + y) * w + x] != 0 (0 on seeds, INFINITY without any seed);
 * isotropic pitch vox_mm.  Each z slice by edt_sq, then the lower
 * envelope along z for every (x, y) column: exact, O(w h d).  Used by
 * the rhombic engine's cell classification (distance of every voxel of
 * the part to the nearest outside voxel).  0 or ERR_NOMEM. */
int edt3_sq(const uint8_t *seed, int w, int h, int d, double vox_mm, float *out, struct err *e);

#endif
