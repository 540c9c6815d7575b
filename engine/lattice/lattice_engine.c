/* lattice_engine.c - engine_ops of `lattice` (lattice_engine.h).
 *
 * prepare(): a mesh is filled with a generated lattice (generate.h); a
 * lattice file (binary or text, by content) is placed like a mesh would
 * be (units, scale, height, up, centred, lowest node on the plate) and
 * streamed (binary, up = z) or loaded.  layer(): the streaming slicer
 * renders the plane into the job's raster and/or a field grid whose
 * marching-squares contours are the G-code region.  Design, parameters
 * and metrics: docs/lattice.md.
 */
#include "engine/lattice/lattice_engine.h"
#include "engine/lattice/generate.h"
#include "engine/lattice/lattice.h"
#include "engine/lattice/skin.h"
#include "engine/lattice/slicer.h"
#include "engine/lattice/strut.h"
#include "engine/core/mem.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#define GRID_MAX_PIXELS (64u << 20) /* field grid for G-code regions */
#define RESIN_MIN_RADIUS_MM 0.25     /* ~10 pixels across on SL1-class printers */
/* Default skin (mm) around a lattice generated in a mesh: the part's thin
 * limbs are solid and carry the lattice from the plate (docs/lattice.md
 * section 10: the camel's 1.5-2.3 mm legs take no lattice cell, so a bare
 * lattice starts 16.75 mm up in the air). */
#define LATTICE_SKIN_MM 1.0

struct lattice_params {
	double density;
	int density_mode;
	double density_start, density_end;
	double gradient_start[3], gradient_end[3];
	double radial_center[3];
	double radial_radius_mm;
	char density_file[512];
	double voxel_mm;
	double min_radius_mm;
	double so_k;
	int po;
	int po_rounds;
	int match;
	int max_subdiv;
	int mc_samples;
	int match_passes;
	double support_factor;
	int raw_baseline;
	int seed;
	double contour_um;
	double max_nodes_m;
	double sort_budget_mb;
	char tmp_dir[256];
	char export_lattice[512];
	double skin_mm;
};

static const char *const density_modes[] = {"constant", "gradient", "radial", "file", NULL};

