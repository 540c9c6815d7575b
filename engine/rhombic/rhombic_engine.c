/* rhombic_engine.c - engine_ops of `rhombic` (rhombic_engine.h):
 * parameters, validation, prepare (voxels -> orientation search -> initial
 * hierarchy -> refinement for the objective), layers, mesh output and
 * metrics.  Method and figures: docs/rhombic.md.
 */
#include "engine/rhombic/rhombic_engine.h"
#include "engine/rhombic/optimize.h"
#include "engine/rhombic/rhombic.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"
#include "engine/geom/clip.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

/* Classification grid: voxels of wall_mm / 4 (four across the thinnest
 * wall) unless that makes more than RH_VOX_TARGET of them over the
 * part's box; never more than RH_VOX_MAX. */
#define RH_VOX_TARGET 8e6
#define RH_VOX_MAX ((size_t)64 << 20)
#define RH_ORIENT_STEP_DEG 15.0
/* Stiffness analysis: elements of wall_mm / 2, coarsened by 1.1 until the
 * part holds at most RH_FEA_TARGET of them (its volume / h^3) and its box
 * at most RH_FEA_BOX (the solver's vectors span the box). */
#define RH_FEA_TARGET 400000.0
#define RH_FEA_BOX 2e6
#define RH_FEA_MAX ((size_t)8 << 20)
#define RH_FEA_SUPERSAMPLE 4
/* Cavity elements: stiffness 0.1^3 = 1e-3 of the solid's (docs/rhombic.md,
 * "Deviations": at the paper's 0.001^3 the solver's tolerance leaves the
 * cavities' displacements, whose energies rank the cells, undetermined). */
#define RH_RHO_MIN 0.1
/* Relative residual of the solves that rank the cells (docs/rhombic.md,
 * "Stiffness": the ranking needs the energies, not the last digits). */
#define RH_FEA_TOL 1e-3

enum { RH_OBJ_STIFFNESS = 0, RH_OBJ_STABILITY };
enum { RH_REFINE_ADAPTIVE = 0, RH_REFINE_UNIFORM };

struct rh_params {
	int objective;
	int refine;
	double volume_fraction;
	double wall_mm;
	double skin_mm;
	double orient_deg;
	double split_pct;
	double fea_voxel_mm;
	double voxel_mm;
	int max_iterations;
	double penal;
	double rho_min;
	int sensitivity;
	int bound;
	double fea_tol;
	char loads[4096];
};

static const char *const objectives[] = {"stiffness", "stability", NULL};
static const char *const refines[] = {"adaptive", "uniform", NULL};
static const char *const sensitivities[] = {"density", "binary", NULL};

