/* stack.h - the hybrid engine's designed layer stack (stack.c): the
 * partition and the structures composed into every layer on the design
 * grid, and the top-down support rule.  docs/hybrid.md, "The design grid
 * and the support rule".
 */
#ifndef INFILLD_HYBRID_STACK_H
#define INFILLD_HYBRID_STACK_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/raster.h"
#include "engine/geom/vec.h"
#include "engine/hybrid/hybrid.h"
#include "engine/hybrid/structure.h"

struct err;
struct mesh;
struct progress;

/* ---- stack.c: the designed layer stack ---- */

/* Bit planes of every layer on the design grid (pitch_mm square pixels
 * over the part's box, the slice/erode.h grid): bit j * w + i of layer k
 * in words [k * words, (k + 1) * words).  part: pixel centre inside the
 * part; interior: at least the shell's thickness from the outside (3D);
 * voids: interior pixels left empty by the design; tcsr: interior pixels
 * whose structure is the crystal lattice (their support rule uses the
 * struts' angle).  Material = part & !voids. */
struct hy_stack {
	int w, h, layers;
	struct raster_map map;  /* printer mm -> design-grid pixel coordinates */
	double pitch_mm, layer_mm;
	size_t words;           /* uint64_t words per plane of one layer */
	uint64_t *part, *interior, *voids, *tcsr;
};

enum hy_structure { HY_STRUCT_HYBRID = 0, HY_STRUCT_TCS, HY_STRUCT_MFS };

/* What stack.c composes: the partition, the structures and the rules. */
struct hy_design {
	int structure;                 /* enum hy_structure */
	const struct hy_labeler *labels; /* HY_STRUCT_HYBRID only */
	const struct hy_parts *parts;    /* HY_STRUCT_HYBRID only */
	struct hy_mfs *const *mfs;     /* per part (NULL for non-VCol) in hybrid
					  mode; mfs[0] for the whole interior in
					  HY_STRUCT_MFS */
	struct capsule *caps;          /* TCS balls and sticks (owned by the caller;
					  the extended support columns are appended
					  by hy_stack_columns, which may realloc) */
	size_t ncaps, caps_cap;
	double transient_mm;           /* thickness of the transient layer across
					  each VCol part's base plane */
	double bridge_mm;              /* width of its connecting bridges */
	double tcs_cell_mm;            /* length of the extended support columns */
	double column_mm;              /* their diameter */
	double column_spacing_mm;      /* their Poisson-disk spacing */
	double r_alpha_mm;             /* h tan(alpha): the support rule, MFS side */
	double r_tcs_mm;               /* h tan(alpha_tcs): TCS side */
	int threads;
	uint64_t seed;
	int raw;                       /* 1: skip the support rule (the candidates
					  as composed; for tests of the checker) */
};

struct hy_stack_report {
	size_t columns;             /* extended support columns added */
	size_t transient_px;        /* transient-layer pixels, all layers */
	size_t filled_px;           /* void pixels filled by the support rule */
	double overhang_mm2;        /* material of layer k+1 farther than h tan(alpha)
				       from material of layer k, over the part's
				       interior (the struts' own angle) */
	double material_mm3, part_mm3;
	double seconds_interior, seconds_compose, seconds_support;
};

/* The part's and interior planes of every layer (mesh sliced and eroded
 * in 3D by shell_mm on a grid of pitch_mm over box).  0, ERR_LIMIT
 * (grid too large, field "grid_mm"), ERR_NOMEM, slicing errors. */
int hy_stack_init(struct hy_stack *st, const struct mesh *m, struct box3 box, double pitch_mm,
		  double layer_mm, int layers, double shell_mm, struct progress *pg,
		  struct err *e);
/* Section 6.2 for every VCol part of a hybrid design: the extended
 * support columns, appended to d->caps.  Before hy_stack_compose. */
int hy_stack_columns(const struct hy_stack *st, struct hy_design *d, size_t *ncolumns,
		     struct err *e);
/* Sections 5-6: every layer's voids from the structures, then the support
 * rule top-down (docs/hybrid.md "Printability").  Fills rep. */
int hy_stack_compose(struct hy_stack *st, const struct hy_design *d, struct progress *pg,
		     struct hy_stack_report *rep, struct err *e);
/* 1 when design pixel (i, j) of layer k is material; 0 outside the grid. */
int hy_stack_material(const struct hy_stack *st, int k, int i, int j);
/* 1 when it is a void of the design (interior left empty). */
int hy_stack_void(const struct hy_stack *st, int k, int i, int j);
/* Element densities for the FEA: the material fraction of every cube of
 * edge h_mm over the part's box (grid g allocated and filled as
 * fea_voxelize_mesh would; solid_part != 0: the part itself, no voids). */
struct fea_grid;
int hy_stack_fea_grid(const struct hy_stack *st, struct box3 box, double h_mm, int solid_part,
		      size_t max_elements, struct fea_grid *g, struct err *e);
/* The material as a closed manifold mesh: block averages of bx x bx
 * pixels x bz layers, marching tetrahedra (mesh/isosurface.h) at the
 * level that aims at the material's volume (a secant, 0.2 %, the level
 * in [0.25, 0.75]); fit (may be NULL) receives the level used and the
 * mesh's volume. */
struct hy_mesh_fit {
	double iso;        /* iso level of the mesh kept */
	double volume_mm3; /* its volume (divergence theorem) */
};
int hy_stack_mesh(const struct hy_stack *st, int bx, int bz, size_t max_triangles,
		  struct mesh **out, struct hy_mesh_fit *fit, struct err *e);
void hy_stack_fini(struct hy_stack *st);

#endif
