/* gen.h - lattice generation from a solid (paper 000 section 5).
 *
 * Pipeline (docs/lattice.md section 4): target density -> spacing by the
 * Appendix I cubic -> graded Poisson-disk samples of the part (surface and
 * interior) in a space compressed by 1/k along z (SO) -> Delaunay
 * tetrahedra (TetGen) restricted to the part -> stretched back by k ->
 * vertex position optimisation (PO) -> density matching (1:8 subdivision,
 * radius tuning, per-voxel common scaling) -> struts.
 */
#ifndef INFILLD_LATTICE_GEN_H
#define INFILLD_LATTICE_GEN_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/vec.h"
#include "engine/lattice/density.h"
#include "engine/lattice/lattice.h"

struct err;
struct mesh;
struct progress;

/* The part to fill, in the printer frame (mm). */
struct lattice_domain {
	struct box3 box;
	/* 1 when p is inside the part. */
	int (*inside)(void *ctx, struct vec3 p);
	/* Unsigned distance from p to the part's surface. */
	double (*distance)(void *ctx, struct vec3 p);
	void *ctx;
	const struct mesh *surface; /* boundary triangles (sampled for surface nodes) */
	int threads;
};

/* Tetrahedral mesh whose edges are the lattice's struts. */
struct lattice_tetmesh {
	struct vec3 *p;   /* nodes (mm) */
	size_t np, pcap;
	uint32_t *tet;    /* 4 per tet, positively oriented */
	size_t nt, tcap;
	uint8_t *fixed;   /* per node: 1 = on the boundary (never moved) */
};

void lattice_tetmesh_fini(struct lattice_tetmesh *t);
/* Unique undirected edges (a < b), sorted; caller frees *edges. */
int lattice_tetmesh_edges(const struct lattice_tetmesh *t, uint32_t **edges, size_t *nedges,
			  struct err *e);

/* ---- density estimate (Appendix I) ---- */

/* Target tetrahedron edge length L (mm) that realises solid fraction
 * `density` with struts of radius r_mm (material density 1): the largest
 * real root of L^3 + p L + q = 0, and at least 4 r.  density in (0, 1). */
double lattice_spacing_for_density(double density, double r_mm);
/* The model's predicted density for edge length L and radius r (the
 * cubic's left-hand side; used by tests). */
double lattice_density_estimate(double L_mm, double r_mm);

/* ---- sampling and tetrahedra (tetbuild.c) ---- */

struct lattice_build_opts {
	double so_k;          /* SO compression factor k >= 1 (1 = raw TetGen lattice) */
	double r_mm;          /* strut radius used by the spacing estimate */
	const struct lattice_density *density;
	uint64_t seed;
	size_t max_nodes;     /* refuse (ERR_LIMIT) beyond this */
	struct progress *progress; /* may be NULL */
};

struct lattice_build_stats {
	size_t surface_nodes, interior_nodes, delaunay_tets, kept_tets;
	double seconds_sample, seconds_tetgen, seconds_restrict;
};

/* Build the tetrahedral lattice mesh of the domain: nodes spaced by the
 * density estimate, meshed in the SO-compressed space and stretched back. */
int lattice_build_tetmesh(const struct lattice_domain *d, const struct lattice_build_opts *o,
			  struct lattice_tetmesh *out, struct lattice_build_stats *st,
			  struct err *e);

/* ---- self-supporting metrics and PO (support.c) ---- */

/* Risky fraction of a strut's projected area, eq. 12 (alpha = 45 deg: the
 * paper's polynomial) or eq. 20 integrated (other alpha); theta = angle
 * to the print direction, radians in [0, pi/2]. */
double lattice_support_g(double theta, double alpha);

struct lattice_support_metrics {
	double gamma; /* eq. 13, one radius for all struts (Table 3) */
	double psi;   /* eq. 14, length fraction of self-supported struts */
};
/* Over the unique edges of t (or of a lattice, below). */
void lattice_support_measure(const struct lattice_tetmesh *t, double alpha,
			     struct lattice_support_metrics *m);
void lattice_support_measure_lattice(const struct lattice *q, double alpha,
				     struct lattice_support_metrics *m);

struct lattice_po_opts {
	double alpha;      /* self-supporting angle (rad) */
	int max_rounds;    /* paper: 100 */
	uint64_t seed;
	struct progress *progress;
};
struct lattice_po_stats {
	int rounds;
	size_t moves;
	double gamma_before, gamma_after;
};
/* Vertex position optimisation (eq. 16-17): interior nodes in random
 * order, each moved along -grad J inside the inscribed (Chebyshev) sphere
 * of its star's kernel so no tetrahedron inverts; stops when no node moves,
 * Gamma stops decreasing, or after max_rounds. */
int lattice_po_optimize(struct lattice_tetmesh *t, const struct lattice_po_opts *o,
			struct lattice_po_stats *st, struct err *e);

/* ---- density matching (match.c) ---- */

struct lattice_match_opts {
	const struct lattice_density *density;
	double r_min_mm;       /* radius floor */
	double r_init_mm;      /* starting radius (paper: 2 r_min) */
	double support_factor; /* R = factor * largest radius */
	double voxel_mm;       /* voxel edge for matching and measuring */
	int max_subdiv;        /* 1:8 subdivision levels at most */
	int samples;           /* Monte-Carlo samples per voxel */
	int passes;            /* per-voxel common scaling passes */
	int threads;
	uint64_t seed;
	struct progress *progress;
};

struct lattice_match_stats {
	size_t voxels;            /* voxels matched (at least half inside the part) */
	size_t subdivided_tets;   /* tets split 1:8 */
	double error_mean, error_max; /* |density - target| per voxel, measured
					 independently after matching */
	double support_mm;        /* R of the result */
	double seconds_subdiv, seconds_tune, seconds_measure;
};

/* Turn the tet mesh into the final lattice *out (struts with radii, R
 * set) matching the target density per voxel. */
int lattice_match_density(struct lattice_tetmesh *t, const struct lattice_domain *d,
			  const struct lattice_match_opts *o, struct lattice **out,
			  struct lattice_match_stats *st, struct err *e);

/* Independent measurement: solid fraction of q per voxel by a regular
 * sub-grid of samples (not the matching's Monte-Carlo points) against the
 * target; over voxels at least half inside d.  Used by the metrics and
 * the tests. */
int lattice_measure_density(const struct lattice *q, const struct lattice_domain *d,
			    const struct lattice_density *target, double voxel_mm, int threads,
			    double *mean_err, double *max_err, size_t *voxels, struct err *e);

#endif
