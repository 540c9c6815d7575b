/* run.c - engine_run(): one job end to end, and engine_analyze().
 *
 * read -> repair -> place -> fit check -> engine prepare -> extent/fit
 * -> layers (engine -> writer, streamed) -> writer close -> metrics.
 * Memory is the mesh, the engine's state and the writer's few layers in
 * flight; never proportional to the layer count.  docs/architecture.md.
 */
#include "engine/engine.h"
#include "engine/core/pipeline.h"
#include "engine/job/job_internal.h"

#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

/* Slack on the build-volume check: rounding of placed coordinates (mm). */
#define FIT_EPS_MM 1e-6

static double peak_rss_mb(void)
{
	struct rusage ru;

	if (getrusage(RUSAGE_SELF, &ru) != 0)
		return 0;
	return (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
}

static const char *base_name(const char *path)
{
	const char *s = path ? strrchr(path, '/') : NULL;
	return s ? s + 1 : path ? path : "";
}

int job_load_mesh(const struct job_spec *js, struct mesh **out, struct job_mesh_info *mi,
		  struct err *e)
{
	struct mesh *m = NULL;
	struct mesh_placement pl;
	struct mesh_report rep;
	int rc;

	memset(mi, 0, sizeof *mi);
	rc = mesh_read_file(js->input_path, js->input_format, &m, &mi->read, e);
	if (rc) {
		err_prefix(e, "reading %s", base_name(js->input_path));
		return rc;
	}
	rc = mesh_repair(m, &rep, e);
	if (rc)
		goto out;
	if (m->nt == 0) {
		rc = ERR_SET(e, ERR_GEOMETRY, "%s has no usable triangles",
			     base_name(js->input_path));
		goto out;
	}
	mi->repair = rep;
	memset(&pl, 0, sizeof pl);
	pl.units = js->common.units;
	pl.scale = js->common.scale;
	pl.height_mm = js->common.height_mm;
	pl.up = js->common.up;
	printer_center(&js->printer, &pl.center_x_mm, &pl.center_y_mm);
	rc = mesh_place(m, &pl, e);
	if (rc)
		goto out;
	/* Measures in printer millimetres, with the repair counts kept. */
	rc = mesh_analyze(m, &mi->placed, e);
	if (rc)
		goto out;
	mi->placed.welded_vertices = rep.welded_vertices;
	mi->placed.dropped_triangles = rep.dropped_triangles;
	mi->placed.flipped = rep.flipped;
	mi->placed.reoriented_faces = rep.reoriented_faces;
out:
	if (rc) {
		mesh_free(m);
		err_prefix(e, "%s", base_name(js->input_path));
		return rc;
	}
	*out = m;
	return 0;
}

int job_check_fit(const struct box3 *part, const struct printer *p, struct err *e)
{
	struct box3 vol = printer_build_volume(p);
	struct vec3 ps = box3_size(*part), vs = box3_size(vol);
	char over[256] = "";
	size_t n = 0;
	static const char *const axis[3] = {"X", "Y", "Z (height)"};

	for (int a = 0; a < 3; a++) {
		double lo = v3_comp(part->lo, a), hi = v3_comp(part->hi, a);
		double vlo = v3_comp(vol.lo, a), vhi = v3_comp(vol.hi, a);
		double excess = 0;
		if (lo < vlo - FIT_EPS_MM)
			excess += vlo - lo;
		if (hi > vhi + FIT_EPS_MM)
			excess += hi - vhi;
		if (excess > 0 && n < sizeof over)
			n += (size_t)snprintf(over + n, sizeof over - n, "%s%.2f mm too large in %s",
					      n ? ", " : "", excess, axis[a]);
	}
	if (!n)
		return 0;
	return ERR_SET(e, ERR_FIT,
		       "the part (%.2f x %.2f x %.2f mm) does not fit printer '%s' "
		       "(%.2f x %.2f x %.2f mm): %s",
		       ps.x, ps.y, ps.z, p->name, vs.x, vs.y, vs.z, over);
}

/* A part a few millimetres across is most often a file in other units
 * (femur.off is 1 unit tall: metres or a normalised scan) or a scale
 * forgotten: it slices into a handful of layers and prints as a speck
 * (5 mm is about 100 resin pixels or 12 FDM lines across). */
int job_warn_small_part(struct metrics *m, const struct box3 *part)
{
	struct vec3 s = box3_size(*part);
	double big = fmax(s.x, fmax(s.y, s.z));
	char msg[320];

	if (!(big < JOB_SMALL_PART_MM))
		return 0;
	snprintf(msg, sizeof msg,
		 "the part is only %.3g x %.3g x %.3g mm (largest extent below %g mm), too small "
		 "to print sensibly: set height_mm (e.g. height_mm=50) or units (cm, m, in) if the "
		 "file is not in millimetres",
		 s.x, s.y, s.z, JOB_SMALL_PART_MM);
	return metrics_append_str(m, "warnings", msg);
}

int engine_check_fit_size(const struct job_spec *js, struct vec3 size, struct err *e)
{
	/* the box as a mesh: mesh_place() takes the box of the triangles' vertices */
	struct vec3 v[8];
	uint32_t tri[9] = {0, 1, 2, 3, 4, 5, 6, 7, 0};
	struct mesh m = {v, tri, 8, 3};
	struct mesh_placement pl;
	struct box3 b = box3_empty();
	int rc;

	if (!(size.x >= 0 && size.y >= 0 && size.z >= 0))
		return ERR_SET(e, ERR_PARAM, "bad part size");
	for (int k = 0; k < 8; k++)
		v[k] = v3((k & 1) ? size.x : 0, (k & 2) ? size.y : 0, (k & 4) ? size.z : 0);
	memset(&pl, 0, sizeof pl);
	pl.units = js->common.units;
	pl.scale = js->common.scale;
	pl.height_mm = js->common.height_mm;
	pl.up = js->common.up;
	printer_center(&js->printer, &pl.center_x_mm, &pl.center_y_mm);
	if ((rc = mesh_place(&m, &pl, e)) != 0)
		return rc;
	for (int k = 0; k < 8; k++)
		box3_add(&b, v[k]);
	rc = job_check_fit(&b, &js->printer, e);
	if (rc)
		snprintf(e->field, sizeof e->field, "%s",
			 js->common.height_mm > 0 ? "height_mm" : "scale");
	return rc;
}

int job_record_mesh_metrics(struct metrics *m, const struct job_mesh_info *mi)
{
	const struct mesh_report *r = &mi->placed;
	static const char *const fmt_names[] = {"auto", "stl", "obj", "off", "ply"};
	int rc = 0;

	rc |= metrics_str(m, "mesh.format", fmt_names[mi->read.format <= MESH_FMT_PLY ?
							    mi->read.format : 0]);
	rc |= metrics_bool(m, "mesh.binary", mi->read.binary);
	rc |= metrics_int(m, "mesh.triangles", (long long)r->triangles);
	rc |= metrics_int(m, "mesh.vertices", (long long)r->vertices);
	rc |= metrics_num(m, "mesh.volume_mm3", r->volume_mm3);
	rc |= metrics_num(m, "mesh.area_mm2", r->area_mm2);
	rc |= metrics_bool(m, "mesh.watertight", r->watertight);
	rc |= metrics_int(m, "mesh.border_edges", (long long)r->border_edges);
	rc |= metrics_int(m, "mesh.nonmanifold_edges", (long long)r->nonmanifold_edges);
	rc |= metrics_int(m, "mesh.inconsistent_edges", (long long)r->inconsistent_edges);
	rc |= metrics_int(m, "mesh.degenerate_faces", (long long)r->degenerate_faces);
	rc |= metrics_int(m, "mesh.components", (long long)r->components);
	rc |= metrics_int(m, "mesh.repairs.welded_vertices", (long long)r->welded_vertices);
	rc |= metrics_int(m, "mesh.repairs.dropped_triangles", (long long)r->dropped_triangles);
	rc |= metrics_bool(m, "mesh.repairs.flipped", r->flipped);
	rc |= metrics_int(m, "mesh.repairs.reoriented_faces", (long long)r->reoriented_faces);
	rc |= metrics_int(m, "mesh.warnings", (long long)mi->read.warnings);
	if (mi->read.warnings)
		rc |= metrics_str(m, "mesh.first_warning", mi->read.first_warning);
	return rc ? ERR_NOMEM : 0;
}

int job_record_bbox(struct metrics *m, const char *key, const struct box3 *b)
{
	char k[96];
	int rc = 0;
	const char *ax[3] = {"x", "y", "z"};

	for (int a = 0; a < 3; a++) {
		snprintf(k, sizeof k, "%s.min.%s", key, ax[a]);
		rc |= metrics_num(m, k, v3_comp(b->lo, a));
		snprintf(k, sizeof k, "%s.max.%s", key, ax[a]);
		rc |= metrics_num(m, k, v3_comp(b->hi, a));
	}
	return rc ? ERR_NOMEM : 0;
}

/* Produce every layer and hand it to the writer. */
static int run_layers(const struct job_spec *js, void *state, struct out_writer *w,
		      int count, double layer_mm, struct progress *prog, struct err *e)
{
	struct layer ly;
	int rc = 0;

	memset(&ly, 0, sizeof ly);
	progress_layers(prog, 0, count);
	for (int k = 0; k < count; k++) {
		paths_init(&ly.region);
		ly.raster = NULL;
		ly.raster_ready = 0;
		ly.fill = LAYER_FILL_PART;
		layer_place(&ly, k, count, layer_mm);
		if (out_wants_raster(w)) {
			rc = out_raster_get(w, &ly.raster, e);
			if (rc)
				break;
		}
		rc = js->engine->layer(state, &ly, e);
		if (rc) {
			err_prefix(e, "engine %s, layer %d (z = %.3f mm)", js->engine->name, k,
				   ly.z_mm);
			break;
		}
		rc = out_layer(w, &ly, e);
		if (rc)
			break;
		progress_layers(prog, k + 1, count);
		rc = progress_update(prog, (double)(k + 1) / count, e);
		if (rc)
			break;
	}
	/* out_layer takes ownership; anything left belongs to a failed layer. */
	paths_fini(&ly.region);
	raster_free(ly.raster);
	return rc;
}

/* A mesh output: the engine's result mesh, through the writer like layers. */
static int run_mesh(const struct job_spec *js, void *state, struct out_writer *w,
		    struct err *e)
{
	const struct mesh *rm = NULL;
	int rc;

	rc = js->engine->result_mesh(state, &rm, e);
	if (rc)
		return rc;
	return out_mesh(w, rm, e);
}

int engine_run(const struct job_spec *js, struct sink *out, const struct progress_hooks *hooks,
	       struct metrics *m, struct err *e)
{
	const struct engine_ops *ops = js->engine;
	struct progress prog;
	struct mesh *mesh = NULL;
	struct job_mesh_info mi;
	struct engine_ctx ctx;
	struct raster_map map;
	struct out_info oi;
	struct out_writer *w = NULL;
	struct box3 extent;
	void *state = NULL;
	double t0 = progress_now_s(), t_read, t_prep, t_layers;
	double layer_mm, share, part_volume = 0;
	int threads, count = 0, written = 0, img_w = 0, img_h = 0, rc;
	const struct metric *mv;
	double material = 0;

	rc = job_spec_validate(js, e);
	if (rc)
		return rc;
	progress_init(&prog, hooks);
	threads = js->threads > 0 ? js->threads : pipeline_cpu_count();
	layer_mm = job_spec_layer_mm(js);
	share = ops->prepare_share < 0 ? 0 : ops->prepare_share > 0.95 ? 0.95 : ops->prepare_share;

	/* 1. Input. */
	progress_stage(&prog, "read", 0.0, 0.05);
	memset(&mi, 0, sizeof mi);
	if (!(ops->flags & ENGINE_F_LATTICE_INPUT) || !ops->owns_input ||
	    !ops->owns_input(js->input_path)) {
		rc = job_load_mesh(js, &mesh, &mi, e);
		if (rc)
			goto out;
		rc = job_check_fit(&mi.placed.bbox, &js->printer, e);
		if (rc)
			goto out;
		part_volume = mi.placed.volume_mm3;
		if (job_record_mesh_metrics(m, &mi) || job_warn_small_part(m, &mi.placed.bbox)) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
			goto out;
		}
	}
	t_read = progress_now_s();

	/* 2. Engine preparation (all heavy generation). */
	progress_stage(&prog, "prepare", 0.05, 0.05 + share * 0.95);
	memset(&map, 0, sizeof map);
	if (out_format_is_raster(js->format))
		printer_raster_geometry(&js->printer, &map, &img_w, &img_h);
	memset(&ctx, 0, sizeof ctx);
	ctx.mesh = mesh;
	ctx.report = mesh ? &mi.placed : NULL;
	ctx.input_path = js->input_path;
	ctx.common = &js->common;
	ctx.printer = &js->printer;
	ctx.layer_mm = layer_mm;
	ctx.threads = threads;
	ctx.want_raster = out_format_is_raster(js->format);
	/* a mesh output (stl, obj) consumes neither: it has no layers */
	ctx.want_region = !ctx.want_raster && !out_format_is_mesh(js->format);
	ctx.map = ctx.want_raster ? &map : NULL;
	ctx.progress = &prog;
	ctx.scratch_dir = js->scratch_dir;
	ctx.metrics = m;
	rc = ops->prepare(&ctx, js->engine_params, &state, e);
	if (rc) {
		if (rc != ERR_CANCELLED)
			err_prefix(e, "engine %s", ops->name);
		goto out;
	}
	if (ops->extent) {
		rc = ops->extent(state, &extent, e);
		if (rc)
			goto out;
		rc = job_check_fit(&extent, &js->printer, e);
		if (rc)
			goto out;
	} else if (mesh) {
		extent = mi.placed.bbox;
	} else {
		rc = ERR_SET(e, ERR_INTERNAL, "engine %s reads its own input but has no extent",
			     ops->name);
		goto out;
	}
	t_prep = progress_now_s();

	/* 3. Layers (or the result mesh) into the writer. */
	progress_stage(&prog, out_format_is_mesh(js->format) ? "write" : "layers",
		       0.05 + share * 0.95, 1.0);
	if (!out_format_is_mesh(js->format)) {
		count = layer_count_for(extent.hi.z, layer_mm);
		if (count < 1) {
			rc = extent.hi.z > 0
				     ? ERR_SET(e, ERR_LIMIT,
					       "%.2f mm at %g mm layers is more than %d layers",
					       extent.hi.z, layer_mm, LAYER_MAX_COUNT)
				     : ERR_SET(e, ERR_GEOMETRY, "the part has no height to print");
			goto out;
		}
	}
	memset(&oi, 0, sizeof oi);
	oi.format = js->format;
	oi.printer = &js->printer;
	oi.layer_count = count;
	oi.layer_mm = layer_mm;
	oi.part_bbox = extent;
	oi.mesh = mesh;
	oi.job_name = js->job_name ? js->job_name : base_name(js->input_path);
	oi.engine_name = ops->name;
	oi.threads = threads;
	oi.created = js->created_unix ? (time_t)js->created_unix : time(NULL);
	oi.scratch_dir = js->scratch_dir;
	rc = out_open(&oi, out, &w, e);
	if (rc)
		goto out;
	rc = out_format_is_mesh(js->format) ? run_mesh(js, state, w, e)
					    : run_layers(js, state, w, count, layer_mm, &prog, e);
	if (rc)
		goto out;
	rc = out_close(w, m, e);
	if (rc)
		goto out;
	t_layers = progress_now_s();

	/* 4. Metrics (docs/metrics.md). */
	if (ops->metrics) {
		rc = ops->metrics(state, m, e);
		if (rc)
			goto out;
	}
	if (!mesh)
		part_volume = 0; /* engines without a mesh report their own volumes */
	/* Copy the value: recording more metrics may move the array. */
	mv = metrics_get(m, "material_volume_mm3");
	material = mv ? mv->num : 0;
	/* The writer drops trailing empty layers: `layers` is what it wrote
	 * (its "<format>.layers"), `layers_scheduled` the schedule. */
	written = count;
	if (!out_format_is_mesh(js->format)) {
		char key[32];
		const struct metric *lv;

		snprintf(key, sizeof key, "%s.layers", out_format_name(js->format));
		lv = metrics_get(m, key);
		if (lv)
			written = (int)lv->ival;
	}
	if (metrics_str(m, "engine", ops->name) ||
	    metrics_str(m, "format", out_format_name(js->format)) ||
	    metrics_str(m, "printer", js->printer.name) || metrics_int(m, "layers", written) ||
	    metrics_int(m, "layers_scheduled", count) ||
	    metrics_num(m, "layer_mm", layer_mm) || job_record_bbox(m, "bbox_mm", &extent) ||
	    (mesh && metrics_num(m, "part_volume_mm3", part_volume)) ||
	    (mesh && mv && part_volume > 0 &&
	     metrics_num(m, "material_fraction", material / part_volume)) ||
	    metrics_num(m, "elapsed_s", progress_now_s() - t0) ||
	    metrics_num(m, "seconds.read", t_read - t0) ||
	    metrics_num(m, "seconds.prepare", t_prep - t_read) ||
	    metrics_num(m, "seconds.layers", t_layers - t_prep) ||
	    metrics_int(m, "threads", threads) || metrics_num(m, "peak_rss_mb", peak_rss_mb())) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
		goto out;
	}
	progress_stage(&prog, "done", 1.0, 1.0);
