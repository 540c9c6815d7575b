/* fea_run.c - engine_fea(): `infilld fea`, linear elasticity of a part
 * under a load case, from a mesh (read, repaired and placed as engine_run
 * does, then voxelised by fea_voxelize_mesh) or from a layer archive
 * infilld wrote (engine/fea/from_layers.c), so every engine's output can
 * be compared under the same load.  docs/fea_cli.md; the solver is
 * engine/fea/fea.h (docs/fea.md).
 */
#include "engine/engine.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/pipeline.h"
#include "engine/fea/fea.h"
#include "engine/fea/from_layers.h"
#include "engine/fea/vtk.h"
#include "engine/job/job_internal.h"
#include "engine/verify/verify.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Automatic voxel: the largest part extent over this, at most 1 mm. */
#define FEA_AUTO_DIVISIONS 100.0
#define FEA_AUTO_MAX_VOXEL_MM 1.0

static const struct param_desc fea_desc[] = {
	{.name = "fea_voxel_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct engine_fea_params, voxel_mm), .min = 0, .max = 100, .def = 0,
	 .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Voxel edge of the FEA model; 0 = the part's largest extent / 100, at most 1 mm, "
		 "coarser when the grid would pass 2,000,000 voxels."},
	{.name = "fea_supersample", .type = PARAM_INT,
	 .offset = offsetof(struct engine_fea_params, supersample), .min = 1, .max = 8, .def = 4,
	 .unit = "",
	 .help = "Samples per voxel edge when a mesh is voxelised (ss^3 per voxel)."},
	{.name = "tol", .type = PARAM_NUM, .offset = offsetof(struct engine_fea_params, tol),
	 .min = 0, .max = 0.1, .def = 1e-6, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Relative residual |r|/|f| the conjugate-gradient solve must reach."},
	{.name = "fea_max_iter", .type = PARAM_INT,
	 .offset = offsetof(struct engine_fea_params, max_iter), .min = 1, .max = 100000,
	 .def = 1000, .unit = "",
	 .help = "Most conjugate-gradient iterations before the solve fails."},
	{.name = "fea_penal", .type = PARAM_NUM,
	 .offset = offsetof(struct engine_fea_params, penal), .min = 1, .max = 5, .def = 1,
	 .unit = "",
	 .help = "Exponent p of a voxel's stiffness rho^p E: 1 (default) makes a partly filled "
		 "voxel as stiff as its material fraction; 3 is the SIMP of the optimising engines."},
	{.name = "fea_levels", .type = PARAM_INT,
	 .offset = offsetof(struct engine_fea_params, levels), .min = 0, .max = 12, .def = 0,
	 .flags = PARAM_F_AUTO, .unit = "",
	 .help = "Multigrid levels including the finest; 0 = automatic (docs/fea.md)."},
};

static const struct param_table fea_table = {"fea", fea_desc,
					     sizeof fea_desc / sizeof fea_desc[0]};

const struct param_table *engine_fea_param_table(void)
{
	return &fea_table;
}

void engine_fea_defaults(struct engine_fea_params *p)
{
	param_defaults(&fea_table, p);
}

/* The placement keys of the common table that `infilld fea` takes. */
static const char *const placement_keys[] = {"units", "scale", "height_mm", "up", NULL};

int engine_fea_set(struct job_spec *js, struct engine_fea_params *p, const char *key,
		   const char *value, struct err *e)
{
	int rc;

	if (!strcmp(key, "printer")) {
		rc = printer_lookup(value, &js->printer, e);
		if (rc && e)
			snprintf(e->field, sizeof e->field, "printer");
		return rc == ERR_NOTFOUND ? ERR_PARAM : rc;
	}
	rc = param_set(&fea_table, p, key, value, e);
	if (rc != ERR_NOTFOUND)
		return rc;
	for (int i = 0; placement_keys[i]; i++)
		if (!strcmp(key, placement_keys[i]))
			return param_set(common_param_table(), &js->common, key, value, e);
	return ERR_FIELD(e, key,
			 "unknown parameter '%s' for fea (accepted: units, scale, height_mm, up, "
			 "printer, fea_voxel_mm, fea_supersample, tol, fea_max_iter, fea_penal, fea_levels)",
			 key);
}

/* Zip local-file magic: SL1, SL1S and zip stacks are zip archives. */
static int is_archive(const char *path)
{
	unsigned char m[4] = {0};
	FILE *f = fopen(path, "rb");
	size_t n;

	if (!f)
		return 0; /* the mesh reader reports the path */
	n = fread(m, 1, 4, f);
	fclose(f);
	return n == 4 && m[0] == 'P' && m[1] == 'K' && m[2] == 3 && m[3] == 4;
}

static double grid_cells(struct vec3 size, double h)
{
	return (ceil(size.x / h - 1e-9) + 2) * (ceil(size.y / h - 1e-9) + 2) *
	       (ceil(size.z / h - 1e-9) + 2);
}

/* The voxel edge for a part of this size: p->voxel_mm, or automatic. */
static double voxel_for(const struct engine_fea_params *p, struct vec3 size)
{
	double big = fmax(size.x, fmax(size.y, size.z)), h;

	if (p->voxel_mm > 0)
		return p->voxel_mm;
	if (!(big > 0) || !isfinite(big))
		return 0; /* no extent: the voxelisers refuse it */
	h = fmin(big / FEA_AUTO_DIVISIONS, FEA_AUTO_MAX_VOXEL_MM);
	while (grid_cells(size, h) > ENGINE_FEA_MAX_ELEMENTS)
		h *= 1.02;
	return h;
}

/* ---- archive input: two passes over the layers ---------------------- */

/* Per-thread scratch of the archive passes. */
struct stack_slot {
	struct raster *img;
	struct box3 box;
	struct err err;
	int rc;
};

struct stack_read {
	const struct verify_stack_reader *rd;
	struct fea_layers_geom geo;
	struct fea_layers *acc; /* pass 2 */
	int layers;
	struct stack_slot *slot; /* one per thread */
};

/* Pass 1, one layer: its lit pixels' extent. */
static void box_layer(void *ctx, size_t k, int tid)
{
	struct stack_read *sr = ctx;
	struct stack_slot *sl = &sr->slot[tid];

	if (sl->rc)
		return;
	sl->rc = verify_stack_layer(sr->rd, (int)k, &sl->img, &sl->err);
	if (!sl->rc)
		fea_layers_box(&sr->geo, (int)k, sl->img, &sl->box);
}

/* Pass 2, one voxel slab: every layer reaching it (a layer straddling two
 * slabs is decoded for each). */
static void fill_slab(void *ctx, size_t iz, int tid)
{
	struct stack_read *sr = ctx;
	struct stack_slot *sl = &sr->slot[tid];
	int k0, k1;

	fea_layers_slab_range(sr->acc, (int)iz, &k0, &k1);
	for (int k = k0; k < k1 && k < sr->layers && !sl->rc; k++) {
		sl->rc = verify_stack_layer(sr->rd, k, &sl->img, &sl->err);
		if (!sl->rc)
			sl->rc = fea_layers_add(sr->acc, k, (int)iz, sl->img, &sl->err);
	}
}

/* The first failure of the threads into e. */
static int slots_rc(const struct stack_read *sr, int threads, struct err *e)
{
	for (int t = 0; t < threads; t++)
		if (sr->slot[t].rc) {
			if (e)
				*e = sr->slot[t].err;
			return sr->slot[t].rc;
		}
	return 0;
}

static int stack_geom(struct stack_read *sr, const struct verify_stack *st,
		      const struct job_spec *js, struct err *e)
{
	sr->geo.width = st->width;
	sr->geo.height = st->height;
	sr->geo.layer_mm = st->layer_mm; /* 0 when unstated: fea_layers_check says so */
	if (st->has_map) {
		sr->geo.map = st->map;
	} else {
		int w, h;
		if (js->printer.kind != PRINTER_RESIN)
			return ERR_SET(e, ERR_PARSE, "the archive states no pixel size: give the resin "
				       "--printer it was written for");
		printer_raster_geometry(&js->printer, &sr->geo.map, &w, &h);
		if (w != st->width || h != st->height)
			return ERR_SET(e, ERR_PARSE,
				       "the archive states no pixel size and its %dx%d images are "
				       "not printer '%s''s %dx%d",
				       st->width, st->height, js->printer.name, w, h);
	}
	return fea_layers_check(&sr->geo, e);
}

static int grid_from_archive(const struct job_spec *js, const struct engine_fea_params *p,
			     int threads, struct fea_grid *g, int *layers, struct err *e)
{
	struct verify_stack_reader *rd = NULL;
	struct verify_stack st;
	struct stack_read sr;
	struct box3 box = box3_empty();
	int rc;

	memset(&sr, 0, sizeof sr);
	rc = verify_stack_open(js->input_path, &rd, &st, e);
	if (rc)
		return rc;
	sr.rd = rd;
	sr.layers = st.layers;
	*layers = st.layers;
	rc = stack_geom(&sr, &st, js, e);
	if (rc)
		goto out;
	sr.slot = mem_calloc((size_t)threads, sizeof *sr.slot);
	if (!sr.slot) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	for (int t = 0; t < threads; t++)
		sr.slot[t].box = box3_empty();
	parfor_run((size_t)st.layers, threads, 4, box_layer, &sr);
	if ((rc = slots_rc(&sr, threads, e)) != 0)
		goto out;
	for (int t = 0; t < threads; t++)
		if (!box3_is_empty(sr.slot[t].box)) {
			box3_add(&box, sr.slot[t].box.lo);
			box3_add(&box, sr.slot[t].box.hi);
		}
	if (box3_is_empty(box)) {
		rc = ERR_SET(e, ERR_GEOMETRY, "no layer of the archive exposes a pixel");
		goto out;
	}
	rc = fea_layers_new(&sr.geo, &box, voxel_for(p, box3_size(box)), ENGINE_FEA_MAX_ELEMENTS,
			    &sr.acc, e);
	if (rc)
		goto out;
	parfor_run((size_t)fea_layers_slabs(sr.acc), threads, 1, fill_slab, &sr);
	if ((rc = slots_rc(&sr, threads, e)) != 0)
		goto out;
	rc = fea_layers_finish(sr.acc, g, e);
out:
	for (int t = 0; sr.slot && t < threads; t++)
		raster_free(sr.slot[t].img);
	mem_free(sr.slot);
	fea_layers_free(sr.acc);
	verify_stack_close(rd);
	return rc;
}

/* ---- mesh input ------------------------------------------------------ */

static int grid_from_mesh(const struct job_spec *js, const struct engine_fea_params *p,
			  int threads, struct fea_grid *g, struct metrics *m, struct err *e)
{
	struct mesh *mesh = NULL;
	struct job_mesh_info mi;
	double h;
	int rc;

	rc = job_load_mesh(js, &mesh, &mi, e);
	if (rc)
		return rc;
	if (metrics_num(m, "mesh.volume_mm3", mi.placed.volume_mm3) ||
	    metrics_bool(m, "mesh.watertight", mi.placed.watertight) ||
	    metrics_int(m, "mesh.triangles", (long long)mi.placed.triangles) ||
	    job_warn_small_part(m, &mi.placed.bbox)) {
		mesh_free(mesh);
		return ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	}
	h = voxel_for(p, box3_size(mi.placed.bbox));
	rc = fea_voxelize_mesh(mesh, h, p->supersample, ENGINE_FEA_MAX_ELEMENTS, threads, g, e);
	mesh_free(mesh);
	return rc;
}

/* ---- results --------------------------------------------------------- */

/* Element fields of the solution, for the VTK file and the maxima. */
static int element_fields(const struct fea_solver *s, const struct fea_grid *g, double penal,
			  double rho_min, float **vm_out, float **se_out, struct err *e)
{
	size_t n = (size_t)g->nx * g->ny * g->nz;
	float *vm = mem_alloc(n * sizeof *vm), *se = mem_alloc(n * sizeof *se);

	if (!vm || !se) {
		mem_free(vm);
		mem_free(se);
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu element fields", n);
	}
	fea_element_stress(s, vm, NULL, NULL);
	fea_element_energy(s, se);
	for (size_t i = 0; i < n; i++) {
		/* u_e^T K0 u_e -> the element's energy u_e^T rho^p K0 u_e / 2 (N mm) */
		double rho = g->rho[i] <= 0 ? 0 : g->rho[i] < rho_min ? rho_min : g->rho[i];
		se[i] = rho > 0 ? (float)(0.5 * se[i] * pow(rho, penal)) : 0.0f;
	}
	*vm_out = vm;
	*se_out = se;
	return 0;
}

static int record(struct metrics *m, const struct fea_result *r, const struct fea_grid *g,
		  const struct fea_loads *l, const float *vm, const float *se)
{
	size_t n = (size_t)g->nx * g->ny * g->nz;
	double vol = 0, vm_max = 0, energy = 0, h3 = g->h_mm * g->h_mm * g->h_mm;
	char text[4096];
	struct box3 part = {g->part_lo_mm, g->part_hi_mm};
	struct vec3 ps = box3_size(part);
	int rc = 0;

	for (size_t i = 0; i < n; i++) {
		vol += g->rho[i] > 0 ? g->rho[i] * h3 : 0;
		vm_max = fmax(vm_max, vm[i]);
		energy += se[i];
	}
	rc |= metrics_num(m, "compliance_nmm", r->compliance_nmm);
	rc |= metrics_num(m, "max_displacement_mm", r->max_displacement_mm);
	rc |= metrics_num(m, "max_von_mises_mpa", vm_max);
	rc |= metrics_num(m, "strain_energy_nmm", energy);
	rc |= metrics_int(m, "elements", (long long)r->elements);
	rc |= metrics_int(m, "dofs", (long long)r->dofs);
	rc |= metrics_int(m, "held_nodes", (long long)r->held_nodes);
	rc |= metrics_int(m, "levels", r->levels);
	rc |= metrics_int(m, "iterations", r->iterations);
	rc |= metrics_num(m, "residual", r->residual);
	rc |= metrics_num(m, "solve_s", r->solve_s);
	rc |= metrics_num(m, "mem_mb", r->mem_bytes / 1048576.0);
	rc |= metrics_num(m, "voxel_mm", g->h_mm);
	rc |= metrics_num(m, "volume_mm3", vol);
	rc |= metrics_int(m, "grid.nx", g->nx);
	rc |= metrics_int(m, "grid.ny", g->ny);
	rc |= metrics_int(m, "grid.nz", g->nz);
	rc |= metrics_num(m, "part_size_mm.x", ps.x);
	rc |= metrics_num(m, "part_size_mm.y", ps.y);
	rc |= metrics_num(m, "part_size_mm.z", ps.z);
	rc |= metrics_num(m, "material.E_mpa", l->material.E_mpa);
	rc |= metrics_num(m, "material.nu", l->material.nu);
	if (fea_loads_format(l, text, sizeof text, NULL) == 0)
		rc |= metrics_str(m, "loads", text);
	return rc ? ERR_NOMEM : 0;
}

int engine_fea(const struct job_spec *js, const struct engine_fea_params *p,
	       const char *loads_text, const char *vtk_path, struct metrics *m, struct err *e)
{
	struct fea_grid g;
	struct fea_loads loads;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct fea_material mat;
	float *vm = NULL, *se = NULL;
	double t0 = progress_now_s(), t_model;
	int threads = js->threads > 0 ? js->threads : pipeline_cpu_count();
	int archive = is_archive(js->input_path), layers = 0, rc;

	memset(&g, 0, sizeof g);
	memset(&loads, 0, sizeof loads);
	rc = param_check(&fea_table, p, e);
	if (rc)
		return rc;
	/* the printer's kind chooses the material unless the load case gives one */
	if (js->printer.kind == PRINTER_RESIN || archive)
		mat = (struct fea_material){FEA_RESIN_E_MPA, FEA_RESIN_NU};
	else
		mat = (struct fea_material){FEA_PLA_E_MPA, FEA_PLA_NU};
	rc = fea_loads_parse(loads_text ? loads_text : "", mat, &loads, e);
	if (rc)
		goto out;
	if (archive) {
		rc = grid_from_archive(js, p, threads, &g, &layers, e);
		if (rc)
			err_prefix(e, "%s", js->input_path);
	} else {
		rc = grid_from_mesh(js, p, threads, &g, m, e);
	}
	if (rc)
		goto out;
	t_model = progress_now_s();
	fea_opts_default(&o);
	o.tol = p->tol;
	o.max_iter = p->max_iter;
	o.levels = p->levels;
	o.penal = p->penal;
	o.threads = threads;
	rc = fea_solver_new(&g, &loads, &o, &s, e);
	if (!rc)
		rc = fea_solve(s, &r, e);
	if (!rc)
		rc = element_fields(s, &g, o.penal, o.rho_min, &vm, &se, e);
	if (rc)
		goto out;
	if (vtk_path) {
		struct fea_vtk_fields f = {fea_displacement(s), vm, se};
		rc = fea_vtk_write(vtk_path, &g, &f, e);
		if (rc)
			goto out;
	}
	if (record(m, &r, &g, &loads, vm, se) ||
	    metrics_str(m, "input", archive ? "archive" : "mesh") ||
	    (archive && metrics_int(m, "archive_layers", layers)) ||
	    (!archive && metrics_int(m, "supersample", p->supersample)) ||
	    metrics_num(m, "penal", p->penal) ||
	    metrics_str(m, "printer", js->printer.name) || metrics_num(m, "tol", p->tol) ||
	    metrics_int(m, "threads", threads) ||
	    metrics_num(m, "seconds.model", t_model - t0) ||
	    metrics_num(m, "elapsed_s", progress_now_s() - t0))
		rc = ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
out:
	mem_free(vm);
	mem_free(se);
	fea_solver_free(s);
	fea_loads_fini(&loads);
	fea_grid_fini(&g);
	return rc;
}
