/* mesh.h - triangle meshes: reading, writing, analysis, placement, BVH.
 *
 * A struct mesh is an indexed triangle soup in double millimetres.  Before
 * placement it is in the file's frame and units; mesh_place() moves it
 * into the printer frame (z up from the build plate, part centred in XY).
 * Readers treat every input as hostile: counts are checked against the
 * file size before allocation, and every error names its place (byte
 * offset or line, and facet/vertex index).  Design: docs/mesh.md.
 */
#ifndef INFILLD_MESH_H
#define INFILLD_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"

struct err;
struct sink;

struct mesh {
	struct vec3 *v;  /* nv vertices, owned */
	uint32_t *tri;   /* 3 * nt vertex indices, owned; CCW seen from outside */
	size_t nv, nt;
};

enum mesh_format {
	MESH_FMT_AUTO = 0, /* by content, then by file name extension */
	MESH_FMT_STL,      /* binary or ASCII, decided by content */
	MESH_FMT_OBJ,
	MESH_FMT_OFF,
	MESH_FMT_PLY
};

/* Hard caps applied by every reader before allocating. */
#define MESH_MAX_TRIANGLES 50000000u
#define MESH_MAX_VERTICES 50000000u
/* Largest |coordinate| a file may hold, in its own units: no printable part
 * is 1e9 units across in any unit (mm, cm, m, in), and keeping coordinates
 * this small keeps extents, areas and volumes finite in double. */
#define MESH_MAX_COORD 1e9

/* What a reader saw besides the geometry. */
struct mesh_read_info {
	enum mesh_format format;
	int binary;              /* 1 for binary STL/PLY */
	char name[128];          /* STL solid name / OBJ object name, "" if none */
	size_t polygons_split;   /* OBJ/OFF/PLY polygons with > 3 corners fan-triangulated */
	size_t warnings;         /* tolerated quirks (see docs/mesh.md) */
	char first_warning[256]; /* the first of them, "" if none */
};

/* Allocate an empty mesh; caller frees with mesh_free() (NULL-safe).
 * mesh_reserve/mesh_add_* and mesh_free only take meshes made by
 * mesh_new(), mesh_clone() or a reader (they keep hidden capacities);
 * every other function also accepts a caller-built struct mesh. */
struct mesh *mesh_new(void);
void mesh_free(struct mesh *m);
/* Reserve room; 0 or ERR_NOMEM. */
int mesh_reserve(struct mesh *m, size_t nv, size_t nt);
int mesh_add_vertex(struct mesh *m, struct vec3 p);
int mesh_add_triangle(struct mesh *m, uint32_t a, uint32_t b, uint32_t c);
/* Deep copy; caller frees. NULL on ERR_NOMEM. */
struct mesh *mesh_clone(const struct mesh *m);

/* Read a mesh file (mmap or read; never more than the file's size is
 * allocated for raw data).  name_hint: used for extension-based detection
 * and messages.  On success *out is a new mesh (caller frees) and *info
 * (may be NULL) is filled.  The mesh is not welded: call mesh_weld()
 * (STL readers already share bitwise-identical corners of the soup). */
int mesh_read_file(const char *path, enum mesh_format fmt, struct mesh **out,
		   struct mesh_read_info *info, struct err *e);
/* Same from memory (fuzz targets, uploads already in memory). */
int mesh_read_buffer(const void *data, size_t len, enum mesh_format fmt, const char *name_hint,
		     struct mesh **out, struct mesh_read_info *info, struct err *e);

/* Writers (for round-trip tests and the hollow engine's mesh output). */
int mesh_write_stl(const struct mesh *m, int binary, struct sink *s, struct err *e);
int mesh_write_obj(const struct mesh *m, struct sink *s, struct err *e);
int mesh_write_off(const struct mesh *m, struct sink *s, struct err *e);
int mesh_write_ply(const struct mesh *m, int binary, struct sink *s, struct err *e);

/* Merge vertices closer than tol_mm (0 = exact duplicates only) and drop
 * triangles that become degenerate (repeated index).  O(n log n). */
int mesh_weld(struct mesh *m, double tol_mm, size_t *merged_vertices, size_t *dropped_triangles,
	      struct err *e);

