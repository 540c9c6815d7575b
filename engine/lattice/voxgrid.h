/* voxgrid.h - voxel grids with per-voxel sample points (internal to lattice/).
 *
 * Density matching and its independent measurement look at the part
 * through a voxel grid centred on its bounding box; each voxel carries
 * side^3 sample points (jittered-stratified for matching, regular cell
 * centres for measuring), which of them lie inside the part, and the
 * mean target density over those.
 */
#ifndef INFILLD_LATTICE_VOXGRID_H
#define INFILLD_LATTICE_VOXGRID_H

#include <stddef.h>
#include <stdint.h>

#include "engine/lattice/gen.h"

struct voxels {
	struct vec3 lo;
	double h;
	int n[3];
	int side;          /* samples per axis (side^3 per voxel) */
	uint64_t seed;
	uint8_t *inside;   /* side^3 bits per voxel */
	size_t bytes_per;
	double *target;    /* mean target over inside samples */
	float *frac;       /* inside fraction */
};

size_t lattice_vox_count(const struct voxels *v);
struct box3 lattice_vox_box(const struct voxels *v, size_t idx);
/* Sample s (0 .. side^3 - 1) of voxel idx: jittered stratified when
 * jitter, else the centre of its sub-cell. */
struct vec3 lattice_vox_sample(const struct voxels *v, size_t idx, int s, int jitter);
/* Grid of edge h (mm) over d's box with about `samples` points per voxel;
 * classifies every point (in parallel over d->threads).  Caller calls
 * lattice_voxels_fini() even on failure. */
int lattice_voxels_init(struct voxels *v, const struct lattice_domain *d,
			const struct lattice_density *den, double h, int samples, uint64_t seed,
			int jitter, struct err *e);
void lattice_voxels_fini(struct voxels *v);

static inline int lattice_vox_inside(const struct voxels *v, size_t idx, int s)
{
	return (v->inside[idx * v->bytes_per + (s >> 3)] >> (s & 7)) & 1;
}

#endif
