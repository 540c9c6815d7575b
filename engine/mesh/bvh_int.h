/* bvh_int.h - layout of struct mesh_bvh, shared by bvh.c and winding.c only.
 *
 * Nodes are stored depth-first-allocated: an internal node's children are
 * `left` and `left + 1`, both after it, so a reverse sweep visits
 * children before parents.  Triangles are copied in leaf order.
 */
#ifndef INFILLD_MESH_BVH_INT_H
#define INFILLD_MESH_BVH_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/mesh/mesh.h"

#define BVH_MAX_DEPTH 96   /* bounded by the build (docs/mesh.md) */
#define BVH_STACK (2 * BVH_MAX_DEPTH + 8)

struct bvh_node {
	struct box3 box;
	uint32_t left;  /* internal: first child; leaf: first triangle (leaf order) */
	uint32_t count; /* 0 = internal, else triangles in the leaf */
};

struct bvh_tri {
	struct vec3 a, b, c;
};

/* Far-field data per node for the winding number (winding.c). */
struct bvh_wn {
	struct vec3 p;  /* area-weighted centroid of the node's triangles */
	struct vec3 n;  /* sum of area vectors (b-a)x(c-a)/2 */
	double m[9];    /* sum of area_vector (x) (centroid - p), row-major */
	double r;       /* every triangle corner lies within r of p */
	double area;    /* sum of triangle areas (weights of p) */
};

struct mesh_bvh {
	const struct mesh *m;
	struct bvh_node *nodes;
	size_t nnodes;
	struct bvh_tri *tris; /* nt, leaf order */
	uint32_t *idx;        /* leaf order -> mesh triangle */
	struct bvh_wn *wn;    /* nnodes */
	int closed;           /* every edge used as often forward as backward */
};

/* Signed crossings of the ray from q along a fixed oblique direction
 * (+1 leaving through a face, -1 entering): equals the winding number
 * when the mesh is closed.  0 and *crossings set, or -1 when a hit is
 * too close to an edge, a vertex, q itself or a face's plane to count
 * robustly (callers then use the winding number). */
int mesh_bvh_crossings(const struct mesh_bvh *b, struct vec3 q, int *crossings);

/* Fill b->wn (allocated by the caller, nnodes entries). */
void mesh_bvh_winding_prepare(struct mesh_bvh *b);

#endif
