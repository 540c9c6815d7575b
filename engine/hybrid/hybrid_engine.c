/* hybrid_engine.c - engine_ops of `hybrid` (hybrid_engine.h): parameters,
 * validation, prepare (partition -> verification -> structures -> layer
 * stack), layers, mesh output and metrics.  Method, deviations and
 * figures: docs/hybrid.md.
 */
#include "engine/hybrid/hybrid_engine.h"
#include "engine/hybrid/stack.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"
#include "engine/geom/clip.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HY_FEA_MAX ((size_t)4 << 20)
/* elements of the verification and compliance analyses: the part's
 * height / HY_FEA_DIV unless fea_voxel_mm is given */
#define HY_FEA_DIV 60.0
#define HY_MAX_CAPS ((size_t)16 << 20)
#define HY_MESH_MAX_TRIANGLES ((size_t)40 << 20)
/* the crystal's support rule leans this much more than its sticks */
#define HY_TCS_ALPHA_MARGIN_DEG 5.0

struct hy_params {
	int structure;
	double sdf_alpha;
	double sdf_threshold;
	int sdf_rays;
	double sdf_cone_deg;
	double merge_pct;
	double dominance;
	double stress_floor;
	double load_n;
	double contact_pct;
	double wall_mm;
	double mfs_cell_mm;
	char mfs_template[1024];
	double mfs_template_mm;
	double tcs_cell_mm;
	double tcs_ball_mm;
	double tcs_stick_mm;
	double tcs_alpha_deg;
	double transient_mm;
	double column_mm;
	double column_spacing_mm;
	double skin_mm;
	double grid_mm;
	double label_voxel_mm;
	double fea_voxel_mm;
	double mesh_voxel_mm;
	int compliance;
	char loads[4096];
	int seed;
};

static const char *const structure_names[] = {"hybrid", "tcs", "mfs", NULL};