struct mesh_report {
	size_t triangles, vertices;
	size_t edges;               /* distinct undirected edges (for V - E + F) */
	struct box3 bbox;           /* mm (or file units before placement) */
	double volume_mm3;          /* signed (divergence theorem); < 0 = inside out */
	double area_mm2;
	size_t border_edges;        /* edges used by exactly one triangle */
	size_t nonmanifold_edges;   /* edges used by more than two triangles */
	size_t inconsistent_edges;  /* manifold edges traversed the same way by both faces */
	size_t degenerate_faces;    /* zero area (repeated or collinear corners) */
	size_t components;          /* edge-connected components */
	int watertight;             /* no border, non-manifold or inconsistent edges */
	/* repairs performed by mesh_repair() */
	size_t welded_vertices;
	size_t dropped_triangles;
	int flipped;                /* some component was inside out and got reversed */
	size_t flipped_components;  /* how many components were reversed as a whole */
	size_t reoriented_faces;    /* faces flipped to agree with their component */
};

/* Volume (mm^3) and first moment (mm^4: volume x centroid) of a closed,
 * outward mesh by the divergence theorem; centre of mass = moment / vol. */
void mesh_mass(const struct mesh *m, double *vol_mm3, struct vec3 *moment_mm4);

/* Facet adjacency across edges: nb[3 t + k] = the triangle sharing edge
 * k of triangle t (corner k -> corner k + 1 mod 3), or MESH_NO_FACET when
 * that edge is a border, non-manifold (used by more than two triangles)
 * or has equal ends.  Edges are matched by vertex index, so m must be
 * welded.  nb: 3 * m->nt entries, caller's storage.  O(n) plus the sort
 * of each vertex's fan.  0, ERR_LIMIT or ERR_NOMEM (nb undefined). */
#define MESH_NO_FACET UINT32_MAX
int mesh_facet_neighbours(const struct mesh *m, uint32_t *nb, struct err *e);

/* Topology and measure analysis (does not modify m).  O(n log n). */
int mesh_analyze(const struct mesh *m, struct mesh_report *r, struct err *e);

/* Standard clean-up before slicing: weld exact duplicates, drop degenerate
 * faces, make orientation consistent per component and outward (positive
 * volume).  Records what it did in r (then re-analysed). */
int mesh_repair(struct mesh *m, struct mesh_report *r, struct err *e);

enum mesh_units { MESH_UNITS_MM, MESH_UNITS_CM, MESH_UNITS_M, MESH_UNITS_IN };
enum mesh_up { MESH_UP_Z, MESH_UP_NZ, MESH_UP_Y, MESH_UP_NY, MESH_UP_X, MESH_UP_NX };

struct mesh_placement {
	int units;           /* enum mesh_units of the file */
	double scale;        /* extra uniform factor (> 0) */
	double height_mm;    /* > 0: scale uniformly so the z extent is this */
	int up;              /* enum mesh_up: file axis that points up in the printer */
	double center_x_mm;  /* where the bbox centre goes on the plate */
	double center_y_mm;
};

/* Transform m in place into the printer frame: units -> mm, rotate
 * (proper rotation, keeps orientation) so `up` becomes +z, scale, then
 * translate so bbox min z = 0 and the XY bbox centre is at the given
 * centre.  Fails (ERR_GEOMETRY) for an empty or zero-height mesh. */
int mesh_place(struct mesh *m, const struct mesh_placement *p, struct err *e);

/* ---- Spatial queries (engines: lattice, hollow) ---- */
struct mesh_bvh;

/* Build over m (borrowed: must outlive the BVH).  Caller frees. */
int mesh_bvh_new(const struct mesh *m, struct mesh_bvh **out, struct err *e);
void mesh_bvh_free(struct mesh_bvh *b);
/* Closest point on the surface to p; returns the distance (mm) and, if
 * non-NULL, the point and triangle index. */
double mesh_bvh_closest(const struct mesh_bvh *b, struct vec3 p, struct vec3 *q, size_t *tri);
/* Generalised winding number of the surface at p: ~1 inside a closed
 * outward mesh, ~0 outside, smooth across small holes.  Exact (sum of
 * triangle solid angles) near p, hierarchical dipole expansion far away:
 * absolute error ~1e-3 typical, below 0.05 (docs/mesh.md). */
double mesh_bvh_winding(const struct mesh_bvh *b, struct vec3 p);
/* Inside test by generalised winding number (robust for small holes):
 * winding > 0.5 counts as inside.  Closed meshes use one exact ray
 * crossing count instead (falling back to the winding number when the
 * ray grazes an edge). */
int mesh_bvh_inside(const struct mesh_bvh *b, struct vec3 p);
/* First hit of the ray o + t*d (t > 0); returns t or INFINITY. */
double mesh_bvh_ray(const struct mesh_bvh *b, struct vec3 o, struct vec3 d, size_t *tri);

#endif