#define P(f) offsetof(struct rh_params, f)
static const struct param_desc rh_desc[] = {
	{.name = "objective", .type = PARAM_ENUM, .offset = P(objective), .def = RH_OBJ_STIFFNESS,
	 .choices = objectives, .unit = "",
	 .help = "What the refinement improves: stiffness under `loads` (eq. 5-13, needs FEA) or "
		 "static stability on the plate (eq. 14-16)."},
	{.name = "refine", .type = PARAM_ENUM, .offset = P(refine), .def = RH_REFINE_ADAPTIVE,
	 .choices = refines, .unit = "",
	 .help = "adaptive: split the cells the objective ranks first; uniform: split every "
		 "cell, step by step, until volume_fraction is reached (the paper's reference)."},
	{.name = "volume_fraction", .type = PARAM_NUM, .offset = P(volume_fraction), .min = 0,
	 .max = 1, .def = 0.7, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Most material as a fraction of the solid part (eq. 7); refinement stops before "
		 "exceeding it (uniform: at the first step reaching it)."},
	{.name = "wall_mm", .type = PARAM_NUM, .offset = P(wall_mm), .min = 0, .max = 100,
	 .def = 1.0, .flags = PARAM_F_MIN_EXCL, .unit = "mm",
	 .help = "Thinnest wall the printer makes (t_min): walls between cells are this thick, "
		 "and no cell is split below twice it (eq. 2)."},
	{.name = "skin_mm", .type = PARAM_NUM, .offset = P(skin_mm), .min = 0, .max = 100,
	 .def = 1.0, .unit = "mm",
	 .help = "Least solid skin between a cell and the part's surface (t_bnd, >= wall_mm); a "
		 "common shell_mm > 0 replaces it."},
	{.name = "orient_deg", .type = PARAM_NUM, .offset = P(orient_deg), .min = -1, .max = 180,
	 .def = -1, .flags = PARAM_F_MAX_EXCL, .unit = "deg",
	 .help = "Direction of the rhombi's plane about z (u axis from +x); -1 = try 0, 15, ..., "
		 "165 and keep the sparsest initial structure."},
	{.name = "split_pct", .type = PARAM_NUM, .offset = P(split_pct), .min = 0, .max = 100,
	 .def = 2, .flags = PARAM_F_MIN_EXCL, .unit = "%",
	 .help = "Share of the leaves split per stiffness iteration (paper: 2)."},
	{.name = "fea_voxel_mm", .type = PARAM_NUM, .offset = P(fea_voxel_mm), .min = 0, .max = 100,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Element edge of the stiffness analysis; 0 = wall_mm / 2, coarsened until the "
		 "part holds at most 400k elements and its box 2M."},
	{.name = "voxel_mm", .type = PARAM_NUM, .offset = P(voxel_mm), .min = 0, .max = 100,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Voxel edge of the cell classification grid; 0 = wall_mm / 4, coarsened until "
		 "the part's box holds at most 8M voxels."},
	{.name = "max_iterations", .type = PARAM_INT, .offset = P(max_iterations), .min = 1,
	 .max = 100000, .def = 2000, .unit = "",
	 .help = "Most stiffness iterations (each one FEA solve)."},
	{.name = "penal", .type = PARAM_NUM, .offset = P(penal), .min = 1, .max = 5,
	 .def = FEA_PENAL, .unit = "",
	 .help = "Exponent p of the element stiffness rho^p K0 (rho: the element's material "
		 "fraction); 3 = the paper's SIMP; 1 = linear in the fraction, so walls thinner "
		 "than an element keep their stiffness."},
	{.name = "rho_min", .type = PARAM_NUM, .offset = P(rho_min), .min = 1e-4, .max = 0.5,
	 .def = RH_RHO_MIN, .unit = "",
	 .help = "Density of the cavities' elements in the stiffness analysis: their stiffness "
		 "is rho_min^penal of the solid's (default 0.1^3 = 1e-3; paper: 0.001^3)."},
	{.name = "sensitivity", .type = PARAM_ENUM, .offset = P(sensitivity), .def = 0,
	 .choices = sensitivities, .unit = "",
	 .help = "Eq. 10 over the material a split adds: density = at each element's own density "
		 "(elements are partly filled walls); binary = at rho_min for all of them (the "
		 "paper's all-or-nothing elements)."},
	{.name = "bound", .type = PARAM_BOOL, .offset = P(bound), .def = 0, .unit = "",
	 .help = "With objective=stiffness and refine=adaptive: also compute the lowest C/C_solid "
		 "any refinement of the initial structure could reach with the result's material "
		 "(certified by duality on a convex relaxation of rho^p; tens to hundreds of extra "
		 "solves), reported as rhombic.compliance_bound_normalized."},
	{.name = "fea_tol", .type = PARAM_NUM, .offset = P(fea_tol), .min = 1e-8, .max = 0.1,
	 .def = RH_FEA_TOL, .unit = "",
	 .help = "Relative residual of the FEA solves that rank the cells (each starts from the "
		 "last displacement); the result's and the solid part's compliance are solved to "
		 "1e-6."},
	{.name = "loads", .type = PARAM_STR, .offset = P(loads), .max = 4095, .str_cap = 4096,
	 .unit = "",
	 .help = "Load case of the stiffness objective in the FEA text form (docs/fea.md), e.g. "
		 "'fixed plate axes=xyz; force top n=0,0,-1000'; empty = that default, with PLA "
		 "on FDM printers and a standard resin on resin printers."},
};
#undef P