#define P(f) offsetof(struct lattice_params, f)
static const struct param_desc lattice_desc[] = {
	{.name = "density", .type = PARAM_NUM, .offset = P(density), .min = 0, .max = 0.9,
	 .def = 0.2, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Target solid fraction of the lattice (density_mode=constant)."},
	{.name = "density_mode", .type = PARAM_ENUM, .offset = P(density_mode), .def = 0,
	 .choices = density_modes, .unit = "",
	 .help = "Target density: constant, linear gradient, radial falloff, or a NRRD voxel "
		 "grid spanning the part's bounding box."},
	{.name = "density_start", .type = PARAM_NUM, .offset = P(density_start), .min = 0,
	 .max = 0.9, .def = 0.1, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Density at gradient_start (gradient) or at the centre (radial)."},
	{.name = "density_end", .type = PARAM_NUM, .offset = P(density_end), .min = 0,
	 .max = 0.9, .def = 0.3, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Density at gradient_end (gradient) or at radial_radius_mm (radial)."},
	{.name = "gradient_start", .type = PARAM_VEC3, .offset = P(gradient_start), .min = 0,
	 .max = 1, .def_str = "0.5,0.5,0", .unit = "bbox fraction",
	 .help = "Start point of the gradient as fractions of the part's bounding box."},
	{.name = "gradient_end", .type = PARAM_VEC3, .offset = P(gradient_end), .min = 0,
	 .max = 1, .def_str = "0.5,0.5,1", .unit = "bbox fraction",
	 .help = "End point of the gradient as fractions of the part's bounding box."},
	{.name = "radial_center", .type = PARAM_VEC3, .offset = P(radial_center), .min = 0,
	 .max = 1, .def_str = "0.5,0.5,0.5", .unit = "bbox fraction",
	 .help = "Centre of the radial density as fractions of the part's bounding box."},
	{.name = "radial_radius_mm", .type = PARAM_NUM, .offset = P(radial_radius_mm), .min = 0,
	 .max = 10000, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Distance over which the radial density goes from start to end; 0 = to the "
		 "farthest bounding-box corner."},
	{.name = "density_file", .type = PARAM_STR, .offset = P(density_file), .max = 511,
	 .str_cap = 512, .flags = PARAM_F_PATH, .unit = "path",
	 .help = "NRRD voxel grid of target densities (density_mode=file)."},
	{.name = "voxel_mm", .type = PARAM_NUM, .offset = P(voxel_mm), .min = 0, .max = 1000,
	 .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Voxel edge for density matching and its error metrics; 0 = 1.5 x the strut "
		 "spacing at the mean density."},
	{.name = "min_radius_mm", .type = PARAM_NUM, .offset = P(min_radius_mm), .min = 0,
	 .max = 20, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Smallest strut radius the printer makes reliably; struts start at twice it. "
		 "0 = 0.25 mm on resin printers, one extrusion width on FDM printers."},
	{.name = "so_k", .type = PARAM_NUM, .offset = P(so_k), .min = 1, .max = 3, .def = 1.6,
	 .unit = "",
	 .help = "Scaling operation: build in a space compressed by 1/k along z (paper: "
		 "1.5-1.8; 1 = off)."},
	{.name = "po", .type = PARAM_BOOL, .offset = P(po), .def = 1, .unit = "",
	 .help = "Vertex position optimisation for self-support."},
	{.name = "po_rounds", .type = PARAM_INT, .offset = P(po_rounds), .min = 1, .max = 1000,
	 .def = 100, .unit = "",
	 .help = "Most rounds of vertex position optimisation (paper: 100)."},
	{.name = "match", .type = PARAM_BOOL, .offset = P(match), .def = 1, .unit = "",
	 .help = "Density matching (subdivision and radius tuning); off = uniform struts."},
	{.name = "max_subdiv", .type = PARAM_INT, .offset = P(max_subdiv), .min = 0, .max = 4,
	 .def = 2, .unit = "", .help = "Most levels of 1:8 tetrahedron subdivision."},
	{.name = "mc_samples", .type = PARAM_INT, .offset = P(mc_samples), .min = 27,
	 .max = 100000, .def = 1000, .unit = "",
	 .help = "Monte-Carlo samples per voxel in density matching."},
	{.name = "match_passes", .type = PARAM_INT, .offset = P(match_passes), .min = 0,
	 .max = 20, .def = 4, .unit = "", .help = "Per-voxel radius scaling passes."},
	{.name = "support_factor", .type = PARAM_NUM, .offset = P(support_factor), .min = 1,
	 .max = 4, .def = 1.5, .flags = PARAM_F_MIN_EXCL, .unit = "",
	 .help = "Kernel support R as a multiple of the largest strut radius (paper: 1.5)."},
	{.name = "raw_baseline", .type = PARAM_BOOL, .offset = P(raw_baseline), .def = 1,
	 .unit = "",
	 .help = "Also build the unscaled lattice to report gamma_raw/psi_raw (Table 3)."},
	{.name = "seed", .type = PARAM_INT, .offset = P(seed), .min = 0, .max = 2147483647,
	 .def = 1, .unit = "", .help = "Seed of every randomised step (reproducible output)."},
	{.name = "contour_um", .type = PARAM_NUM, .offset = P(contour_um), .min = 5, .max = 1000,
	 .def = 25, .unit = "um",
	 .help = "Field grid pitch for G-code contours (marching squares)."},
	{.name = "max_nodes_m", .type = PARAM_NUM, .offset = P(max_nodes_m), .min = 0.001,
	 .max = 100, .def = 5, .unit = "millions",
	 .help = "Refuse to generate lattices with more nodes than this."},
	{.name = "sort_budget_mb", .type = PARAM_NUM, .offset = P(sort_budget_mb), .min = 1,
	 .max = 65536, .def = 256, .unit = "MB",
	 .help = "Memory for sorting struts by z; larger inputs are sorted out of core."},
	{.name = "tmp_dir", .type = PARAM_STR, .offset = P(tmp_dir), .max = 255, .str_cap = 256,
	 .flags = PARAM_F_PATH, .unit = "path",
	 .help = "Directory for the external sort's spill file; empty = the job's scratch "
		 "directory (beside the output), else $TMPDIR or /tmp."},
	{.name = "export_lattice", .type = PARAM_STR, .offset = P(export_lattice), .max = 511,
	 .str_cap = 512, .flags = PARAM_F_PATH, .unit = "path",
	 .help = "Also write the generated lattice to this binary lattice file, to slice it "
		 "again later or elsewhere."},
	{.name = "skin_mm", .type = PARAM_NUM, .offset = P(skin_mm), .min = 0, .max = 100,
	 .def = LATTICE_SKIN_MM, .unit = "mm",
	 .help = "Solid skin kept around a lattice generated in a mesh: parts thinner than "
		 "twice it print solid and the skin carries the lattice from the plate. 0 = the "
		 "bare lattice (it starts where its lowest node is, often in mid-air). A common "
		 "shell_mm > 0 replaces it; lattice files have no surface and get none."},
};
#undef P

/* Placement of a lattice file: x' = s Rot x + t (Rot a proper rotation
 * taking the file's `up` axis to +z, from mesh_place()). */
struct place {
	double rot[3][3];
	double s;
	struct vec3 t;
};

/* A strut source applying a placement and counting what passes. */
struct placed_source {
	struct lattice_source inner;
	struct place pl;
	uint64_t count;
	double length_mm;
};

struct lat_state {
	struct lattice_params p;
	struct lattice *q;             /* in-memory lattice (generated or loaded) */
	struct lattice_stream *stream; /* binary file, streamed */
	struct lattice_sorter *sorter;
	struct placed_source ps;       /* placement of streamed struts */
	struct lattice_slicer *slicer;
	struct lattice_file_header hdr;
	double R;
	struct box3 extent;
	int want_raster, want_region, antialias;
	const struct raster_map *map;
	struct raster_map gmap; /* field grid for regions */
	int gw, gh;
	float *field;
	/* figures */
	struct lattice_gen_report rep;
	int generated;
	uint64_t nodes, struts;
	double strut_length_mm, rmin, rmax;
	double s_load, s_sort, s_layers;
	int layers;
	double volume_mm3;
	struct lattice_skin *skin; /* shell_mm > 0 (shell_mm, else skin_mm) */
	double shell_mm, shell_pixel_mm, layer_mm;
};

static int lat_owns_input(const char *path)
{
	return lattice_file_probe(path) != LATTICE_FILE_NONE;
}

static int lat_validate(const void *params, const struct common_params *common,
			const struct printer *printer, struct err *e)
{
	const struct lattice_params *p = params;

	(void)printer;
	if (p->density_mode == LATTICE_DENSITY_FILE && !p->density_file[0])
		return ERR_FIELD(e, "density_file", "density_mode=file needs density_file");
	if (p->density_mode != LATTICE_DENSITY_FILE && p->density_file[0])
		return ERR_FIELD(e, "density_file",
				 "density_file is only read with density_mode=file");
	if (common->alpha_deg < 10 || common->alpha_deg > 80)
		return ERR_FIELD(e, "alpha_deg",
				 "the lattice engine's support metric needs alpha_deg in [10, 80]");
	return 0;
}

static struct vec3 place_pt(const struct place *pl, struct vec3 q)
{
	return v3(pl->s * (pl->rot[0][0] * q.x + pl->rot[0][1] * q.y + pl->rot[0][2] * q.z) + pl->t.x,
		  pl->s * (pl->rot[1][0] * q.x + pl->rot[1][1] * q.y + pl->rot[1][2] * q.z) + pl->t.y,
		  pl->s * (pl->rot[2][0] * q.x + pl->rot[2][1] * q.y + pl->rot[2][2] * q.z) + pl->t.z);
}

static int placed_next(void *ctx, struct lattice_strut *s, struct err *e)
{
	struct placed_source *ps = ctx;
	int rc = ps->inner.next(ps->inner.ctx, s, e);
	struct vec3 a, b;

	if (rc <= 0)
		return rc;
	a = place_pt(&ps->pl, v3(s->a[0], s->a[1], s->a[2]));
	b = place_pt(&ps->pl, v3(s->b[0], s->b[1], s->b[2]));
	lattice_strut_make(s, a, b, s->radius_mm * ps->pl.s);
	ps->count++;
	ps->length_mm += v3_dist(a, b);
	return 1;
}

/* The placement of a lattice file, exactly as mesh_place() places a mesh:
 * units, scale or height_mm, the up axis, XY centred on the plate, the
 * bottom on z = 0.  The part is the skeleton's box grown by the largest
 * radius r (the solid's extent), handed to mesh_place() as triangles; four
 * stray probe vertices (which move along without counting for the box)
 * give the affine map x' = s Rot x + t. */
static int lattice_placement(const struct common_params *c, const struct printer *pr,
			     struct box3 b, double r, struct place *pl, struct err *e)
{
	struct vec3 v[12];
	uint32_t tri[9] = {0, 1, 2, 3, 4, 5, 6, 7, 0};
	struct mesh m = {v, tri, 12, 3};
	struct mesh_placement mp;
	int rc;

	b = box3_inflate(b, r);
	for (int k = 0; k < 8; k++)
		v[k] = v3((k & 1) ? b.hi.x : b.lo.x, (k & 2) ? b.hi.y : b.lo.y,
			  (k & 4) ? b.hi.z : b.lo.z);
	v[8] = v3(0, 0, 0);
	v[9] = v3(1, 0, 0);
	v[10] = v3(0, 1, 0);
	v[11] = v3(0, 0, 1);
	memset(&mp, 0, sizeof mp);
	mp.units = c->units;
	mp.scale = c->scale;
	mp.height_mm = c->height_mm;
	mp.up = c->up;
	printer_center(pr, &mp.center_x_mm, &mp.center_y_mm);
	if ((rc = mesh_place(&m, &mp, e)) != 0)
		return rc;
	pl->t = v[8];
	for (int a = 0; a < 3; a++) {
		struct vec3 col = v3_sub(v[9 + a], v[8]);
		pl->rot[0][a] = col.x;
		pl->rot[1][a] = col.y;
		pl->rot[2][a] = col.z;
	}
	pl->s = v3_len(v3_sub(v[9], v[8]));
	for (int i = 0; i < 3; i++)
		for (int a = 0; a < 3; a++)
			pl->rot[i][a] /= pl->s;
	return 0;
}

/* ---- prepare ---- */

static int make_density(const struct engine_ctx *ctx, const struct lattice_params *p,
			struct lattice_density *d, struct err *e)
{
	struct box3 b = ctx->report ? ctx->report->bbox : box3_empty();
	struct vec3 g0 = v3(p->gradient_start[0], p->gradient_start[1], p->gradient_start[2]);
	struct vec3 g1 = v3(p->gradient_end[0], p->gradient_end[1], p->gradient_end[2]);
	struct vec3 rc = v3(p->radial_center[0], p->radial_center[1], p->radial_center[2]);

	if (box3_is_empty(b)) {
		b = box3_empty();
		for (size_t i = 0; i < ctx->mesh->nv; i++)
			box3_add(&b, ctx->mesh->v[i]);
	}
	switch (p->density_mode) {
	case LATTICE_DENSITY_GRADIENT:
		lattice_density_gradient(d, b, g0, g1, p->density_start, p->density_end);
		return 0;
	case LATTICE_DENSITY_RADIAL:
		lattice_density_radial(d, b, rc, p->radial_radius_mm, p->density_start,
				       p->density_end);
		return 0;
	case LATTICE_DENSITY_FILE: {
		int r = lattice_density_load(d, b, p->density_file, e);
		if (!r && !(d->hi > 0))
			r = ERR_FIELD(e, "density_file", "the density grid is zero everywhere");
		return r;
	}
	default:
		lattice_density_constant(d, b, p->density);
		return 0;
	}
}

static int generate(const struct engine_ctx *ctx, struct lat_state *s, struct err *e)
{
	struct lattice_density den;
	struct lattice_gen_opts o;
	int rc;

	if ((rc = make_density(ctx, &s->p, &den, e)) != 0)
		return rc;
	memset(&o, 0, sizeof o);
	o.density = &den;
	o.min_radius_mm = s->p.min_radius_mm > 0 ? s->p.min_radius_mm
			  : ctx->printer->kind == PRINTER_FDM ? ctx->printer->fdm.line_width_mm
							      : RESIN_MIN_RADIUS_MM;
	o.so_k = s->p.so_k;
	o.po = s->p.po;
	o.po_rounds = s->p.po_rounds;
	o.match = s->p.match;
	o.max_subdiv = s->p.max_subdiv;
	o.mc_samples = s->p.mc_samples;
	o.match_passes = s->p.match_passes;
	o.voxel_mm = s->p.voxel_mm;
	o.support_factor = s->p.support_factor;
	o.alpha_rad = ctx->common->alpha_deg * M_PI / 180;
	o.raw_baseline = s->p.raw_baseline;
	o.max_nodes = (size_t)(s->p.max_nodes_m * 1e6);
	o.seed = (uint64_t)s->p.seed;
	o.threads = ctx->threads;
	o.progress = ctx->progress;
	rc = lattice_generate(ctx->mesh, &o, &s->q, &s->rep, e);
	lattice_density_fini(&den);
	s->generated = rc == 0;
	return rc;
}

/* Load a lattice file into memory and place it. */
static int load_file(const struct engine_ctx *ctx, struct lat_state *s, struct err *e)
{
	struct place pl;
	struct box3 b;
	int rc;

	if ((rc = lattice_read(ctx->input_path, &s->q, e)) != 0)
		return rc;
	if (s->q->nedges == 0)
		return ERR_SET(e, ERR_GEOMETRY, "the lattice file has no struts");
	b = lattice_bbox(s->q);
	if ((rc = lattice_placement(ctx->common, ctx->printer, b, lattice_max_radius(s->q), &pl,
				    e)) != 0)
		return rc;
	for (size_t i = 0; i < s->q->nnodes; i++)
		s->q->node[i] = place_pt(&pl, s->q->node[i]);
	for (size_t i = 0; i < s->q->nedges; i++)
		s->q->edge[i].radius_mm = (float)(s->q->edge[i].radius_mm * pl.s);
	s->q->support_mm *= pl.s;
	return 0;
}

/* The printed extent: the solid lies strictly within R of its skeleton
 * (the kernel vanishes at R), so the skeleton's box grown by R, less a
 * nanometre against rounding adding an empty layer; z from the plate. */
static void set_extent(struct lat_state *s, struct box3 nodes)
{
	s->extent = box3_inflate(nodes, s->R - 1e-6);
	s->extent.lo.z = 0;
}

/* Figures of an in-memory lattice and its sorted strut source. */
static int stage_in_memory(struct lat_state *s, const char *scratch, struct err *e)
{
	const struct lattice *q = s->q;
	struct box3 b = lattice_bbox(q);
	double t0 = progress_now_s();
	int rc;

	s->nodes = q->nnodes;
	s->struts = q->nedges;
	s->strut_length_mm = lattice_total_length(q);
	s->rmin = INFINITY;
	s->rmax = 0;
	for (size_t i = 0; i < q->nedges; i++) {
		s->rmin = fmin(s->rmin, q->edge[i].radius_mm);
		s->rmax = fmax(s->rmax, q->edge[i].radius_mm);
	}
	s->R = lattice_support(q, s->p.support_factor);
	if (!(s->rmax < s->R))
		return ERR_SET(e, ERR_GEOMETRY,
			       "the largest strut radius %g mm is not below the support %g mm",
			       s->rmax, s->R);
	set_extent(s, b);
	if ((rc = lattice_sorter_new((size_t)(s->p.sort_budget_mb * 1048576.0),
				     s->p.tmp_dir[0] ? s->p.tmp_dir : scratch, &s->sorter, e)) != 0 ||
	    (rc = lattice_sorter_add_lattice(s->sorter, q, e)) != 0 ||
	    (rc = lattice_sorter_finish(s->sorter, e)) != 0)
		return rc;
	s->s_sort = progress_now_s() - t0;
	s->ps.inner = lattice_sorter_source(s->sorter);
	memset(&s->ps.pl, 0, sizeof s->ps.pl);
	for (int i = 0; i < 3; i++)
		s->ps.pl.rot[i][i] = 1;
	s->ps.pl.s = 1;
	return 0;
}

/* Stream a binary file (up = z keeps its z order). */
static int stage_stream(const struct engine_ctx *ctx, struct lat_state *s, struct err *e)
{
	int rc;
	struct box3 b;

	if ((rc = lattice_stream_open(ctx->input_path, &s->hdr, &s->stream, e)) != 0)
		return rc;
	if (s->hdr.nedges == 0)
		return ERR_SET(e, ERR_GEOMETRY, "the lattice file has no struts");
	if ((rc = lattice_placement(ctx->common, ctx->printer, s->hdr.bbox, s->hdr.max_radius_mm,
				    &s->ps.pl, e)) != 0)
		return rc;
	s->ps.inner = lattice_stream_source(s->stream);
	s->nodes = s->hdr.nnodes;
	s->struts = s->hdr.nedges;
	s->rmax = s->hdr.max_radius_mm * s->ps.pl.s;
	s->rmin = NAN; /* not known before streaming */
	s->R = s->hdr.support_mm > 0 ? s->hdr.support_mm * s->ps.pl.s
				     : s->p.support_factor * s->rmax;
	if (!(s->rmax < s->R))
		return ERR_SET(e, ERR_GEOMETRY,
			       "the largest strut radius %g mm is not below the support %g mm",
			       s->rmax, s->R);
	b.lo = place_pt(&s->ps.pl, s->hdr.bbox.lo);
	b.hi = place_pt(&s->ps.pl, s->hdr.bbox.hi);
	set_extent(s, b);
	return 0;
}

/* Field grid over the extent for G-code regions. */
static int setup_grid(struct lat_state *s, struct err *e)
{
	double p = s->p.contour_um * 1e-3;
	struct vec3 sz = box3_size(s->extent);

	for (;;) {
		double w = ceil(sz.x / p) + 2, h = ceil(sz.y / p) + 2;
		if (w * h <= GRID_MAX_PIXELS && w <= 65535 && h <= 65535) {
			s->gw = (int)w;
			s->gh = (int)h;
			break;
		}
		p *= 1.25;
	}
	/* pixel (0, 0) starts one pitch before the extent's corner */
	s->gmap.a[0][0] = 1 / p;
	s->gmap.a[0][1] = 0;
	s->gmap.a[1][0] = 0;
	s->gmap.a[1][1] = 1 / p;
	s->gmap.b[0] = -(s->extent.lo.x - p) / p;
	s->gmap.b[1] = -(s->extent.lo.y - p) / p;
	s->field = mem_alloc((size_t)s->gw * s->gh * sizeof *s->field);
	return s->field ? 0 : ERR_SET(e, ERR_NOMEM, "out of memory for a %dx%d field grid", s->gw,
				      s->gh);
}

static void lat_release(void *state);

static int lat_prepare(const struct engine_ctx *ctx, const void *params, void **out,
		       struct err *e)
{
	struct lat_state *s = mem_calloc(1, sizeof *s);
	struct lattice_slicer_opts so;
	double t0 = progress_now_s();
	int rc;

	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	memcpy(&s->p, params, sizeof s->p);
	s->want_raster = ctx->want_raster && ctx->map;
	s->want_region = ctx->want_region;
	s->map = ctx->map;
	s->layer_mm = ctx->layer_mm;
	s->antialias = ctx->printer->kind == PRINTER_RESIN ? ctx->printer->resin.antialias : 0;
	if (ctx->common->shell_mm > 0 && !ctx->mesh) {
		rc = ERR_FIELD(e, "shell_mm",
			       "a skin (shell_mm > 0) needs the part's surface: lattice files have "
			       "none");
		goto fail;
	}
	if (ctx->mesh) {
		if ((rc = generate(ctx, s, e)) != 0)
			goto fail;
		if (s->p.export_lattice[0] &&
		    (rc = lattice_write_binary(s->q, s->p.export_lattice, e)) != 0)
			goto fail;
		rc = stage_in_memory(s, ctx->scratch_dir, e);
	} else if (lattice_file_probe(ctx->input_path) == LATTICE_FILE_BINARY &&
		   ctx->common->up == MESH_UP_Z) {
		rc = stage_stream(ctx, s, e);
	} else {
		if ((rc = load_file(ctx, s, e)) != 0)
			goto fail;
		rc = stage_in_memory(s, ctx->scratch_dir, e);
	}
	if (rc)
		goto fail;
	/* the skin: shell_mm when given, else the engine's skin_mm (mesh input) */
	s->shell_mm = ctx->common->shell_mm > 0 ? ctx->common->shell_mm
		      : ctx->mesh		  ? s->p.skin_mm
						  : 0;
	if (s->shell_mm > 0) {
		const struct box3 *bb = &ctx->report->bbox;
		/* With a skin the layer is (lattice AND part) OR skin: the print is
		 * the part's own box, not the skeleton's, which can end below the
		 * part's top (the camel's: 46.8 of 50 mm, and its skin with it). */
		s->extent = *bb;
		s->extent.lo.z = 0;
		s->shell_pixel_mm = ctx->map ? sqrt(raster_map_pixel_area_mm2(ctx->map)) : 0.05;
		if ((rc = lattice_skin_new(ctx->mesh, s->shell_mm, s->shell_pixel_mm, ctx->layer_mm,
					   s->extent.hi.z, bb->lo.x, bb->lo.y, bb->hi.x, bb->hi.y,
					   &s->skin, e)) != 0)
			goto fail;
	}
	s->s_load = progress_now_s() - t0;
	if (s->want_region && (rc = setup_grid(s, e)) != 0)
		goto fail;
	memset(&so, 0, sizeof so);
	so.support_mm = s->R;
	so.threads = ctx->threads;
	so.antialias = s->antialias;
	{
		struct lattice_source src = {placed_next, &s->ps};
		if ((rc = lattice_slicer_new(src, &so, &s->slicer, e)) != 0)
			goto fail;
	}
	*out = s;
	return 0;
fail:
	lat_release(s);
	return rc;
}

static int lat_extent(void *state, struct box3 *bbox, struct err *e)
{
	struct lat_state *s = state;

	(void)e;
	*bbox = s->extent;
	return 0;
}

static int lat_layer(void *state, struct layer *ly, struct err *e)
{
	struct lat_state *s = state;
	double t0 = progress_now_s();
	int rc;

	ly->fill = LAYER_FILL_SOLID;
	if (s->want_raster && ly->raster) {
		if ((rc = lattice_slicer_render(s->slicer, ly->z_mm, s->map, ly->raster, NULL, 0, 0,
						e)) != 0)
			return rc;
		ly->raster_ready = 1;
		if (s->skin && (rc = lattice_skin_raster(s->skin, ly->index, ly->z_mm, s->map,
							 s->antialias, ly->raster, e)) != 0)
			return rc;
		s->volume_mm3 += raster_coverage_px(ly->raster) *
				 raster_map_pixel_area_mm2(s->map) * ly->height_mm;
	}
	if (s->want_region) {
		if ((rc = lattice_slicer_render(s->slicer, ly->z_mm, &s->gmap, NULL, s->field, s->gw,
						s->gh, e)) != 0)
			return rc;
		paths_clear(&ly->region);
		if ((rc = slice_field_contours(s->field, s->gw, s->gh, 1.0f, &s->gmap, &ly->region,
					       e)) != 0)
			return rc;
		if (s->skin &&
		    (rc = lattice_skin_region(s->skin, ly->index, ly->z_mm, &ly->region, e)) != 0)
			return rc;
		if (!s->want_raster)
			s->volume_mm3 += paths_area_mm2(&ly->region) * ly->height_mm;
	}
	s->layers++;
	s->s_layers += progress_now_s() - t0;
	return 0;
}

static int lat_metrics(void *state, struct metrics *m, struct err *e)
{
	struct lat_state *s = state;
	struct lattice_slicer_stats st;
	const struct lattice_gen_report *r = &s->rep;
	int rc = 0;

	lattice_slicer_get_stats(s->slicer, &st);
	if (s->stream) { /* known only once streamed */
		s->strut_length_mm = s->ps.length_mm;
	}
	rc |= metrics_int(m, "lattice.nodes", (long long)s->nodes);
	rc |= metrics_int(m, "lattice.struts", (long long)s->struts);
	rc |= metrics_num(m, "lattice.strut_length_mm", s->strut_length_mm);
	rc |= metrics_num(m, "lattice.support_mm", s->R);
	rc |= metrics_num(m, "lattice.radius_min_mm", s->rmin);
	rc |= metrics_num(m, "lattice.radius_max_mm", s->rmax);
	rc |= metrics_bool(m, "lattice.generated", s->generated);
	if (s->generated) {
		rc |= metrics_num(m, "lattice.gamma_raw", r->gamma_raw);
		rc |= metrics_num(m, "lattice.gamma_so", r->gamma_so);
		rc |= metrics_num(m, "lattice.gamma_so_po", r->gamma_so_po);
		rc |= metrics_num(m, "lattice.gamma_final", r->gamma_final);
		rc |= metrics_num(m, "lattice.psi_raw", r->psi_raw);
		rc |= metrics_num(m, "lattice.psi_so", r->psi_so);
		rc |= metrics_num(m, "lattice.psi_so_po", r->psi_so_po);
		rc |= metrics_num(m, "lattice.psi_final", r->psi_final);
		rc |= metrics_int(m, "lattice.raw_struts", (long long)r->raw_struts);
		rc |= metrics_int(m, "lattice.po_rounds", r->po_rounds);
		rc |= metrics_int(m, "lattice.po_moves", (long long)r->po_moves);
		rc |= metrics_int(m, "lattice.subdivided_tets", (long long)r->subdivided_tets);
		rc |= metrics_int(m, "lattice.density_voxels", (long long)r->voxels);
		rc |= metrics_num(m, "lattice.voxel_mm", r->voxel_mm);
		rc |= metrics_num(m, "lattice.density_error_mean", r->density_error_mean);
		rc |= metrics_num(m, "lattice.density_error_max", r->density_error_max);
		rc |= metrics_num(m, "lattice.seconds.raw_baseline", r->s_raw);
		rc |= metrics_num(m, "lattice.seconds.sample", r->s_sample);
		rc |= metrics_num(m, "lattice.seconds.tetgen", r->s_tetgen);
		rc |= metrics_num(m, "lattice.seconds.po", r->s_po);
		rc |= metrics_num(m, "lattice.seconds.match", r->s_match);
		rc |= metrics_num(m, "lattice.seconds.measure", r->s_measure);
	}
	rc |= metrics_num(m, "lattice.seconds.prepare", s->s_load);
	rc |= metrics_num(m, "lattice.seconds.sort", s->s_sort);
	rc |= metrics_num(m, "lattice.seconds.layers", s->s_layers);
	rc |= metrics_int(m, "lattice.sort_runs",
			  s->sorter ? (long long)lattice_sorter_runs(s->sorter) : 0);
	if (s->stream)
		rc |= metrics_int(m, "lattice.stream_window_nodes",
				  (long long)lattice_stream_window_peak(s->stream));
	rc |= metrics_int(m, "lattice.max_active_struts", (long long)st.max_active);
	rc |= metrics_int(m, "lattice.kernel_evaluations", (long long)st.pairs);
	rc |= metrics_num(m, "lattice.seconds_per_slice", s->layers ? s->s_layers / s->layers : 0);
	rc |= metrics_num(m, "lattice.sliced_volume_mm3", s->volume_mm3);
	rc |= metrics_num(m, "material_volume_mm3", s->volume_mm3);
	if (s->skin) {
		rc |= metrics_num(m, "lattice.shell_mm", s->shell_mm);
		rc |= metrics_num(m, "lattice.shell_volume_mm3",
				  lattice_skin_area_mm2(s->skin) * s->layer_mm);
	}
	return rc ? ERR_SET(e, ERR_NOMEM, "out of memory recording metrics") : 0;
}

static void lat_release(void *state)
{
	struct lat_state *s = state;

	if (!s)
		return;
	lattice_skin_free(s->skin);
	lattice_slicer_free(s->slicer);
	lattice_sorter_free(s->sorter);
	lattice_stream_free(s->stream);
	lattice_free(s->q);
	mem_free(s->field);
	mem_free(s);
}

const struct engine_ops lattice_engine = {
	.name = "lattice",
	.summary = "Graded self-supporting lattice as a convolution surface, streamed slicing "
		   "(also slices lattice files).",
	.paper = "Liu, Liu, Zou, Wang, Doubrovski, Wang: Memory-efficient modeling and slicing "
		 "of large-scale adaptive lattice structures (ASME JCISE 2021)",
	.params = {"lattice", lattice_desc, sizeof lattice_desc / sizeof lattice_desc[0]},
	.params_size = sizeof(struct lattice_params),
	.flags = ENGINE_F_LATTICE_INPUT,
	.prepare_share = 0.5,
	.owns_input = lat_owns_input,
	.validate = lat_validate,
	.prepare = lat_prepare,
	.extent = lat_extent,
	.layer = lat_layer,
	.metrics = lat_metrics,
	.release = lat_release,
};