#define P(f) offsetof(struct hy_params, f)
static const struct param_desc hy_desc[] = {
	{.name = "structure", .type = PARAM_ENUM, .offset = P(structure), .def = HY_STRUCT_HYBRID,
	 .choices = structure_names, .unit = "",
	 .help = "hybrid: muscle fibres in the verified columns and the crystal elsewhere (the "
		 "paper's method); tcs or mfs: one structure everywhere (the paper's comparison)."},
	{.name = "sdf_alpha", .type = PARAM_NUM, .offset = P(sdf_alpha), .min = 0, .max = 1000,
	 .def = 4, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "alpha of the shape diameter's log normalisation (section 4.1; paper: 4)."},
	{.name = "sdf_threshold", .type = PARAM_NUM, .offset = P(sdf_threshold), .min = 0,
	 .max = 1, .def = 0.5, .unit = "",
	 .help = "Facets whose normalised shape diameter is below this are column candidates "
		 "(section 4.1; paper: 0.26, which keeps stout legs such as an elephant's or a "
		 "camel's in the body: docs/hybrid.md)."},
	{.name = "sdf_rays", .type = PARAM_INT, .offset = P(sdf_rays), .min = 3, .max = 512,
	 .def = 30, .unit = "", .help = "Rays per facet of the shape diameter function."},
	{.name = "sdf_cone_deg", .type = PARAM_NUM, .offset = P(sdf_cone_deg), .min = 1, .max = 179,
	 .def = 120, .unit = "deg", .help = "Opening angle of the rays' cone (Shapira et al.: 120)."},
	{.name = "merge_pct", .type = PARAM_NUM, .offset = P(merge_pct), .min = 0, .max = 50,
	 .def = 1, .unit = "%",
	 .help = "Facet components smaller than this share of the surface area are merged into "
		 "their neighbour."},
	{.name = "dominance", .type = PARAM_NUM, .offset = P(dominance), .min = 1, .max = 1000,
	 .def = 2, .unit = "",
	 .help = "A column candidate is a valid column (VCol) when its largest mean stress "
		 "component is at least this many times the second, under both of the paper's "
		 "loads (section 4.2)."},
	{.name = "stress_floor", .type = PARAM_NUM, .offset = P(stress_floor), .min = 0, .max = 1,
	 .def = 0.05, .unit = "",
	 .help = "... and at least this fraction of the largest one over all candidates: a part "
		 "that carries nothing is no column."},
	{.name = "load_n", .type = PARAM_NUM, .offset = P(load_n), .min = 0, .max = 1e7,
	 .def = 1000, .flags = PARAM_F_MIN_EXCL, .unit = "N",
	 .help = "Force of the verification loads on the part's top (paper: 1000 N, straight "
		 "down and at 45 degrees)."},
	{.name = "contact_pct", .type = PARAM_NUM, .offset = P(contact_pct), .min = 0, .max = 50,
	 .def = 3, .unit = "%",
	 .help = "The verification fixes what lies within this share of the part's height above "
		 "the plate (feet modelled a little apart all stand; at least half an element)."},
	{.name = "wall_mm", .type = PARAM_NUM, .offset = P(wall_mm), .min = 0, .max = 100,
	 .def = 0.8, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Wall thickness of the muscle-fibre cells (and the least a template's walls are "
		 "thickened to)."},
	{.name = "mfs_cell_mm", .type = PARAM_NUM, .offset = P(mfs_cell_mm), .min = 0, .max = 1000,
	 .def = 4, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Spacing of the muscle-fibre cells (Poisson-disk radius of their Voronoi "
		 "sites)."},
	{.name = "mfs_template", .type = PARAM_STR, .offset = P(mfs_template), .max = 1023,
	 .str_cap = 1024, .flags = PARAM_F_PATH, .unit = "",
	 .help = "A PNG muscle-fibre section (white = material), tiled instead of the Voronoi "
		 "cells (CLI only)."},
	{.name = "mfs_template_mm", .type = PARAM_NUM, .offset = P(mfs_template_mm), .min = 0,
	 .max = 100, .def = 0.1, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Pixel pitch of mfs_template in the part."},
	{.name = "tcs_cell_mm", .type = PARAM_NUM, .offset = P(tcs_cell_mm), .min = 0, .max = 1000,
	 .def = 6, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Edge of the diamond crystal's cubic cell (8 balls, 16 sticks)."},
	{.name = "tcs_ball_mm", .type = PARAM_NUM, .offset = P(tcs_ball_mm), .min = 0, .max = 100,
	 .def = 1.6, .unit = "mm", .help = "Diameter of the crystal's balls (0 = sticks only)."},
	{.name = "tcs_stick_mm", .type = PARAM_NUM, .offset = P(tcs_stick_mm), .min = 0, .max = 100,
	 .def = 1.2, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Diameter of the crystal's sticks."},
	{.name = "tcs_alpha_deg", .type = PARAM_NUM, .offset = P(tcs_alpha_deg), .min = 0, .max = 85,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "deg",
	 .help = "Overhang the support rule allows on the crystal's side; 0 = the sticks' own "
		 "angle (54.7 deg) + 5, so the sticks stand as designed."},
	{.name = "transient_mm", .type = PARAM_NUM, .offset = P(transient_mm), .min = 0, .max = 100,
	 .def = 1.0, .unit = "mm",
	 .help = "Thickness of the transient layer across each column's interface (section 6.1; 0 "
		 "= none)."},
	{.name = "column_mm", .type = PARAM_NUM, .offset = P(column_mm), .min = 0, .max = 100,
	 .def = 1.0, .unit = "mm",
	 .help = "Diameter of the extended support columns (section 6.2; 0 = none)."},
	{.name = "column_spacing_mm", .type = PARAM_NUM, .offset = P(column_spacing_mm), .min = 0,
	 .max = 1000, .def = 3, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Poisson-disk spacing of the extended support columns."},
	{.name = "skin_mm", .type = PARAM_NUM, .offset = P(skin_mm), .min = 0, .max = 100,
	 .def = 0.8, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Solid outer shell; a common shell_mm > 0 replaces it."},
	{.name = "grid_mm", .type = PARAM_NUM, .offset = P(grid_mm), .min = 0, .max = 10,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Pixel of the design grid; 0 = the resin printer's pixel, or 0.1 mm."},
	{.name = "label_voxel_mm", .type = PARAM_NUM, .offset = P(label_voxel_mm), .min = 0,
	 .max = 100, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Voxel of the volumetric partition; 0 = the part's height / 120."},
	{.name = "fea_voxel_mm", .type = PARAM_NUM, .offset = P(fea_voxel_mm), .min = 0, .max = 100,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Element edge of the verification and compliance analyses; 0 = the part's "
		 "height / 60, at least two layers."},
	{.name = "mesh_voxel_mm", .type = PARAM_NUM, .offset = P(mesh_voxel_mm), .min = 0,
	 .max = 10, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Sample spacing of the mesh output (marching tetrahedra); 0 = 0.25 mm."},
	{.name = "compliance", .type = PARAM_BOOL, .offset = P(compliance), .def = 1, .unit = "",
	 .help = "Measure the design's compliance under `loads` against the solid part's (two "
		 "FEA solves)."},
	{.name = "loads", .type = PARAM_STR, .offset = P(loads), .max = 4095, .str_cap = 4096,
	 .unit = "",
	 .help = "Load case of the compliance measure in the FEA text form (docs/fea.md); empty "
		 "= the plate fixed and 1000 N down on the top."},
	{.name = "seed", .type = PARAM_INT, .offset = P(seed), .min = 0, .max = 1 << 30, .def = 1,
	 .unit = "", .help = "Seed of the rays and of the Poisson-disk sites."},
};
#undef P

struct hy_job {
	struct hy_params p;
	const struct mesh *mesh;
	struct mesh_bvh *bvh;
	struct hy_parts parts;
	struct hy_labeler *labels;
	struct hy_stress *stress;    /* per final part */
	struct hy_mfs **mfs;         /* per part, or [0] in mfs mode */
	size_t nmfs;
	struct hy_design d;
	struct hy_stack st;
	struct hy_stack_report rep;
	struct slicer *slicer;
	struct mesh *result;
	struct hy_mesh_fit mesh_fit; /* its iso level and volume (hy_stack_mesh) */
	struct paths voids;
	float *field;                /* void field for G-code regions */
	struct box3 box;
	const struct raster_map *map; /* the driver's, when it wants pixels */
	double shell_mm, pitch_mm, tcs_steepest_deg, tcs_alpha_deg;
	double s_sdf, s_parts, s_labels, s_verify, s_fea, s_structures;
	double compliance_nmm, compliance_solid_nmm;
	double fea_voxel_mm;
	size_t ncols, ncaps_tcs;
	int antialias, did_compliance, layers_out;
	double sdf_min, sdf_max;
	char loads_text[4096];
};

static struct fea_material hy_material(const struct printer *printer)
{
	struct fea_material m = {FEA_RESIN_E_MPA, FEA_RESIN_NU};

	if (printer && printer->kind == PRINTER_FDM) {
		m.E_mpa = FEA_PLA_E_MPA;
		m.nu = FEA_PLA_NU;
	}
	return m;
}

static int hy_validate(const void *params, const struct common_params *common,
		       const struct printer *printer, struct err *e)
{
	const struct hy_params *p = params;

	if (!(common->alpha_deg >= 5 && common->alpha_deg <= 85))
		return ERR_FIELD(e, "alpha_deg",
				 "the hybrid engine needs alpha_deg in [5, 85]; %g is outside",
				 common->alpha_deg);
	if (p->tcs_stick_mm >= p->tcs_cell_mm * sqrt(3) / 4)
		return ERR_FIELD(e, "tcs_stick_mm",
				 "tcs_stick_mm (%g) must be thinner than the crystal's bond length "
				 "sqrt(3)/4 tcs_cell_mm (%g mm)",
				 p->tcs_stick_mm, p->tcs_cell_mm * sqrt(3) / 4);
	if (p->tcs_ball_mm >= p->tcs_cell_mm * sqrt(3) / 4)
		return ERR_FIELD(e, "tcs_ball_mm",
				 "tcs_ball_mm (%g) must be below the bond length sqrt(3)/4 "
				 "tcs_cell_mm (%g mm): balls would swallow the sticks",
				 p->tcs_ball_mm, p->tcs_cell_mm * sqrt(3) / 4);
	if (p->wall_mm >= p->mfs_cell_mm)
		return ERR_FIELD(e, "wall_mm",
				 "wall_mm (%g) must be below mfs_cell_mm (%g): the cells would be "
				 "solid",
				 p->wall_mm, p->mfs_cell_mm);
	if (p->tcs_alpha_deg > 0 && p->tcs_alpha_deg < common->alpha_deg)
		return ERR_FIELD(e, "tcs_alpha_deg",
				 "tcs_alpha_deg (%g) must be 0 (automatic) or at least alpha_deg (%g)",
				 p->tcs_alpha_deg, common->alpha_deg);
	if (p->compliance) {
		struct fea_loads l;
		int rc = fea_loads_parse(p->loads, hy_material(printer), &l, e);
		if (rc)
			return rc;
		fea_loads_fini(&l);
	}
	return 0;
}

static void hy_release(void *state);

/* Section 4: SDF -> facet parts -> labels -> verification -> NCol merges. */
static int partition(struct hy_job *s, const struct engine_ctx *ctx, struct err *e)
{
	const struct mesh *m = ctx->mesh;
	struct hy_sdf_opts so;
	struct hy_verify_opts vo;
	struct fea_material mat = hy_material(ctx->printer);
	double *sdf = NULL, *nsdf = NULL, t0 = progress_now_s(), vs = 0;
	double height = box3_size(s->box).z;
	int *remap = NULL;
	size_t n0;
	int rc;

	sdf = mem_alloc(m->nt * sizeof *sdf);
	nsdf = mem_alloc(m->nt * sizeof *nsdf);
	if (!sdf || !nsdf) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu facets' SDF", m->nt);
		goto out;
	}
	if ((rc = mesh_bvh_new(m, &s->bvh, e)) != 0)
		goto out;
	memset(&so, 0, sizeof so);
	so.rays = s->p.sdf_rays;
	so.cone_deg = s->p.sdf_cone_deg;
	so.threads = ctx->threads;
	so.seed = (uint64_t)s->p.seed;
	if ((rc = hy_sdf(m, s->bvh, &so, sdf, e)) != 0)
		goto out;
	s->sdf_min = INFINITY;
	s->sdf_max = -INFINITY;
	for (size_t i = 0; i < m->nt; i++) {
		s->sdf_min = fmin(s->sdf_min, sdf[i]);
		s->sdf_max = fmax(s->sdf_max, sdf[i]);
	}
	hy_nsdf(sdf, m->nt, s->p.sdf_alpha, nsdf);
	s->s_sdf = progress_now_s() - t0;
	if ((rc = progress_update(ctx->progress, 0.05, e)) != 0)
		goto out;
	t0 = progress_now_s();
	if ((rc = hy_parts_build(m, nsdf, sdf, s->p.sdf_threshold, s->p.merge_pct / 100,
				 &s->parts, e)) != 0)
		goto out;
	s->s_parts = progress_now_s() - t0;
	t0 = progress_now_s();
	if ((rc = hy_labeler_new(m, s->bvh, &s->parts,
				 s->p.label_voxel_mm > 0 ? s->p.label_voxel_mm : height / 120,
				 ctx->threads, &s->labels, e)) != 0)
		goto out;
	s->s_labels = progress_now_s() - t0;
	if ((rc = progress_update(ctx->progress, 0.1, e)) != 0)
		goto out;
	/* section 4.2 */
	s->stress = mem_calloc(s->parts.n ? s->parts.n : 1, sizeof *s->stress);
	remap = mem_alloc((s->parts.n ? s->parts.n : 1) * sizeof *remap);
	if (!s->stress || !remap) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu parts", s->parts.n);
		goto out;
	}
	memset(&vo, 0, sizeof vo);
	vo.load_n = s->p.load_n;
	vo.fea_voxel_mm = s->fea_voxel_mm;
	vo.dominance = s->p.dominance;
	vo.floor_frac = s->p.stress_floor;
	vo.E_mpa = mat.E_mpa;
	vo.nu = mat.nu;
	vo.contact_mm = s->p.contact_pct / 100 * height;
	vo.max_elements = HY_FEA_MAX;
	vo.threads = ctx->threads;
	if ((rc = hy_verify(m, s->labels, &s->parts, &vo, s->stress, &vs, e)) != 0)
		goto out;
	s->s_verify = vs;
	/* neighbouring NCol parts merge; remap[original] = current */
	n0 = s->parts.n;
	for (size_t i = 0; i < n0; i++)
		remap[i] = (int)i;
	for (;;) {
		size_t a = 0, b = 0;
		int found = 0;
		for (size_t i = 0; i < s->parts.n && !found; i++)
			for (size_t j = i + 1; j < s->parts.n && !found; j++)
				if (s->parts.p[i].cls == HY_NCOL && s->parts.p[j].cls == HY_NCOL &&
				    s->parts.shared_mm[i * s->parts.n + j] > 0) {
					a = i;
					b = j;
					found = 1;
				}
		if (!found)
			break;
		/* the merged part keeps the stresses of the one with more elements */
		if (s->stress[b].elements > s->stress[a].elements)
			s->stress[a] = s->stress[b];
		memmove(&s->stress[b], &s->stress[b + 1],
			(s->parts.n - b - 1) * sizeof *s->stress);
		if ((rc = hy_parts_merge(&s->parts, m, a, b, e)) != 0)
			goto out;
		for (size_t i = 0; i < n0; i++) {
			if (remap[i] == (int)b)
				remap[i] = (int)a;
			else if (remap[i] > (int)b)
				remap[i]--;
		}
	}
	hy_labeler_remap(s->labels, &s->parts, remap);
out:
	mem_free(remap);
	mem_free(sdf);
	mem_free(nsdf);
	return rc;
}

/* Sections 5.1-5.2: the muscle fibres of every VCol part (or one for the
 * whole interior) and the crystal's balls and sticks. */
static int structures(struct hy_job *s, const struct engine_ctx *ctx, struct err *e)
{
	struct vec3 sz = box3_size(s->box), c = box3_center(s->box);
	double extent = v3_len(sz) / 2 + s->p.mfs_cell_mm;
	size_t nparts = s->p.structure == HY_STRUCT_HYBRID ? s->parts.n : 1;
	int rc = 0;

	(void)ctx;
	if (s->p.structure != HY_STRUCT_TCS) {
		s->mfs = mem_calloc(nparts ? nparts : 1, sizeof *s->mfs);
		if (!s->mfs)
			return ERR_SET(e, ERR_NOMEM, "out of memory");
		s->nmfs = nparts;
		for (size_t i = 0; i < nparts && rc == 0; i++) {
			struct vec3 axis = v3(0, 0, 1), org = c;
			if (s->p.structure == HY_STRUCT_HYBRID) {
				if (s->parts.p[i].cls != HY_VCOL)
					continue;
				axis = s->parts.p[i].axis;
				org = s->parts.p[i].base_mm;
			}
			if (s->p.mfs_template[0])
				rc = hy_mfs_new_template(axis, org, s->p.mfs_template,
							 s->p.mfs_template_mm, s->p.wall_mm,
							 &s->mfs[i], e);
			else
				rc = hy_mfs_new_voronoi(axis, org, extent, s->p.mfs_cell_mm,
							s->p.wall_mm, (uint64_t)s->p.seed + i,
							&s->mfs[i], e);
		}
		if (rc) {
			if (!e->field[0])
				snprintf(e->field, sizeof e->field, "%s",
					 s->p.mfs_template[0] ? "mfs_template" : "mfs_cell_mm");
			return rc;
		}
	}
	if (s->p.structure != HY_STRUCT_MFS) {
		struct vec3 lo = s->box.lo, hi = s->box.hi, shift = v3(0, 0, 0);
		if ((rc = hy_tcs_build(lo, hi, s->p.tcs_cell_mm, s->p.tcs_ball_mm / 2,
				       s->p.tcs_stick_mm, shift, HY_MAX_CAPS, &s->d.caps,
				       &s->d.ncaps, &s->tcs_steepest_deg, e)) != 0) {
			if (rc == ERR_LIMIT)
				snprintf(e->field, sizeof e->field, "tcs_cell_mm");
			return rc;
		}
		s->d.caps_cap = s->d.ncaps;
		s->ncaps_tcs = s->d.ncaps;
	}
	return 0;
}

/* Compliance of the design and of the solid part under the load case. */
static int compliance(struct hy_job *s, const struct engine_ctx *ctx, struct err *e)
{
	struct fea_loads l;
	struct fea_opts fo;
	double t0 = progress_now_s();
	int rc;

	if ((rc = fea_loads_parse(s->p.loads, hy_material(ctx->printer), &l, e)) != 0)
		return rc;
	fea_loads_format(&l, s->loads_text, sizeof s->loads_text, NULL);
	fea_opts_default(&fo);
	fo.threads = ctx->threads;
	fo.penal = 1; /* walls thinner than an element keep their stiffness */
	for (int solid = 0; solid < 2 && rc == 0; solid++) {
		struct fea_grid g;
		struct fea_solver *sv = NULL;
		struct fea_result r;
		if ((rc = hy_stack_fea_grid(&s->st, s->box, s->fea_voxel_mm, solid, HY_FEA_MAX, &g,
					    e)) != 0)
			break;
		rc = fea_solver_new(&g, &l, &fo, &sv, e);
		fea_grid_fini(&g);
		if (rc == 0 && (rc = fea_solve(sv, &r, e)) == 0)
			*(solid ? &s->compliance_solid_nmm : &s->compliance_nmm) = r.compliance_nmm;
		fea_solver_free(sv);
	}
	fea_loads_fini(&l);
	s->s_fea = progress_now_s() - t0;
	s->did_compliance = rc == 0;
	return rc;
}

/* A layer output whose layers may overhang less than one design pixel
 * (alpha 30 at 0.05 mm layers on 0.047 mm pixels: 0.029 mm): the support
 * rule's whole pixels cannot widen a cavity under its ridge, so the MFS
 * cells fill; say so in the job's warnings. */
static int warn_sub_pixel(struct metrics *m, double alpha_deg, double layer_mm, double reach_mm,
			  double pitch_mm, struct err *e)
{
	char msg[400];

	snprintf(msg, sizeof msg,
		 "hybrid: at alpha_deg %g and layer_mm %g a layer may overhang %.3f mm, less than "
		 "the %.3f mm design pixel, so no cavity can widen below its roof and most voids are "
		 "filled (see hybrid.support_filled_mm3); raise layer_mm or alpha_deg, or write a "
		 "mesh (stl/obj), which designs on layers of pixel / tan(alpha)",
		 alpha_deg, layer_mm, reach_mm, pitch_mm);
	if (metrics_append_str(m, "warnings", msg))
		return ERR_SET(e, ERR_NOMEM, "out of memory recording a warning");
	return 0;
}

static int hy_prepare(const struct engine_ctx *ctx, const void *params, void **out,
		      struct err *e)
{
	struct hy_job *s;
	double alpha = ctx->common->alpha_deg * M_PI / 180, layer_mm = ctx->layer_mm, t0;
	int layers, rc;

	if (!ctx->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the hybrid engine needs a mesh");
	if (!(s = mem_calloc(1, sizeof *s)))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	memcpy(&s->p, params, sizeof s->p);
	paths_init(&s->voids);
	s->mesh = ctx->mesh;
	s->map = ctx->want_raster ? ctx->map : NULL;
	s->box = ctx->report->bbox;
	s->shell_mm = ctx->common->shell_mm > 0 ? ctx->common->shell_mm : s->p.skin_mm;
	s->antialias = ctx->printer->kind == PRINTER_RESIN ? ctx->printer->resin.antialias : 0;
	s->pitch_mm = s->p.grid_mm > 0			   ? s->p.grid_mm
		      : ctx->want_raster && ctx->map ? sqrt(raster_map_pixel_area_mm2(ctx->map))
						     : 0.1;
	/* A mesh output has no print layers: its design layers are tall enough
	 * for the support rule to widen a cavity by one grid pixel a layer at
	 * alpha.  At the print layer (0.05 mm under 0.1 mm pixels at 45 deg:
	 * half a pixel) no cavity could widen below its ridge and the rule
	 * filled every void. */
	if (!ctx->want_raster && !ctx->want_region)
		layer_mm = fmax(layer_mm, s->pitch_mm / tan(alpha));
	s->fea_voxel_mm = s->p.fea_voxel_mm > 0
				  ? s->p.fea_voxel_mm
				  : fmax(box3_size(s->box).z / HY_FEA_DIV, 2 * layer_mm);
	layers = layer_count_for(s->box.hi.z, layer_mm);
	if (layers < 1) {
		rc = ERR_SET(e, ERR_GEOMETRY, "the part has no height (%g mm)", s->box.hi.z);
		goto fail;
	}
	if (s->p.structure == HY_STRUCT_HYBRID && (rc = partition(s, ctx, e)) != 0)
		goto fail;
	t0 = progress_now_s();
	if ((rc = structures(s, ctx, e)) != 0)
		goto fail;
	s->s_structures = progress_now_s() - t0;
	s->tcs_alpha_deg = s->p.tcs_alpha_deg > 0
				   ? s->p.tcs_alpha_deg
				   : fmax(ctx->common->alpha_deg,
					  fmin(85, s->tcs_steepest_deg + HY_TCS_ALPHA_MARGIN_DEG));
	s->d.structure = s->p.structure;
	s->d.labels = s->labels;
	s->d.parts = &s->parts;
	s->d.mfs = s->mfs;
	s->d.transient_mm = s->p.transient_mm;
	s->d.bridge_mm = s->p.wall_mm;
	s->d.tcs_cell_mm = s->p.tcs_cell_mm;
	s->d.column_mm = s->p.column_mm;
	s->d.column_spacing_mm = s->p.column_spacing_mm;
	s->d.r_alpha_mm = layer_mm * tan(alpha);
	s->d.r_tcs_mm = layer_mm * tan(s->tcs_alpha_deg * M_PI / 180);
	if (s->d.r_alpha_mm < s->pitch_mm && ctx->metrics &&
	    (rc = warn_sub_pixel(ctx->metrics, ctx->common->alpha_deg, layer_mm,
				 s->d.r_alpha_mm, s->pitch_mm, e)) != 0)
		goto fail;
	s->d.threads = ctx->threads;
	s->d.seed = (uint64_t)s->p.seed;
	if ((rc = hy_stack_init(&s->st, ctx->mesh, s->box, s->pitch_mm, layer_mm, layers,
				s->shell_mm, ctx->progress, e)) != 0)
		goto fail;
	s->rep.seconds_interior = progress_now_s() - t0 - s->s_structures;
	if ((rc = progress_update(ctx->progress, 0.3, e)) != 0 ||
	    (rc = hy_stack_columns(&s->st, &s->d, &s->ncols, e)) != 0)
		goto fail;
	{
		double si = s->rep.seconds_interior;
		if ((rc = hy_stack_compose(&s->st, &s->d, ctx->progress, &s->rep, e)) != 0)
			goto fail;
		s->rep.seconds_interior = si;
	}
	if ((rc = progress_update(ctx->progress, 0.85, e)) != 0)
		goto fail;
	if (s->p.compliance && (rc = compliance(s, ctx, e)) != 0)
		goto fail;
	if ((rc = slice_new(ctx->mesh, &s->slicer, e)) != 0)
		goto fail;
	if (ctx->want_region &&
	    !(s->field = mem_alloc((size_t)s->st.w * s->st.h * sizeof *s->field))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a layer field");
		goto fail;
	}
	*out = s;
	return 0;
fail:
	hy_release(s);
	return rc;
}

/* Output pixels of map m covering box b (clamped to w x h). */
static void pixel_box(const struct raster_map *m, struct box3 b, int w, int h, int *i0, int *j0,
		      int *i1, int *j1)
{
	double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;

	for (int c = 0; c < 4; c++) {
		double u, v;
		raster_map_apply(m, (c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y, &u, &v);
		umin = fmin(umin, u);
		umax = fmax(umax, u);
		vmin = fmin(vmin, v);
		vmax = fmax(vmax, v);
	}
	*i0 = (int)fmax(0, floor(umin) - 1);
	*j0 = (int)fmax(0, floor(vmin) - 1);
	*i1 = (int)fmin(w - 1, ceil(umax) + 1);
	*j1 = (int)fmin(h - 1, ceil(vmax) + 1);
}

static int hy_layer(void *state, struct layer *ly, struct err *e)
{
	struct hy_job *s = state;
	struct hy_stack *st = &s->st;
	int k = ly->index, rc;

	if ((rc = slice_at(s->slicer, ly->z_mm, &ly->region, NULL, e)) != 0)
		return rc;
	ly->fill = LAYER_FILL_SOLID;
	s->layers_out++;
	if (k >= st->layers)
		return 0;
	if (ly->raster && s->map) {
		/* the part's exact coverage, emptied where the design has voids */
		struct raster *r = ly->raster;
		int i0, j0, i1, j1;
		if ((rc = slice_rasterize(&ly->region, s->map, s->antialias, r, e)) != 0)
			return rc;
		ly->raster_ready = 1;
		pixel_box(s->map, s->box, r->w, r->h, &i0, &j0, &i1, &j1);
		for (int j = j0; j <= j1; j++)
			for (int i = i0; i <= i1; i++) {
				double x, y, u, v;
				uint8_t *px = &r->px[(size_t)j * r->stride + i];
				if (!*px)
					continue;
				raster_map_invert(s->map, i + 0.5, j + 0.5, &x, &y);
				raster_map_apply(&st->map, x, y, &u, &v);
				if (hy_stack_void(st, k, (int)floor(u), (int)floor(v)))
					*px = 0;
			}
	}
	if (s->field) {
		/* G-code: the region minus the void contours */
		size_t n = (size_t)st->w * st->h;
		int any = 0;
		for (size_t i = 0; i < n; i++) {
			int v = hy_stack_void(st, k, (int)(i % st->w), (int)(i / st->w));
			s->field[i] = v ? 1.0f : 0.0f;
			any |= v;
		}
		paths_clear(&s->voids);
		if (any &&
		    ((rc = slice_field_contours(s->field, st->w, st->h, 0.5f, &st->map, &s->voids,
						e)) != 0 ||
		     (rc = clip_boolean(CLIP_DIFFERENCE, &ly->region, &s->voids, CLIP_FILL_NONZERO,
					&ly->region, e)) != 0))
			return rc;
	}
	return 0;
}

static int hy_result_mesh(void *state, const struct mesh **out, struct err *e)
{
	struct hy_job *s = state;
	int rc;

	if (!s->result) {
		double vox = s->p.mesh_voxel_mm > 0 ? s->p.mesh_voxel_mm : 0.25;
		int bx = (int)fmax(1, round(vox / s->st.pitch_mm));
		int bz = (int)fmax(1, round(vox / s->st.layer_mm));
		if ((rc = hy_stack_mesh(&s->st, bx, bz, HY_MESH_MAX_TRIANGLES, &s->result,
					 &s->mesh_fit, e)) != 0) {
			if (rc == ERR_LIMIT)
				snprintf(e->field, sizeof e->field, "mesh_voxel_mm");
			return rc;
		}
	}
	*out = s->result;
	return 0;
}

static const char *const class_names[] = {"NCol", "Col", "VCol"};

static int hy_metrics(void *state, struct metrics *m, struct err *e)
{
	struct hy_job *s = state;
	const struct hy_stack_report *r = &s->rep;
	char key[128], buf[160];
	int rc = 0, ncol = 0;

	rc |= metrics_str(m, "hybrid.structure", structure_names[s->p.structure]);
	if (s->p.structure == HY_STRUCT_HYBRID) {
		rc |= metrics_num(m, "hybrid.sdf_min_mm", s->sdf_min);
		rc |= metrics_num(m, "hybrid.sdf_max_mm", s->sdf_max);
		for (size_t i = 0; i < s->parts.n; i++) {
			const struct hy_part *q = &s->parts.p[i];
			const struct hy_stress *t = &s->stress[i];
#define K(x) (snprintf(key, sizeof key, "hybrid.components.%zu.%s", i, x), key)
			ncol += q->cls == HY_VCOL;
			rc |= metrics_str(m, K("class"), class_names[q->cls]);
			rc |= metrics_int(m, K("facets"), (long long)q->facets);
			rc |= metrics_num(m, K("area_mm2"), q->area_mm2);
			rc |= metrics_num(m, K("volume_mm3"),
					  (double)t->elements * pow(s->fea_voxel_mm, 3));
			rc |= metrics_num(m, K("sdf_mean_mm"), q->sdf_mean_mm);
			snprintf(buf, sizeof buf, "%.4f,%.4f,%.4f", q->axis.x, q->axis.y, q->axis.z);
			rc |= metrics_str(m, K("axis"), buf);
			snprintf(buf, sizeof buf, "%.3f,%.3f,%.3f", q->base_mm.x, q->base_mm.y,
				 q->base_mm.z);
			rc |= metrics_str(m, K("base_mm"), buf);
			rc |= metrics_num(m, K("radius_mm"), q->radius_mm);
			for (int c = 0; c < 2; c++) {
				snprintf(buf, sizeof buf, "%.5g,%.5g,%.5g", t->mean_mpa[c][0],
					 t->mean_mpa[c][1], t->mean_mpa[c][2]);
				rc |= metrics_str(m, K(c ? "mean_stress_mpa_45" : "mean_stress_mpa"),
						  buf);
				rc |= metrics_num(m, K(c ? "dominance_45" : "dominance"),
						  t->ratio[c]);
			}
#undef K
		}
		rc |= metrics_int(m, "hybrid.vcol_components", ncol);
		rc |= metrics_int(m, "hybrid.extended_columns", (long long)s->ncols);
		rc |= metrics_num(m, "hybrid.transient_mm2", r->transient_px * s->st.pitch_mm *
								       s->st.pitch_mm);
	}
	if (s->p.structure != HY_STRUCT_MFS) {
		rc |= metrics_int(m, "hybrid.tcs_capsules", (long long)s->ncaps_tcs);
		rc |= metrics_num(m, "hybrid.tcs_steepest_deg", s->tcs_steepest_deg);
		rc |= metrics_num(m, "hybrid.tcs_alpha_deg", s->tcs_alpha_deg);
	}
	rc |= metrics_num(m, "hybrid.shell_mm", s->shell_mm);
	rc |= metrics_num(m, "hybrid.grid_mm", s->st.pitch_mm);
	rc |= metrics_num(m, "hybrid.weight_fraction",
			  r->part_mm3 > 0 ? r->material_mm3 / r->part_mm3 : NAN);
	rc |= metrics_num(m, "hybrid.material_mm3", r->material_mm3);
	if (s->result) {
		rc |= metrics_num(m, "hybrid.mesh.iso", s->mesh_fit.iso);
		rc |= metrics_num(m, "hybrid.mesh.volume_mm3", s->mesh_fit.volume_mm3);
	}
	rc |= metrics_num(m, "hybrid.part_grid_mm3", r->part_mm3);
	rc |= metrics_num(m, "hybrid.support_filled_mm3",
			  r->filled_px * s->st.pitch_mm * s->st.pitch_mm * s->st.layer_mm);
	rc |= metrics_num(m, "hybrid.interior_overhang_mm2", r->overhang_mm2);
	rc |= metrics_int(m, "hybrid.islands", 0);
	if (s->did_compliance) {
		rc |= metrics_num(m, "hybrid.compliance_nmm", s->compliance_nmm);
		rc |= metrics_num(m, "hybrid.compliance_solid_nmm", s->compliance_solid_nmm);
		rc |= metrics_num(m, "hybrid.compliance_x_weight",
				  s->compliance_nmm * r->material_mm3 / r->part_mm3 /
					  s->compliance_solid_nmm);
		rc |= metrics_str(m, "hybrid.loads", s->loads_text);
	}
	rc |= metrics_num(m, "hybrid.fea_voxel_mm", s->fea_voxel_mm);
	rc |= metrics_num(m, "hybrid.seconds.sdf", s->s_sdf);
	rc |= metrics_num(m, "hybrid.seconds.parts", s->s_parts);
	rc |= metrics_num(m, "hybrid.seconds.labels", s->s_labels);
	rc |= metrics_num(m, "hybrid.seconds.verify", s->s_verify);
	rc |= metrics_num(m, "hybrid.seconds.structures", s->s_structures);
	rc |= metrics_num(m, "hybrid.seconds.interior", r->seconds_interior);
	rc |= metrics_num(m, "hybrid.seconds.compose", r->seconds_compose);
	rc |= metrics_num(m, "hybrid.seconds.support", r->seconds_support);
	rc |= metrics_num(m, "hybrid.seconds.compliance", s->s_fea);
	rc |= metrics_num(m, "material_volume_mm3", r->material_mm3);
	return rc ? ERR_SET(e, ERR_NOMEM, "out of memory recording metrics") : 0;
}

static void hy_release(void *state)
{
	struct hy_job *s = state;

	if (!s)
		return;
	for (size_t i = 0; i < s->nmfs; i++)
		hy_mfs_free(s->mfs[i]);
	mem_free(s->mfs);
	free(s->d.caps);
	hy_labeler_free(s->labels);
	hy_parts_fini(&s->parts);
	mem_free(s->stress);
	mesh_bvh_free(s->bvh);
	hy_stack_fini(&s->st);
	slice_free(s->slicer);
	mesh_free(s->result);
	paths_fini(&s->voids);
	mem_free(s->field);
	mem_free(s);
}

const struct engine_ops hybrid_engine = {
	.name = "hybrid",
	.summary = "Muscle-fibre columns and a diamond crystal elsewhere, split by shape and "
		   "stress, joined by transient layers; support-free and island-free.",
	.paper = "Mao, Wu, Yan, Guo, Chen, Chen: Generating hybrid interior structure for 3D "
		 "printing (Computer Aided Geometric Design 62, 2018)",
	.params = {"hybrid", hy_desc, sizeof hy_desc / sizeof hy_desc[0]},
	.params_size = sizeof(struct hy_params),
	.flags = ENGINE_F_MESH_OUTPUT,
	.prepare_share = 0.8,
	.validate = hy_validate,
	.prepare = hy_prepare,
	.layer = hy_layer,
	.metrics = hy_metrics,
	.result_mesh = hy_result_mesh,
	.release = hy_release,
};