struct rh_job {
	struct rh_params p;
	const struct mesh *mesh;    /* placed part, borrowed from the driver */
	struct rh_tree tree;
	struct rh_carve carve;
	struct slicer *slicer;
	struct mesh *result;        /* result_mesh, built on demand */
	struct paths rects;
	double part_vol_mm3;
	double vf_initial, vf;
	double vox_mm, tau_mm;
	double orient_deg;
	int orientations;           /* initial structures built */
	int steps;                  /* uniform steps */
	int objective, refine;
	struct rh_stab_report stab;
	int did_stab;
	struct rh_stiff_report stiff;
	int did_stiff;
	char loads_text[4096];      /* the load case used, canonical form */
	double s_classify, s_build, s_optimize;
	double area_sum_mm2, layer_mm;
	int layers;
};

/* The default material: PLA on FDM printers, a standard resin otherwise. */
static struct fea_material rh_material(const struct printer *printer)
{
	struct fea_material m = {FEA_RESIN_E_MPA, FEA_RESIN_NU};

	if (printer && printer->kind == PRINTER_FDM) {
		m.E_mpa = FEA_PLA_E_MPA;
		m.nu = FEA_PLA_NU;
	}
	return m;
}

/* Element edge for the stiffness analysis (fea_voxel_mm = 0). */
static double auto_fea_voxel(const struct rh_params *p, struct vec3 sz, double vol_mm3)
{
	double h = p->wall_mm / 2;

	while (vol_mm3 / (h * h * h) > RH_FEA_TARGET ||
	       (ceil(sz.x / h) + 2) * (ceil(sz.y / h) + 2) * (ceil(sz.z / h) + 2) > RH_FEA_BOX)
		h *= 1.1;
	return h;
}

static int run_stiffness(struct rh_job *s, const struct engine_ctx *ctx, int adaptive,
			 struct err *e)
{
	struct rh_stiff_opts o;
	struct fea_loads l;
	int rc;

	if ((rc = fea_loads_parse(s->p.loads, rh_material(ctx->printer), &l, e)) != 0)
		return rc;
	fea_loads_format(&l, s->loads_text, sizeof s->loads_text, NULL);
	memset(&o, 0, sizeof o);
	o.part_vol_mm3 = s->part_vol_mm3;
	o.target = s->p.volume_fraction;
	o.split_pct = s->p.split_pct;
	o.max_iterations = s->p.max_iterations;
	o.adaptive = adaptive;
	o.fea_voxel_mm = s->p.fea_voxel_mm > 0 ? s->p.fea_voxel_mm
					       : auto_fea_voxel(&s->p, box3_size(ctx->report->bbox),
								s->part_vol_mm3);
	o.supersample = RH_FEA_SUPERSAMPLE;
	o.penal = s->p.penal;
	o.rho_min = s->p.rho_min;
	o.binary = s->p.sensitivity == 1;
	o.bound = s->p.bound;
	o.fea_tol = s->p.fea_tol;
	o.max_elements = RH_FEA_MAX;
	o.threads = ctx->threads;
	o.progress = ctx->progress;
	rc = rh_stiffness(&s->tree, ctx->mesh, &l, &o, &s->stiff, e);
	fea_loads_fini(&l);
	s->did_stiff = rc == 0;
	return rc;
}

