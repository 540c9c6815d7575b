/* place.c - mesh_place: file frame and units -> printer frame in mm.
 *
 * Order: units to mm and the `scale` factor; a proper rotation (det +1,
 * so orientation and the sign of the volume are kept) taking the file's
 * `up` axis to +z; height_mm > 0 replaces the scale so the z extent is
 * exactly that; then a translation putting the bbox minimum z at 0 and
 * the XY bbox centre at (center_x_mm, center_y_mm).  The bbox is that of
 * the triangle corners (stray vertices move along but do not count).
 */
#include "engine/mesh/mesh.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"

/* Rotation taking file axis `up` to +z: rows of a proper rotation. */
static void up_rotation(int up, double r[3][3])
{
	static const double rot[6][3][3] = {
		[MESH_UP_Z] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
		[MESH_UP_NZ] = {{1, 0, 0}, {0, -1, 0}, {0, 0, -1}}, /* 180 deg about x */
		[MESH_UP_Y] = {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}},   /* +90 deg about x */
		[MESH_UP_NY] = {{1, 0, 0}, {0, 0, 1}, {0, -1, 0}},  /* -90 deg about x */
		[MESH_UP_X] = {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}},   /* -90 deg about y */
		[MESH_UP_NX] = {{0, 0, 1}, {0, 1, 0}, {-1, 0, 0}},  /* +90 deg about y */
	};
	memcpy(r, rot[up], sizeof rot[up]);
}

static struct vec3 transform(const double r[3][3], double s, struct vec3 q)
{
	return v3(s * (r[0][0] * q.x + r[0][1] * q.y + r[0][2] * q.z),
		  s * (r[1][0] * q.x + r[1][1] * q.y + r[1][2] * q.z),
		  s * (r[2][0] * q.x + r[2][1] * q.y + r[2][2] * q.z));
}

static double units_mm(int units)
{
	switch (units) {
	case MESH_UNITS_MM: return 1.0;
	case MESH_UNITS_CM: return 10.0;
	case MESH_UNITS_M: return 1000.0;
	case MESH_UNITS_IN: return 25.4;
	}
	return 0.0;
}

int mesh_place(struct mesh *m, const struct mesh_placement *p, struct err *e)
{
	double r[3][3], s = units_mm(p->units), zmin = INFINITY, zmax = -INFINITY;
	struct box3 bb = box3_empty();
	struct vec3 shift;
	size_t i;

	if (s == 0.0)
		return ERR_FIELD(e, "units", "unknown units %d (mm, cm, m or in)", p->units);
	if (!(p->scale > 0) || !isfinite(p->scale))
		return ERR_FIELD(e, "scale", "scale must be a finite number > 0, not %g", p->scale);
	if (!(p->height_mm >= 0) || !isfinite(p->height_mm))
		return ERR_FIELD(e, "height_mm", "height_mm must be >= 0 (0 = keep), not %g",
				 p->height_mm);
	if (p->up < MESH_UP_Z || p->up > MESH_UP_NX)
		return ERR_FIELD(e, "up", "unknown up axis %d (z, -z, y, -y, x or -x)", p->up);
	if (!isfinite(p->center_x_mm) || !isfinite(p->center_y_mm))
		return ERR_FIELD(e, "center", "plate centre must be finite");
	if (m->nt == 0)
		return ERR_SET(e, ERR_GEOMETRY, "cannot place an empty mesh (no triangles)");
	for (i = 0; i < 3 * m->nt; i++)
		if (m->tri[i] >= m->nv)
			return ERR_SET(e, ERR_GEOMETRY, "triangle %zu refers to vertex %u of %zu",
				       i / 3, m->tri[i], m->nv);
	up_rotation(p->up, r);
	s *= p->scale;
	/* z extent after rotation, before scaling: decides height scaling. */
	for (i = 0; i < 3 * m->nt; i++) {
		struct vec3 q = m->v[m->tri[i]];
		double z = r[2][0] * q.x + r[2][1] * q.y + r[2][2] * q.z;
		zmin = fmin(zmin, z);
		zmax = fmax(zmax, z);
	}
	if (!(zmax > zmin))
		return ERR_SET(e, ERR_GEOMETRY, "the part has zero height along the up axis");
	if (p->height_mm > 0)
		s = p->height_mm / (zmax - zmin);
	/* First pass: the final bbox, so a failure leaves m untouched. */
	for (i = 0; i < 3 * m->nt; i++)
		box3_add(&bb, transform(r, s, m->v[m->tri[i]]));
	if (!isfinite(bb.lo.x) || !isfinite(bb.hi.x) || !isfinite(bb.lo.y) ||
	    !isfinite(bb.hi.y) || !isfinite(bb.lo.z) || !isfinite(bb.hi.z))
		return ERR_SET(e, ERR_GEOMETRY, "the scaled part overflows (scale %g)", s);
	/* Rotation entries are 0 or +-1, so each coordinate is one exact
	 * product: the vertex with the minimum z lands exactly on z = 0. */
	shift = v3(p->center_x_mm - 0.5 * (bb.lo.x + bb.hi.x),
		   p->center_y_mm - 0.5 * (bb.lo.y + bb.hi.y), -bb.lo.z);
	for (i = 0; i < m->nv; i++)
		m->v[i] = v3_add(transform(r, s, m->v[i]), shift);
	return 0;
}