out:
	out_free(w);
	if (state)
		ops->release(state);
	mesh_free(mesh);
	return rc;
}

int engine_analyze(const struct job_spec *js, struct metrics *m, struct err *e)
{
	struct mesh *mesh = NULL;
	struct job_mesh_info mi;
	struct err fit;
	int rc;

	rc = job_load_mesh(js, &mesh, &mi, e);
	if (rc)
		return rc;
	rc = job_record_mesh_metrics(m, &mi);
	if (!rc)
		rc = job_record_bbox(m, "bbox_mm", &mi.placed.bbox);
	if (!rc) {
		struct vec3 s = box3_size(mi.placed.bbox);
		err_clear(&fit);
		rc = metrics_num(m, "size_mm.x", s.x) | metrics_num(m, "size_mm.y", s.y) |
		     metrics_num(m, "size_mm.z", s.z);
		rc |= metrics_str(m, "printer", js->printer.name);
		rc |= metrics_bool(m, "fits_printer",
				   job_check_fit(&mi.placed.bbox, &js->printer, &fit) == 0);
		if (fit.code)
			rc |= metrics_str(m, "fit_error", fit.msg);
		rc |= job_warn_small_part(m, &mi.placed.bbox);
		if (rc)
			rc = ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	}
	mesh_free(mesh);
	return rc;
}