static int rh_validate(const void *params, const struct common_params *common,
		       const struct printer *printer, struct err *e)
{
	const struct rh_params *p = params;

	(void)printer;
	if (!(common->alpha_deg >= 5 && common->alpha_deg <= 85))
		return ERR_FIELD(e, "alpha_deg",
				 "the rhombic engine needs alpha_deg in [5, 85] (rhombi of aspect "
				 "h/w = tan(90 - alpha)); %g is outside",
				 common->alpha_deg);
	if (common->shell_mm > 0 && common->shell_mm < p->wall_mm)
		return ERR_FIELD(e, "shell_mm",
				 "shell_mm (%g), the rhombic engine's skin, must be at least wall_mm "
				 "(%g): the skin is a wall too",
				 common->shell_mm, p->wall_mm);
	if (!(common->shell_mm > 0) && p->skin_mm < p->wall_mm)
		return ERR_FIELD(e, "skin_mm",
				 "skin_mm (%g) must be at least wall_mm (%g): the skin is a wall too",
				 p->skin_mm, p->wall_mm);
	if (p->objective == RH_OBJ_STIFFNESS) {
		struct fea_loads l;
		int rc = fea_loads_parse(p->loads, rh_material(printer), &l, e);
		if (rc)
			return rc;
		fea_loads_fini(&l);
	}
	if (p->bound && (p->objective != RH_OBJ_STIFFNESS || p->refine != RH_REFINE_ADAPTIVE))
		return ERR_FIELD(e, "bound",
				 "bound=true bounds what adaptive refinement could reach: it needs "
				 "objective=stiffness and refine=adaptive");
	if (p->orient_deg != -1 && p->orient_deg < 0)
		return ERR_FIELD(e, "orient_deg", "orient_deg is -1 (automatic) or in [0, 180), not %g",
				 p->orient_deg);
	return 0;
}

static double fraction_of(const struct rh_job *s, const struct rh_tree *t)
{
	return (s->part_vol_mm3 - t->cavity_volume_mm3) / s->part_vol_mm3;
}

/* The initial structure at each orientation tried; the sparsest wins. */
static int build_initial(struct rh_job *s, const struct engine_ctx *ctx,
			 const struct rh_vox *vx, struct err *e)
{
	double alpha = ctx->common->alpha_deg * M_PI / 180;
	int n = s->p.orient_deg < 0 ? (int)(180 / RH_ORIENT_STEP_DEG) : 1;
	int rc = 0;

	for (int k = 0; k < n; k++) {
		double o = s->p.orient_deg < 0 ? k * RH_ORIENT_STEP_DEG : s->p.orient_deg;
		struct rh_frame f;
		struct rh_tree t;
		rh_frame_init(&f, ctx->mesh, alpha, o, s->p.wall_mm, s->tau_mm);
		rh_tree_init(&t, &f);
		if ((rc = rh_tree_build(&t, vx, ctx->threads, e)) != 0) {
			rh_tree_fini(&t);
			return rc;
		}
		s->orientations++;
		if (k == 0 || fraction_of(s, &t) < fraction_of(s, &s->tree)) {
			rh_tree_fini(&s->tree);
			s->tree = t;
		} else {
			rh_tree_fini(&t);
		}
		if ((rc = progress_update(ctx->progress, 0.1 + 0.4 * (k + 1) / n, e)) != 0)
			return rc;
	}
	s->orient_deg = s->tree.f.orient_deg;
	return 0;
}

static void rh_release(void *state);

static int rh_prepare(const struct engine_ctx *ctx, const void *params, void **out,
		      struct err *e)
{
	struct rh_job *s;
	struct rh_vox vx;
	struct vec3 sz;
	double t0 = progress_now_s(), t1;
	int rc;

