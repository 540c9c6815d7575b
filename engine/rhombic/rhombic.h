/* rhombic.h - internals of the `rhombic` engine: self-supporting adaptive
 * rhombic infill (Wu, Wang, Zhang, Westermann, paper 001).  The method as
 * built, its formulas and deviations: docs/rhombic.md.
 *
 * Frames.  Printer frame x, y, z (mm, z up from the plate).  The cell
 * frame turns the horizontal axes by orient_deg about z:
 *   u = x cos(o) + y sin(o),   v = -x sin(o) + y cos(o),   z = z,
 * so rhombi lie in the (u, z) plane and are extruded along v.
 *
 * Hierarchy.  With the root centred at (cu, cz) with half-width a0 (along
 * u) and half-height b0 (along z), p = (u - cu)/a0, q = (z - cz)/b0 and
 * the sheared coordinates s = (p + q)/2, r = (q - p)/2, the root rhombus
 * |p| + |q| <= 1 is the square max(|s|, |r|) <= 1/2, and the paper's 1:4
 * split (new vertices at the edge midpoints and the centre) is exactly the
 * quadtree split of that square.  A cell of level L is the square
 * s in [-1/2 + i 2^-L, -1/2 + (i+1) 2^-L), r likewise with j: integer
 * (L, i, j), point location and children by integer arithmetic.  Along v
 * a separate binary subdivision: the cells' v range [v0, v0 + E] is cut
 * into 2^m(L) slabs at level L, m(L) the smallest m with E / 2^m <= w_L
 * (w_L = 2 a0 / 2^L, the cell width), so cells are extruded by between
 * w_L / 2 and w_L and a split is 1:8, or 1:4 while v is not cut.
 */
#ifndef INFILLD_RHOMBIC_H
#define INFILLD_RHOMBIC_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/path.h"
#include "engine/geom/vec.h"

struct err;
struct mesh;

#define RH_MAX_LEVEL 24

/* Cell states.  RH_OUT: outside the part (kept so point location is a
 * fixed child index per level).  RH_SPLIT: an inner node.  RH_CAVITY: a
 * leaf carved into a shell (the design variables).  RH_SOLID: a leaf with
 * no cavity (a boundary cell at the minimum size, or a cavity leaf split
 * whose children would be below the minimum size). */
enum rh_state { RH_OUT = 0, RH_SPLIT, RH_CAVITY, RH_SOLID };

struct rh_frame {
	double orient_deg;  /* u axis angle from +x, [0, 180) */
	double cos_o, sin_o;
	double cu_mm, cz_mm; /* root centre (u, z): the part's bbox centre */
	double a0_mm, b0_mm; /* root half-width along u, half-height along z */
	double v0_mm, e_mm;  /* cells' v range [v0, v0 + E]: the part's v range less tau */
	double t_mm;         /* wall half-thickness t = t_min / 2 (eq. 2) */
	double tmin_mm;      /* t_min, the thinnest plate (wall_mm) */
	int max_level;       /* deepest level a cell may have (its opposite faces and v
				extent >= 2 t_min); -1 when even the root is too small */
	int vsplit[RH_MAX_LEVEL + 1]; /* m(L): 2^m(L) v slabs at level L */
};

struct rh_cell {
	int32_t i, j, kv;    /* sheared square (i, j) at this level, v slab kv */
	int32_t parent;      /* -1 for a root */
	int32_t child;       /* first of nchild contiguous children, -1 = leaf */
	uint8_t level, nchild, state;
};

/* A cell's box in the cell frame (mm): rhombus |u-cu|/a + |z-cz|/b <= 1,
 * v in [vlo, vhi]. */
struct rh_geom {
	double cu, cz, a, b, vlo, vhi;
};

/* A cell's cavity: the rhombic prism offset inward by t, |p| + |q| <= k
 * with k = 1 - t sqrt(1/a^2 + 1/b^2), v in [vlo, vhi] (already less t). */
struct rh_cavity {
	double cu, cz, a, b, k, vlo, vhi;
	double zlo, zhi;     /* cz -+ b k */
	double volume_mm3;   /* 2 (a k)(b k)(vhi - vlo) */
};

struct rh_tree {
	struct rh_frame f;
	struct rh_cell *c;   /* owned; n used, cap allocated */
	size_t n, cap;
	int32_t nroots;      /* cells 0 .. nroots-1: level 0, kv = index */
	size_t cavities;     /* leaves in RH_CAVITY */
	double cavity_volume_mm3; /* sum of their cavity volumes */
};

/* ---- tree.c: frame, cell geometry, splitting, point location ---- */

/* Frame for the placed part m (printer frame): orientation orient_deg,
 * overhang alpha_rad from the vertical (0 < alpha < pi/2), wall t_min =
 * wall_mm, and the cells' v range shrunk by tau_mm at both ends.  The
 * root satisfies eq. 3: its inner box (w/2 along u, h/2 along z) holds
 * the part's (u, z) extent, w = max(2 L_u, 2 L_z / tan(pi/2 - alpha)). */
void rh_frame_init(struct rh_frame *f, const struct mesh *m, double alpha_rad, double orient_deg,
		   double wall_mm, double tau_mm);
/* Cell geometry and cavity (cell frame, mm). */
void rh_cell_geom(const struct rh_frame *f, const struct rh_cell *c, struct rh_geom *g);
void rh_cell_cavity(const struct rh_frame *f, const struct rh_cell *c, struct rh_cavity *cv);
/* Opposite-face distance of a rhombus of half-width a, half-height b:
 * 2ab / sqrt(a^2 + b^2). */
