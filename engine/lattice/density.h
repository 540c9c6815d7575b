/* density.h - target solid fraction of the lattice over the part.
 *
 * Four sources: a constant; a linear gradient between two points; a
 * radial falloff from a centre; a voxel grid read from a NRRD file
 * (docs/lattice.md section 5.3).  Points are given as fractions of the
 * part's bounding box (0,0,0 = min corner, 1,1,1 = max corner) so a
 * field does not depend on the part's scale or placement; a voxel grid
 * spans the bounding box exactly.
 */
#ifndef INFILLD_LATTICE_DENSITY_H
#define INFILLD_LATTICE_DENSITY_H

#include <stddef.h>

#include "engine/geom/vec.h"

struct err;

enum lattice_density_mode {
	LATTICE_DENSITY_CONSTANT = 0,
	LATTICE_DENSITY_GRADIENT,
	LATTICE_DENSITY_RADIAL,
	LATTICE_DENSITY_FILE
};

struct lattice_density {
	enum lattice_density_mode mode;
	struct box3 box;        /* the part's bounding box, mm */
	double value;           /* constant */
	struct vec3 p0, p1;     /* gradient end points / radial centre (p0), mm */
	double d0, d1;          /* densities at p0 and p1 (radial: centre, rim) */
	double radius_mm;       /* radial falloff distance */
	float *grid;            /* FILE: nx*ny*nz values, x fastest; owned */
	int nx, ny, nz;
	double lo, hi;          /* smallest / largest value anywhere */
};

/* Set up from fractions of box (see above).  radius_mm <= 0 for radial =
 * distance from the centre to the farthest corner of box. */
void lattice_density_constant(struct lattice_density *d, struct box3 box, double value);
void lattice_density_gradient(struct lattice_density *d, struct box3 box, struct vec3 f0,
			      struct vec3 f1, double d0, double d1);
void lattice_density_radial(struct lattice_density *d, struct box3 box, struct vec3 fc,
			    double radius_mm, double d_center, double d_rim);

/* Read a 3D NRRD voxel grid (type uint8 (value/255), float or double;
 * encoding raw; little endian; header keys checked, sizes against the
 * file size).  Values must lie in [0, 1].  ERR_PARSE with the line or
 * byte offset on malformed input. */
int lattice_density_load(struct lattice_density *d, struct box3 box, const char *path,
			 struct err *e);
int lattice_density_load_buffer(struct lattice_density *d, struct box3 box, const void *data,
				size_t len, struct err *e);
void lattice_density_fini(struct lattice_density *d);

/* Target solid fraction at p (mm), clamped into [0, 1]; FILE grids are
 * trilinear between voxel centres. */
double lattice_density_at(const struct lattice_density *d, struct vec3 p);

#endif