	if (!ctx->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the rhombic engine needs a mesh");
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	memset(&vx, 0, sizeof vx);
	memcpy(&s->p, params, sizeof s->p);
	s->mesh = ctx->mesh;
	s->layer_mm = ctx->layer_mm;
	s->objective = s->p.objective;
	s->refine = s->p.refine;
	paths_init(&s->rects);
	s->part_vol_mm3 = ctx->report->volume_mm3;
	if (!(s->part_vol_mm3 > 0)) {
		rc = ERR_SET(e, ERR_GEOMETRY, "the part has no volume (%g mm3)", s->part_vol_mm3);
		goto fail;
	}
	/* 1. the classification grid (section 4.3) */
	sz = box3_size(ctx->report->bbox);
	s->vox_mm = s->p.voxel_mm > 0 ? s->p.voxel_mm
				      : fmax(s->p.wall_mm / 4,
					     cbrt((sz.x + 1) * (sz.y + 1) * (sz.z + 1) / RH_VOX_TARGET));
	/* a common shell_mm > 0 is the skin, as for the lattice engine */
	if (ctx->common->shell_mm > 0)
		s->p.skin_mm = ctx->common->shell_mm;
	s->tau_mm = s->p.skin_mm + sqrt(3) / 2 * s->vox_mm;
	if ((rc = rh_vox_build(ctx->mesh, s->vox_mm, s->tau_mm, RH_VOX_MAX, &vx, e)) != 0) {
		if (rc == ERR_LIMIT)
			snprintf(e->field, sizeof e->field, "voxel_mm");
		goto fail;
	}
	t1 = progress_now_s();
	s->s_classify = t1 - t0;
	/* 2. the initial hierarchy, the sparsest orientation */
	if ((rc = build_initial(s, ctx, &vx, e)) != 0)
		goto fail;
	rh_vox_fini(&vx);
	s->s_build = progress_now_s() - t1;
	if (s->tree.cavities == 0) {
		rc = ERR_FIELD(e, "wall_mm",
			       "wall_mm = %g mm with skin_mm = %g mm leaves no room for a single "
			       "rhombic cell in this part (a cell needs opposite faces and a depth "
			       "of 2 wall_mm inside the skin)",
			       s->p.wall_mm, s->p.skin_mm);
		goto fail;
	}
	s->vf_initial = fraction_of(s, &s->tree);
	/* 3. refinement for the objective */
	t1 = progress_now_s();
	if (s->refine == RH_REFINE_UNIFORM) {
		rc = rh_uniform(&s->tree, s->part_vol_mm3, s->p.volume_fraction, &s->steps, e);
		/* the result's compliance: one solve (and the solid's) */
		if (!rc && s->objective == RH_OBJ_STIFFNESS)
			rc = run_stiffness(s, ctx, 0, e);
	} else if (s->objective == RH_OBJ_STABILITY) {
		rc = rh_stability(&s->tree, ctx->mesh, ctx->layer_mm, 0, &s->stab, e);
		s->did_stab = rc == 0;
	} else {
		rc = run_stiffness(s, ctx, 1, e);
	}
	if (rc)
		goto fail;
	s->s_optimize = progress_now_s() - t1;
	s->vf = fraction_of(s, &s->tree);
	/* 4. cavities for slicing */
	if ((rc = rh_carve_init(&s->carve, &s->tree, e)) != 0 ||
	    (rc = slice_new(ctx->mesh, &s->slicer, e)) != 0)
		goto fail;
	*out = s;
	return 0;
fail:
	rh_vox_fini(&vx);
	rh_release(s);
	return rc;
}

static int rh_layer(void *state, struct layer *ly, struct err *e)
{
	struct rh_job *s = state;
	int rc;

	if ((rc = slice_at(s->slicer, ly->z_mm, &ly->region, NULL, e)) != 0 ||
	    (rc = rh_carve_rects(&s->carve, ly->z_mm, &s->rects, e)) != 0)
		return rc;
	/* the cavities are disjoint and strictly inside the part */
	if (s->rects.n && ly->region.n &&
	    (rc = clip_boolean(CLIP_DIFFERENCE, &ly->region, &s->rects, CLIP_FILL_NONZERO,
			       &ly->region, e)) != 0)
		return rc;
	ly->fill = LAYER_FILL_SOLID;
	s->area_sum_mm2 += paths_area_mm2(&ly->region);
	s->layers++;
	return 0;
}

static int rh_result_mesh(void *state, const struct mesh **out, struct err *e)
{
	struct rh_job *s = state;
	int rc;

	if (!s->result && (rc = rh_carve_mesh(&s->carve, s->mesh, &s->result, e)) != 0)
		return rc;
	*out = s->result;
	return 0;
}

static int metric_xy(struct metrics *m, const char *key, struct vec3 p)
{
	char k[96];
	int rc;

	snprintf(k, sizeof k, "%s.x", key);
	rc = metrics_num(m, k, p.x);
	snprintf(k, sizeof k, "%s.y", key);
	return rc | metrics_num(m, k, p.y);
}

static int rh_metrics(void *state, struct metrics *m, struct err *e)
{
	struct rh_job *s = state;
	size_t cells = 0;
	int rc = 0;

	for (size_t i = 0; i < s->tree.n; i++)
		cells += s->tree.c[i].state != RH_OUT;
	rc |= metrics_str(m, "rhombic.objective", objectives[s->objective]);
	rc |= metrics_str(m, "rhombic.refine", refines[s->refine]);
	rc |= metrics_int(m, "rhombic.cells", (long long)cells);
	rc |= metrics_int(m, "rhombic.leaves", (long long)s->tree.cavities);
	rc |= metrics_int(m, "rhombic.levels", rh_tree_levels(&s->tree));
	rc |= metrics_int(m, "rhombic.max_level", s->tree.f.max_level);
	rc |= metrics_num(m, "rhombic.orientation_deg", s->orient_deg);
	rc |= metrics_int(m, "rhombic.orientations_tried", s->orientations);
	rc |= metrics_num(m, "rhombic.root_width_mm", 2 * s->tree.f.a0_mm);
	rc |= metrics_num(m, "rhombic.root_height_mm", 2 * s->tree.f.b0_mm);
	rc |= metrics_num(m, "rhombic.voxel_mm", s->vox_mm);
	rc |= metrics_num(m, "rhombic.tau_mm", s->tau_mm);
	rc |= metrics_num(m, "rhombic.volume_fraction_initial", s->vf_initial);
	rc |= metrics_num(m, "rhombic.volume_fraction", s->vf);
	rc |= metrics_num(m, "rhombic.cavity_volume_mm3", s->tree.cavity_volume_mm3);
	rc |= metrics_num(m, "rhombic.solid_volume_mm3", s->part_vol_mm3 - s->tree.cavity_volume_mm3);
	if (s->refine == RH_REFINE_UNIFORM)
		rc |= metrics_int(m, "rhombic.uniform_steps", s->steps);
	if (s->did_stab) {
		rc |= metric_xy(m, "rhombic.com_before_mm", s->stab.com_solid);
		rc |= metric_xy(m, "rhombic.com_initial_mm", s->stab.com_initial);
		rc |= metric_xy(m, "rhombic.com_after_mm", s->stab.com_after);
		rc |= metric_xy(m, "rhombic.hull_center_mm", s->stab.hull_center);
		rc |= metrics_bool(m, "rhombic.com_solid_inside_hull", s->stab.solid_inside);
		rc |= metrics_bool(m, "rhombic.com_inside_hull", s->stab.inside);
		rc |= metrics_num(m, "rhombic.com_hull_distance_mm", s->stab.hull_distance_mm);
		rc |= metrics_int(m, "rhombic.stability_splits", (long long)s->stab.splits);
		rc |= metrics_int(m, "rhombic.iterations", s->stab.updates);
	}
	if (s->did_stiff) {
		const struct rh_stiff_report *r = &s->stiff;
		char buf[160];
		rc |= metrics_num(m, "rhombic.compliance_nmm", r->compliance_nmm);
		rc |= metrics_num(m, "rhombic.compliance_solid_nmm", r->compliance_solid_nmm);
		rc |= metrics_num(m, "rhombic.compliance_normalized",
				  r->compliance_nmm / r->compliance_solid_nmm);
		rc |= metrics_num(m, "rhombic.max_displacement_mm", r->max_displacement_mm);
		rc |= metrics_num(m, "rhombic.max_displacement_solid_mm",
				  r->max_displacement_solid_mm);
		rc |= metrics_int(m, "rhombic.iterations", r->iterations);
		rc |= metrics_num(m, "rhombic.fea_voxel_mm", r->fea_voxel_mm);
		rc |= metrics_int(m, "rhombic.fea_elements", (long long)r->elements);
		rc |= metrics_int(m, "rhombic.fea_solves", (long long)r->nhist);
		rc |= metrics_num(m, "rhombic.fea_solve_s", r->solve_s);
		rc |= metrics_num(m, "rhombic.fea_tol", s->p.fea_tol);
		rc |= metrics_str(m, "rhombic.loads", s->loads_text);
		if (r->bound_nmm > 0) {
			rc |= metrics_num(m, "rhombic.compliance_bound_normalized",
					  r->bound_nmm / r->compliance_solid_nmm);
			rc |= metrics_num(m, "rhombic.bound_gap",
					  r->bound_upper_nmm / r->bound_nmm - 1);
			rc |= metrics_int(m, "rhombic.bound_iterations", r->bound_iterations);
			rc |= metrics_num(m, "rhombic.bound_s", r->bound_s);
		}
		/* per solve: the compliance-vs-volume curve (the solid's last) */
		for (size_t i = 0; i < r->nhist; i++) {
			snprintf(buf, sizeof buf, "%d", r->hist[i].cg_iterations);
			rc |= metrics_append_str(m, "rhombic.fea_iterations", buf);
			snprintf(buf, sizeof buf, "%.6f %.6g %.6g", r->hist[i].fraction,
				 r->hist[i].compliance_nmm, r->hist[i].max_displacement_mm);
			rc |= metrics_append_str(m, "rhombic.history", buf);
		}
	}
	rc |= metrics_num(m, "rhombic.seconds.voxels", s->s_classify);
	rc |= metrics_num(m, "rhombic.seconds.initial", s->s_build);
	rc |= metrics_num(m, "rhombic.seconds.optimize", s->s_optimize);
	if (s->layers) {
		rc |= metrics_num(m, "rhombic.sliced_volume_mm3", s->area_sum_mm2 * s->layer_mm);
		rc |= metrics_num(m, "material_volume_mm3", s->area_sum_mm2 * s->layer_mm);
	}
	return rc ? ERR_SET(e, ERR_NOMEM, "out of memory recording metrics") : 0;
}

static void rh_release(void *state)
{
	struct rh_job *s = state;

	if (!s)
		return;
	rh_tree_fini(&s->tree);
	rh_stiff_report_fini(&s->stiff);
	rh_carve_fini(&s->carve);
	slice_free(s->slicer);
	mesh_free(s->result);
	paths_fini(&s->rects);
	mem_free(s);
}

const struct engine_ops rhombic_engine = {
	.name = "rhombic",
	.summary = "Self-supporting adaptive rhombic infill, refined for stiffness under a load "
		   "case or for standing.",
	.paper = "Wu, Wang, Zhang, Westermann: Self-supporting rhombic infill structures for "
		 "additive manufacturing (Computer-Aided Design 80, 2016)",
	.params = {"rhombic", rh_desc, sizeof rh_desc / sizeof rh_desc[0]},
	.params_size = sizeof(struct rh_params),
	.flags = ENGINE_F_MESH_OUTPUT,
	.prepare_share = 0.6,
	.validate = rh_validate,
	.prepare = rh_prepare,
	.layer = rh_layer,
	.metrics = rh_metrics,
	.result_mesh = rh_result_mesh,
	.release = rh_release,
};