double rh_face_distance(double a, double b);
/* Printer frame <-> cell frame. */
void rh_to_cell(const struct rh_frame *f, double x, double y, double *u, double *v);
void rh_to_printer(const struct rh_frame *f, double u, double v, double *x, double *y);

void rh_tree_init(struct rh_tree *t, const struct rh_frame *f);
void rh_tree_fini(struct rh_tree *t);
/* The level-0 cells (2^m(0) slabs along v), state RH_OUT.  0 or ERR_NOMEM. */
int rh_tree_roots(struct rh_tree *t, struct err *e);
/* Append the 4 or 8 children of leaf idx (state RH_OUT) and mark idx
 * RH_SPLIT; the caller sets the children's states.  Invalidates cell
 * pointers.  0, ERR_NOMEM, or ERR_INTERNAL when idx is at max_level. */
int rh_tree_split(struct rh_tree *t, int32_t idx, struct err *e);
/* Can leaf idx be split into cells of at least the minimum size? */
int rh_tree_can_split(const struct rh_tree *t, int32_t idx);
/* The leaf containing printer point (x, y, z), or -1 outside every root
 * (half-open squares and slabs: each point in exactly one leaf). */
int32_t rh_tree_locate(const struct rh_tree *t, double x, double y, double z);
/* 1 when (x, y, z) lies inside the cavity of the leaf holding it. */
int rh_tree_in_cavity(const struct rh_tree *t, double x, double y, double z);
/* Recount cavities and their volume from the states. */
void rh_tree_recount(struct rh_tree *t);
/* Split cavity leaf idx for optimisation: children become cavities, or,
 * when they would be below the minimum size, idx becomes solid.  Keeps
 * cavities and cavity_volume_mm3 current; *added_mm3 (may be NULL) gets
 * the material added (cavity volume lost). */
int rh_tree_refine(struct rh_tree *t, int32_t idx, double *added_mm3, struct err *e);
/* The material rh_tree_refine(idx) would add (mm^3), without doing it. */
double rh_tree_refine_gain(const struct rh_tree *t, int32_t idx);
/* Deepest level holding a cell that is not RH_OUT, + 1. */
int rh_tree_levels(const struct rh_tree *t);

/* ---- classify.c: the part's voxel grid and the initial hierarchy ---- */

/* Voxels of edge h_mm over the part's bbox padded by two voxels; voxel
 * (i, j, k) centred at lo + (i + 1/2, j + 1/2, k + 1/2) h. */
struct rh_vox {
	int nx, ny, nz;
	double h_mm;
	struct vec3 lo;
	uint8_t *code;  /* owned: RH_VOX_OUT, RH_VOX_NEAR (inside, distance <= tau),
			   RH_VOX_DEEP (distance > tau) */
	double tau_mm;
};
enum { RH_VOX_OUT = 0, RH_VOX_NEAR = 1, RH_VOX_DEEP = 2 };

/* Sample the placed part at voxel centres (sliced polygons, centre
 * sampling) and classify each by its exact 3D distance to the nearest
 * outside voxel centre (edt3_sq).  max_voxels caps the grid (ERR_LIMIT).
 * Caller calls rh_vox_fini even on failure. */
int rh_vox_build(const struct mesh *m, double h_mm, double tau_mm, size_t max_voxels,
		 struct rh_vox *vx, struct err *e);
void rh_vox_fini(struct rh_vox *vx);

enum rh_class { RH_CLASS_OUT = 0, RH_CLASS_IN, RH_CLASS_BOUNDARY };
/* Section 4.3: in when every voxel centre the cell covers is deeper than
 * tau, out when every one is outside, else boundary. */
enum rh_class rh_classify(const struct rh_frame *f, const struct rh_vox *vx,
			  const struct rh_cell *c);
/* The initial adaptive hierarchy (section 4.3): from the roots, boundary
 * cells split while they can, inside cells become cavity leaves, boundary
 * cells at the minimum size solid.  t must be freshly initialised. */
int rh_tree_build(struct rh_tree *t, const struct rh_vox *vx, int threads, struct err *e);

/* ---- carve.c: cavities, layers, mesh output ---- */

/* The cavities of a tree sorted by zlo, for slicing. */
struct rh_carve {
	struct rh_frame f;
	struct rh_cavity *cv; /* owned, sorted by zlo */
	size_t n;
	size_t next;          /* first cavity not yet activated (z sweep) */
	size_t *active;       /* indices of cavities with zlo < z (pruned lazily) */
	size_t nactive;
	double last_z;
	struct paths rects;   /* scratch */
};

int rh_carve_init(struct rh_carve *cr, const struct rh_tree *t, struct err *e);
void rh_carve_fini(struct rh_carve *cr);
/* The cavity rectangles at height z (nm, printer frame, CCW), replacing
 * *out.  Successive calls with non-decreasing z are incremental. */
int rh_carve_rects(struct rh_carve *cr, double z_mm, struct paths *out, struct err *e);
/* Horizontal section of one cavity at z: 0 when z is outside (zlo, zhi),
 * else 1 and the rectangle's u half-width and centre. */
int rh_cavity_section(const struct rh_cavity *cv, double z_mm, double *half_u_mm);
/* The part mesh plus every cavity as a closed rhombic prism (8 vertices,
 * 12 triangles, facing into the cavity).  Caller frees with mesh_free. */
int rh_carve_mesh(const struct rh_carve *cr, const struct mesh *part, struct mesh **out,
		  struct err *e);

#endif
