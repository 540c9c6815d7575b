/* hollow.c - the `hollow` engine: support-free hollowing (paper 004,
 * Wang et al., TVCG 2018), lightweight or standing objective, repeated
 * rounds.  The pipeline is rounds.c; this file holds the parameters, the
 * layer output (slices of the hollowed mesh, checked by engine/verify as
 * they stream out) and the metrics.  Design: docs/hollow.md.
 */
#include "engine/hollow/hollow.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/hollow/fill/fill.h"
#include "engine/hollow/hmesh.h"
#include "engine/hollow/repair.h"
#include "engine/hollow/run.h"
#include "engine/hollow/slopes.h"
#include "engine/mesh/mesh.h"
#include "engine/output/printer/printer.h"
#include "engine/slice/slice.h"
#include "engine/verify/verify.h"

struct hollow_params {
	double wall_mm;
	double wall_next_mm;
	double opt_layer_mm;
	double opt_layer_min_mm;
	int smooth_passes;
	int objective;
	int rounds;
	double min_void_mm3;
	double pixel_mm;
	double stack_layer_mm;
	double sample_mm;
	double margin_deg;
	int fill;
	int lean_walls;
	int mitre_corners;
	double optimise_work;
	double optimise_s;
};

static const char *const objective_names[] = {"lightweight", "stability", NULL};

/* Default work budget of the optimisation rounds (reference seconds,
 * docs/hollow.md "3.4": about the seconds it takes on the project's 2-core
 * machine) and the wall-clock guard (s) that only a far slower or busier
 * machine meets. */
#define HOLLOW_WORK_REF_S 60
#define HOLLOW_GUARD_S 300

static const struct param_desc hollow_desc[] = {
	{.name = "wall_mm", .type = PARAM_NUM, .offset = offsetof(struct hollow_params, wall_mm),
	 .min = 0.1, .max = 20, .def = 1.0, .unit = "mm",
	 .help = "Wall to the outside: the first, uniform offset t (paper: 1.0). A common shell_mm "
		 "> 0 replaces it."},
	{.name = "wall_next_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, wall_next_mm), .min = 0.1, .max = 20, .def = 0.8,
	 .unit = "mm", .help = "Walls between voids of successive rounds (paper: 0.8)."},
	{.name = "opt_layer_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, opt_layer_mm), .min = 0.05, .max = 5, .def = 0.5,
	 .unit = "mm",
	 .help = "Slice spacing h of the optimisation (constraints eq. 3-6; with opt_layer_min_mm > 0 the thickest slab); rounded to a multiple "
		 "of the offset stack's layer. Independent of the print layer_mm."},
	{.name = "opt_layer_min_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, opt_layer_min_mm), .min = 0, .max = 5, .def = 0,
	 .unit = "mm",
	 .help = "Adaptive optimisation slices (paper step 2, ref. [30]): > 0, each slab a whole "
		 "number of these (snapped to the offset stack) up to opt_layer_mm, thick where the "
		 "offset surface is straight in z and thin where it bends; thick slabs can leave flat "
		 "void tops beyond the support rule (docs/hollow.md, known limit 6); 0 = every slice "
		 "opt_layer_mm apart."},
	{.name = "smooth_passes", .type = PARAM_INT,
	 .offset = offsetof(struct hollow_params, smooth_passes), .min = 0, .max = 1000, .def = 0,
	 .unit = "",
	 .help = "Section 6's contour smoothing P -> P~ where the constraints are hard to meet: a "
		 "void whose strips end early is built again from its contours smoothed by this "
		 "many truncated Laplacian passes (corners cut inward only; walls only thicken) and "
		 "kept when its support-free start is larger. 0 = never."},
	{.name = "objective", .type = PARAM_ENUM,
	 .offset = offsetof(struct hollow_params, objective), .def = 0, .choices = objective_names,
	 .unit = "",
	 .help = "lightweight: largest support-free voids (eq. 11); stability: move the centre of "
		 "mass over the contact area (eq. 12-14)."},
	{.name = "rounds", .type = PARAM_INT, .offset = offsetof(struct hollow_params, rounds),
	 .min = 0, .max = 50, .def = 8, .unit = "",
	 .help = "Most optimisation rounds (section 7.2); stops earlier when a round adds no void. "
		 "0: no optimisation (with fill=true: the top-down fill alone)."},
	{.name = "min_void_mm3", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, min_void_mm3), .min = 0, .max = 1e9, .def = 8,
	 .unit = "mm3", .help = "Voids smaller than this are not made (paper: 8 mm3)."},
	{.name = "pixel_mm", .type = PARAM_NUM, .offset = offsetof(struct hollow_params, pixel_mm),
	 .min = 0, .max = 1, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Grid of the exact 3D offset; 0 = the resin printer's pixel, or 0.05 mm."},
	{.name = "stack_layer_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, stack_layer_mm), .min = 0, .max = 1, .def = 0,
	 .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Layer height of the offset stack; 0 = the print layer, at most 0.1 mm."},
	{.name = "sample_mm", .type = PARAM_NUM, .offset = offsetof(struct hollow_params, sample_mm),
	 .min = 0, .max = 5, .def = 0, .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Vertex spacing along the contours; 0 = half of the thinnest slab (opt_layer_mm, "
		 "or opt_layer_min_mm when adaptive) * tan(alpha) (0.1..0.5 mm), so zigzag strip "
		 "edges can meet eq. 5."},
	{.name = "margin_deg", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, margin_deg), .min = 0, .max = 10, .def = 0.5,
	 .unit = "deg", .help = "Safety taken off alpha in the optimisation's constraints."},
	{.name = "fill", .type = PARAM_BOOL, .offset = offsetof(struct hollow_params, fill),
	 .min = 0, .max = 1, .def = 1, .unit = "",
	 .help = "After the optimised voids, hollow the space they left with the top-down "
		 "support-free fill, designed on the layer pixels (docs/hollow.md; a mesh output "
		 "carries its pixels as stepped void surfaces). lightweight: the fill alone "
		 "is built too, and kept when it hollows more. stability: only behind the "
		 "centre of mass, away from the contact area."},
	{.name = "lean_walls", .type = PARAM_BOOL,
	 .offset = offsetof(struct hollow_params, lean_walls), .min = 0, .max = 1, .def = 1,
	 .unit = "",
	 .help = "Fill: a wall between two voids leans at alpha over the larger and ends on the "
		 "smaller one's floor (more volume removed; one-pixel bumps along the leaning walls' "
		 "undersides); false: it stands vertical down to a floor (docs/hollow.md)."},
	{.name = "mitre_corners", .type = PARAM_BOOL,
	 .offset = offsetof(struct hollow_params, mitre_corners), .min = 0, .max = 1, .def = 1,
	 .unit = "",
	 .help = "Fill, with lean_walls: a void's convex corners grow square where the exact "
		 "support rule allows (at SL1 pitch one pixel a layer along both axes; more volume "
		 "removed: the 50 mm ball 72.2 -> 76.7 %); false: every front grows round, a "
		 "diamond at SL1 pitch (docs/hollow.md 4.3)."},
	{.name = "optimise_work", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, optimise_work), .min = 0, .max = 86400,
	 .def = HOLLOW_WORK_REF_S, .unit = "ref s",
	 .help = "Work budget of the optimisation rounds, in reference seconds: solver iterations "
		 "priced by a fixed formula of the problem's size, about seconds on the project's "
		 "2-core machine (docs/hollow.md). Every void of a round gets the same iteration "
		 "cap from what is left, and no round starts after one the budget cut, so the "
		 "result does not depend on the machine's speed, its load or the threads. "
		 "0 = no limit."},
	{.name = "optimise_s", .type = PARAM_NUM,
	 .offset = offsetof(struct hollow_params, optimise_s), .min = 0, .max = 86400,
	 .def = HOLLOW_GUARD_S, .unit = "s",
	 .help = "Wall-clock guard of the optimisation rounds: voids not optimised within it keep "
		 "their support-free starting shape and no further round starts (the fill then "
		 "hollows what is left). The result then depends on the machine's speed and load; "
		 "optimise_work is the reproducible limit. 0 = no limit."},
};

/* stability: weight of the lightweight term once the part stands */
#define HOLLOW_LIGHT_WEIGHT 0.05
/* verification grid for outputs without pixels (G-code, meshes) */
#define HOLLOW_VERIFY_PIXEL_MM 0.05

struct hollow_state {
	struct hl_outcome out;
	struct slicer *slicer;       /* on out.mesh, for the layers */
	struct verify *ver;
	struct verify_report rep;
	int verified;                /* rep is filled */
	int layers_seen;
	const struct raster_map *map; /* the driver's, when it wants pixels */
	int antialias;               /* a resin printer's setting, else 1 */
	/* the output is a mesh: its voids are stepped at pixel centres
	 * (hmesh.h), so with optimised voids (stepped()) the check, the beads
	 * and the carving read the layers it slices to again */
	int mesh_out;
	/* the part alone, drawn on the checked pixels: the check's reference
	 * (verify_layer_ref: the part's own air and islands), and the outer
	 * surface of a stepped mesh */
	struct mesh part_view;       /* out.mesh's first part_nv, part_nt */
	struct slicer *part_slicer;  /* on part_view, which it points to; NULL when
				      * out.mesh is the part alone (no optimised voids) */
	struct raster *part_img;     /* its drawing, the checked raster's size */
	struct paths part_region;    /* its section */
	struct raster *own;          /* verification raster when the output has none */
	struct raster_map own_map;
	double layer_mm, alpha_deg, t_prepare, t_verify;
	double min_wall_3d_mm;       /* void vertices to the outer surface */
	size_t part_nv, part_nt;     /* the input part: the result mesh's first ones */
	struct hl_fill frag;         /* beads of the optimised voids, painted solid */
	struct hl_repair repair;     /* the optimised voids' images mended (layer outputs) */
	struct hl_slopes slopes;     /* the optimised voids' slopes on their polygons */
	double t_slopes;
	struct hl_config cfg;
	int objective;
	/* mesh outputs: the checker's and the fill's grid is a resin printer's
	 * own pixels (own_map), so the mesh reslices to the same pixels */
	int own_is_printer;
	int own_w, own_h;            /* that printer's image size */
	struct mesh *result;         /* the mesh output, built on first request */
	size_t result_void_nt;       /* its void surfaces' triangles */
	double t_mesh;
};

static int hollow_validate(const void *params, const struct common_params *common,
			   const struct printer *printer, struct err *e)
{
	const struct hollow_params *p = params;

	(void)printer;
	if (common->alpha_deg <= 0 || common->alpha_deg >= 90)
		return ERR_FIELD(e, "alpha_deg", "hollow needs 0 < alpha_deg < 90 (got %g)",
				 common->alpha_deg);
	if (p->stack_layer_mm > 0 && p->opt_layer_mm < p->stack_layer_mm)
		return ERR_FIELD(e, "opt_layer_mm",
				 "opt_layer_mm (%g) must be at least stack_layer_mm (%g)",
				 p->opt_layer_mm, p->stack_layer_mm);
	if (p->opt_layer_min_mm > p->opt_layer_mm)
		return ERR_FIELD(e, "opt_layer_min_mm",
				 "opt_layer_min_mm (%g) must not exceed opt_layer_mm (%g)",
				 p->opt_layer_min_mm, p->opt_layer_mm);
	return 0;
}

/* Pitch (mm) of one pixel step along image columns and rows of map m. */
static void map_pitch(const struct raster_map *m, double *px, double *py)
{
	double det = m->a[0][0] * m->a[1][1] - m->a[0][1] * m->a[1][0];
	/* columns of the inverse: mm per unit u and per unit v */
	*px = hypot(m->a[1][1], m->a[1][0]) / fabs(det);
	*py = hypot(m->a[0][1], m->a[0][0]) / fabs(det);
}

/* The verifier's own grid when the driver draws no images: pitch
 * HOLLOW_VERIFY_PIXEL_MM, four pixels of margin around m's box. */
static void own_map_of(const struct mesh *m, struct raster_map *map)
{
	struct box3 bb = box3_empty();
	double p = HOLLOW_VERIFY_PIXEL_MM;

	for (size_t i = 0; i < m->nv; i++)
		box3_add(&bb, m->v[i]);
	memset(map, 0, sizeof *map);
	map->a[0][0] = 1 / p;
	map->a[1][1] = 1 / p;
	map->b[0] = -(bb.lo.x - 4 * p) / p;
	map->b[1] = -(bb.lo.y - 4 * p) / p;
}

/* The checker's parameters for s's pixels: the driver's map, or the own
 * grid (pitch HOLLOW_VERIFY_PIXEL_MM). */
static void verify_params_of(const struct hollow_state *s, struct verify_params *vp)
{
	memset(vp, 0, sizeof *vp);
	vp->layer_mm = s->layer_mm;
	vp->alpha_deg = s->alpha_deg;
	vp->threads = s->cfg.opt.threads;
	if (s->map)
		map_pitch(s->map, &vp->pixel_x_mm, &vp->pixel_y_mm);
	else if (s->own_is_printer)
		map_pitch(&s->own_map, &vp->pixel_x_mm, &vp->pixel_y_mm);
	else
		vp->pixel_x_mm = vp->pixel_y_mm = HOLLOW_VERIFY_PIXEL_MM;
}

/* Nonzero when s's layers are a mesh output's with optimised voids: the
 * part's outline grey, the voids stepped at pixel centres (hmesh.h,
 * hl_layer_draw_stepped), as the mesh slices again. */
static int stepped(const struct hollow_state *s)
{
	return !s->map && s->mesh_out && s->out.voids_optimised > 0;
}

/* What the mending (repair.h) allows: the slope plus half the check's
 * tolerance, so that what it leaves reads within the tolerance with
 * room to spare. */
static double hollow_mend_reach_mm(const struct verify_params *vp)
{
	return vp->layer_mm * tan(vp->alpha_deg * M_PI / 180) +
	       0.5 * VERIFY_TOLERANCE_PX * fmax(vp->pixel_x_mm, vp->pixel_y_mm);
}

/* Nonzero when the slope allows at least a pixel a layer.  A mesh output's
 * stepped voids recede by whole pixels: a roof steps at least one a layer,
 * read as 1 px, so on a gentler slope the optimised voids' roofs read over
 * at every step (the 12 mm cube at alpha 30: 57,481 px), and carving runs
 * away (a carved pixel asks the layer above for more than the design
 * recedes).  The fill designs its pixels to the rule at any slope. */
static int steps_follow_slope(const struct verify_params *vp)
{
	return vp->layer_mm * tan(vp->alpha_deg * M_PI / 180) >=
	       fmin(vp->pixel_x_mm, vp->pixel_y_mm);
}

/* Nonzero when s's stepped layers are carved (repair.h). */
static int carve_stepped(const struct hollow_state *s, const struct verify_params *vp)
{
	return stepped(s) && steps_follow_slope(vp);
}

static int start_verify(struct hollow_state *s, const struct mesh *m, struct err *e)
{
	struct verify_params vp;
	struct box3 bb = box3_empty();

	verify_params_of(s, &vp);
	if (!s->map && s->own_is_printer) {
		raster_free(s->own);
		if (!(s->own = raster_new(s->own_w, s->own_h)))
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	} else if (!s->map) {
		double p = HOLLOW_VERIFY_PIXEL_MM;
		int w, h;
		for (size_t i = 0; i < m->nv; i++)
			box3_add(&bb, m->v[i]);
		w = (int)ceil((bb.hi.x - bb.lo.x) / p) + 8;
		h = (int)ceil((bb.hi.y - bb.lo.y) / p) + 8;
		if (w > 65535 || h > 65535)
			return ERR_SET(e, ERR_LIMIT, "hollow: part too wide to verify at %g mm", p);
		raster_free(s->own);
		s->own = raster_new(w, h);
		if (!s->own)
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		own_map_of(m, &s->own_map);
	}
	return verify_new(&vp, &s->ver, e);
}

/* Smallest distance (mm) from any void vertex to the part's outer surface:
 * an independent 3D measure of the wall to the outside. */
static int min_wall_3d(const struct mesh *part, const struct mesh *res, double *out,
		       struct err *e)
{
	struct mesh_bvh *b = NULL;
	double d = INFINITY;
	int rc = mesh_bvh_new(part, &b, e);

	if (rc)
		return rc;
	for (size_t i = part->nv; i < res->nv; i++)
		d = fmin(d, mesh_bvh_closest(b, res->v[i], NULL, NULL));
	mesh_bvh_free(b);
	*out = d;
	return 0;
}

static void hollow_release(void *state);

static int hollow_prepare(const struct engine_ctx *ctx, const void *params, void **out,
			  struct err *e)
{
	const struct hollow_params *p = params;
	struct hollow_state *s;
	struct hl_config *c;
	double t0 = progress_now_s();
	int rc;

	if (!ctx->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the hollow engine needs a mesh");
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->layer_mm = ctx->layer_mm;
	s->part_nv = ctx->mesh->nv;
	s->part_nt = ctx->mesh->nt;
	s->alpha_deg = ctx->common->alpha_deg;
	s->map = ctx->want_raster ? ctx->map : NULL;
	s->antialias = ctx->printer && ctx->printer->kind == PRINTER_RESIN ? ctx->printer->resin.antialias : 1;
	s->mesh_out = !ctx->want_raster && !ctx->want_region;
	paths_init(&s->part_region);
	s->objective = p->objective;
	c = &s->cfg;
	c->opt.wall_mm = ctx->common->shell_mm > 0 ? ctx->common->shell_mm : p->wall_mm;
	c->opt.wall_next_mm = p->wall_next_mm;
	c->opt.stack_layer_mm = p->stack_layer_mm > 0 ? p->stack_layer_mm : fmin(ctx->layer_mm, 0.1);
	c->opt.opt_layer_mm = fmax(p->opt_layer_mm, c->opt.stack_layer_mm);
	c->opt.alpha_rad = s->alpha_deg * M_PI / 180;
	c->opt.margin_rad = p->margin_deg * M_PI / 180;
	if (c->opt.margin_rad >= 0.5 * c->opt.alpha_rad)
		c->opt.margin_rad = 0.5 * c->opt.alpha_rad;
	c->opt.opt_layer_min_mm = p->opt_layer_min_mm > 0
					  ? fmax(p->opt_layer_min_mm, c->opt.stack_layer_mm)
					  : 0;
	c->opt.smooth_passes = p->smooth_passes;
	c->opt.sample_mm = p->sample_mm; /* 0: the optimiser derives it per slice */
	c->opt.min_void_mm3 = p->min_void_mm3;
	c->opt.rounds = p->rounds;
	c->opt.optimise_s = p->optimise_s;
	c->opt.optimise_work = p->optimise_work;
	c->opt.threads = ctx->threads > 0 ? ctx->threads : 1;
	c->opt.objective = p->objective == 1 ? HL_OBJ_STABILITY : HL_OBJ_LIGHTWEIGHT;
	c->opt.light_weight = HOLLOW_LIGHT_WEIGHT;
	c->print_layer_mm = ctx->layer_mm;
	c->opt.print_layer_mm = ctx->layer_mm;
	/* the fill lives in the layers; a mesh output carries its pixels as
	 * stepped void surfaces (hmesh.h) */
	c->fill = p->fill;
	c->fill_lean = p->lean_walls;
	c->fill_corners = p->mitre_corners;
	/* a mesh output for a resin printer is designed on that printer's
	 * pixels: sliced again, it gives the very pixels checked here */
	if (!ctx->want_raster && !ctx->want_region && ctx->printer &&
	    ctx->printer->kind == PRINTER_RESIN) {
		printer_raster_geometry(ctx->printer, &s->own_map, &s->own_w, &s->own_h);
		s->own_is_printer = 1;
	}
	/* the fill is designed on the pixels the verifier reads */
	if (s->map)
		c->fill_map = *s->map;
	else if (s->own_is_printer)
		c->fill_map = s->own_map;
	else
		own_map_of(ctx->mesh, &c->fill_map);
	c->fill_map_set = 1;
	/* the optimiser's erosion grid: the pixels the layers are read on (a
	 * mesh for a resin printer: that printer's, as its SL1 job's) */
	c->opt.pixel_mm = p->pixel_mm > 0 ? p->pixel_mm
			  : s->map || s->own_is_printer ? sqrt(raster_map_pixel_area_mm2(&c->fill_map))
							: HOLLOW_VERIFY_PIXEL_MM;
	/* a mesh's pixel steps cannot follow a slope under a pixel a layer:
	 * there the fill alone, and without it an error */
	if (s->mesh_out) {
		struct verify_params vp;
		verify_params_of(s, &vp);
		if (!steps_follow_slope(&vp)) {
			double pmin = fmin(vp.pixel_x_mm, vp.pixel_y_mm);
			if (!p->fill) {
				rc = ERR_FIELD(e, "alpha_deg",
					       "a mesh output steps the optimiser's voids by whole "
					       "pixels (%g mm), at least one a layer, but alpha_deg %g "
					       "allows %.4f mm a layer: use alpha_deg >= %.1f, "
					       "fill=true, or a layer output",
					       pmin, s->alpha_deg, vp.layer_mm * tan(c->opt.alpha_rad),
					       atan(pmin / vp.layer_mm) * 180 / M_PI);
				hollow_release(s);
				return rc;
			}
			c->opt.rounds = 0; /* the fill alone */
		}
	}
	rc = hl_run(ctx->mesh, c, ctx->progress, &s->out, e);
	if (!rc)
		rc = min_wall_3d(ctx->mesh, s->out.mesh, &s->min_wall_3d_mm, e);
	if (!rc)
		rc = slice_new(s->out.mesh, &s->slicer, e);
	if (!rc && s->out.voids_optimised > 0) {
		double t1 = progress_now_s();
		rc = hl_slopes_check(s->out.mesh, ctx->mesh->nv, ctx->mesh->nt, s->layer_mm,
				     s->layer_mm * tan(c->opt.alpha_rad), &s->slopes, e);
		s->t_slopes = progress_now_s() - t1;
	} else {
		s->slopes.worst_layer = -1;
	}
	if (!rc)
		rc = start_verify(s, s->out.mesh, e);
	/* layer outputs print the pixels: beads split off the optimised voids
	 * there are dropped like voids under min_void_mm3 (fill/fill.h) */
	if (!rc && s->out.voids_optimised > 0)
		rc = hl_fragments_find(s->out.mesh, ctx->mesh->nv, ctx->mesh->nt,
				       s->map ? s->map : &s->own_map,
				       stepped(s) ? 0 : s->map ? s->antialias : 1, VERIFY_THRESHOLD,
				       s->layer_mm, c->opt.min_void_mm3, &s->frag, e);
	/* images written: mend what the optimised voids' grey edges read
	 * over; a mesh stepped at the pixels: carve what its pixels read over
	 * (repair.h); G-code carries the polygons */
	if (!rc && s->out.voids_optimised > 0) {
		struct verify_params vp;
		verify_params_of(s, &vp);
		if (s->map || carve_stepped(s, &vp))
			rc = hl_repair_build(s->out.mesh, s->slicer, s->part_nv, s->part_nt,
					     s->map ? s->map : &s->own_map, s->antialias, &s->out.fill,
					     &s->frag, s->layer_mm, vp.pixel_x_mm, vp.pixel_y_mm,
					     hollow_mend_reach_mm(&vp), c->opt.wall_mm, !s->map,
					     vp.threads, &s->repair, e);
	}
	if (!rc && s->out.mesh->nt != s->part_nt) {
		s->part_view = (struct mesh){s->out.mesh->v, s->out.mesh->tri, s->part_nv, s->part_nt};
		rc = slice_new(&s->part_view, &s->part_slicer, e);
	}
	if (rc) {
		hollow_release(s);
		return rc;
	}
	s->t_prepare = progress_now_s() - t0;
	*out = s;
	return 0;
}

/* s->part_img made w x h (kept when it is) and cleared. */
static int part_img_for(struct hollow_state *s, int w, int h, struct err *e)
{
	if (!s->part_img || s->part_img->w != w || s->part_img->h != h) {
		raster_free(s->part_img);
		if (!(s->part_img = raster_new(w, h)))
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	}
	raster_clear(s->part_img);
	return 0;
}

/* The part alone at layer ly (*part): ly->region, the output mesh's
 * section, when that mesh is the part alone (no part_slicer); else the
 * part sliced apart into s->part_region. */
static int part_section(struct hollow_state *s, const struct layer *ly, const struct paths **part,
			struct err *e)
{
	*part = &ly->region;
	if (!s->part_slicer)
		return 0;
	*part = &s->part_region;
	return slice_at(s->part_slicer, ly->z_mm, &s->part_region, NULL, e);
}

/* The part alone at layer ly drawn into s->part_img (the size of like)
 * through map with antialias, as the layer beside it: the check's
 * reference. */
static int draw_part(struct hollow_state *s, const struct layer *ly,
		     const struct raster_map *map, int antialias, const struct raster *like,
		     struct err *e)
{
	const struct paths *part = NULL;
	int rc = part_img_for(s, like->w, like->h, e);

	if (!rc)
		rc = part_section(s, ly, &part, e);
	if (!rc)
		rc = slice_rasterize(part, map, antialias, s->part_img, e);
	return rc;
}

static int hollow_layer(void *state, struct layer *ly, struct err *e)
{
	struct hollow_state *s = state;
	const struct hl_fill_layer *fill, *frag;
	double t0;
	int rc;

	rc = slice_at(s->slicer, ly->z_mm, &ly->region, NULL, e);
	if (rc)
		return rc;
	fill = ly->region.n ? hl_fill_at(&s->out.fill, ly->z_mm) : NULL;
	frag = ly->region.n ? hl_fill_at(&s->frag, ly->z_mm) : NULL;
	/* the material left is designed: deposit all of it */
	ly->fill = s->out.voids ? LAYER_FILL_SOLID : LAYER_FILL_PART;
	t0 = progress_now_s();
	if (ly->raster && s->map) {
		/* render it here, as the writer would, so the check sees the
		 * very pixels that are written */
		rc = hl_layer_draw(&ly->region, s->map, s->antialias, fill ? &s->out.fill : NULL,
				   frag ? &s->frag : NULL, ly->z_mm, 0, 0, ly->raster, e);
		if (rc)
			return rc;
		hl_repair_apply(&s->repair, ly->z_mm, ly->raster);
		ly->raster_ready = 1;
		rc = draw_part(s, ly, s->map, s->antialias, ly->raster, e);
		if (!rc)
			rc = verify_layer_ref(s->ver, ly->raster, s->part_img, e);
	} else {
		raster_clear(s->own);
		if (stepped(s)) {
			/* the mesh's stepped voids, carved, as it slices again */
			const struct paths *part = NULL;
			rc = part_img_for(s, s->own->w, s->own->h, e);
			if (!rc)
				rc = part_section(s, ly, &part, e);
			if (!rc)
				rc = hl_layer_draw_stepped(&ly->region, part, &s->own_map,
							   s->antialias, fill ? &s->out.fill : NULL,
							   frag ? &s->frag : NULL, ly->z_mm, 0, 0,
							   s->own, s->part_img, e);
			hl_repair_apply(&s->repair, ly->z_mm, s->own);
		} else {
			/* anti-aliased, as a resin writer would: the verifier
			 * measures the optimised voids' slopes at sub-pixel
			 * accuracy */
			rc = hl_layer_draw(&ly->region, &s->own_map, 1, fill ? &s->out.fill : NULL,
					   frag ? &s->frag : NULL, ly->z_mm, 0, 0, s->own, e);
			if (!rc)
				rc = draw_part(s, ly, &s->own_map, 1, s->own, e);
		}
		/* the part's drawing is in part_img either way */
		if (!rc)
			rc = verify_layer_ref(s->ver, s->own, s->part_img, e);
	}
	/* the region handed on (G-code, area metrics) gains the fragments
	 * and loses the fill too */
	if (!rc && frag) {
		struct paths fr;
		paths_init(&fr);
		rc = hl_fill_region(&s->frag, frag, &fr, e);
		if (!rc)
			rc = clip_boolean(CLIP_UNION, &ly->region, &fr, CLIP_FILL_NONZERO,
					  &ly->region, e);
		paths_fini(&fr);
	}
	if (!rc && fill) {
		struct paths fr;
		paths_init(&fr);
		rc = hl_fill_region(&s->out.fill, fill, &fr, e);
		if (!rc)
			rc = clip_boolean(CLIP_DIFFERENCE, &ly->region, &fr, CLIP_FILL_NONZERO,
					  &ly->region, e);
		paths_fini(&fr);
	}
	s->layers_seen++;
	s->t_verify += progress_now_s() - t0;
	return rc;
}

/* Mesh outputs produce no layers: check the mesh's own print layers. */
static int verify_offline(struct hollow_state *s, struct err *e)
{
	struct box3 bb = box3_empty();
	int n, rc = 0;

	for (size_t i = 0; i < s->out.mesh->nv; i++)
		box3_add(&bb, s->out.mesh->v[i]);
	n = layer_count_for(bb.hi.z, s->layer_mm);
	for (int k = 0; k < n && !rc; k++) {
		struct layer ly;
		memset(&ly, 0, sizeof ly);
		paths_init(&ly.region);
		layer_place(&ly, k, n, s->layer_mm);
		rc = hollow_layer(s, &ly, e);
		paths_fini(&ly.region);
	}
	return rc;
}

static int hollow_metrics(void *state, struct metrics *m, struct err *e)
{
	struct hollow_state *s = state;
	const struct hl_outcome *o = &s->out;
	int rc = 0;

	if (!s->verified) {
		if (s->layers_seen == 0) {
			/* the layer pass ran on a pixel map of the driver's: a mesh
			 * output had none, so use the own grid */
			if (s->map) {
				verify_free(s->ver);
				s->ver = NULL;
				s->map = NULL;
				rc = start_verify(s, o->mesh, e);
				if (rc)
					return rc;
			}
			rc = verify_offline(s, e);
			if (rc)
				return rc;
		}
		rc = verify_finish(s->ver, &s->rep, e);
		if (rc)
			return rc;
		s->verified = 1;
	}
	rc |= metrics_int(m, "hollow.voids", (long long)o->voids);
	rc |= metrics_int(m, "hollow.rounds", o->rounds);
	/* the beads painted solid and the gray the mending adds are not voids
	 * of what is printed */
	rc |= metrics_num(m, "hollow.volume_reduction",
			  o->part_volume_mm3 > 0 ? (o->void_volume_mm3 - s->frag.volume_mm3 -
						    s->repair.mm3) / o->part_volume_mm3
						 : 0);
	rc |= metrics_num(m, "hollow.void_volume_mm3",
			  o->void_volume_mm3 - s->frag.volume_mm3 - s->repair.mm3);
	rc |= metrics_int(m, "hollow.fragments", (long long)s->frag.voids);
	rc |= metrics_num(m, "hollow.polygon_slopes.excess_mm2", s->slopes.excess_mm2);
	rc |= metrics_num(m, "hollow.polygon_slopes.worst_mm2", s->slopes.worst_mm2);
	rc |= metrics_int(m, "hollow.polygon_slopes.worst_layer", s->slopes.worst_layer);
	rc |= metrics_int(m, "hollow.polygon_slopes.layers_over", s->slopes.layers_over);
	rc |= metrics_int(m, "hollow.polygon_slopes.layers_checked", s->slopes.layers_checked);
	rc |= metrics_num(m, "hollow.polygon_slopes.seconds", s->t_slopes);
	rc |= metrics_num(m, "hollow.fragment_mm3", s->frag.volume_mm3);
	rc |= metrics_int(m, "hollow.mended.pixels", s->repair.pixels);
	rc |= metrics_num(m, "hollow.mended.mm3", s->repair.mm3);
	rc |= metrics_int(m, "hollow.mended.layers", s->repair.layers);
	rc |= metrics_int(m, "hollow.mended.layers_left", s->repair.layers_left);
	rc |= metrics_num(m, "hollow.mended.seconds", s->repair.seconds);
	rc |= metrics_num(m, "hollow.part_volume_mm3", o->part_volume_mm3);
	rc |= metrics_num(m, "hollow.interior_overhang_mm2", s->rep.interior_overhang_mm2);
	rc |= metrics_num(m, "hollow.part_interior_overhang_mm2", s->rep.part_overhang_mm2);
	rc |= metrics_num(m, "hollow.min_wall_mm", fmin(s->rep.min_wall_mm, s->min_wall_3d_mm));
	rc |= metrics_num(m, "hollow.min_wall_3d_mm", s->min_wall_3d_mm);
	rc |= metrics_num(m, "hollow.wall_mm", s->cfg.opt.wall_mm);
	rc |= metrics_num(m, "hollow.wall_next_mm", s->cfg.opt.wall_next_mm);
	rc |= metrics_num(m, "hollow.alpha_deg", s->alpha_deg);
	rc |= metrics_num(m, "hollow.opt_layer_mm", o->opt.opt_layer_mm);
	rc |= metrics_num(m, "hollow.sample_mm", o->opt.sample_mm);
	rc |= metrics_num(m, "hollow.opt_layer_min_mm", s->cfg.opt.opt_layer_min_mm);
	rc |= metrics_num(m, "hollow.opt_layer_min_used_mm", o->opt.opt_layer_min_used_mm);
	rc |= metrics_int(m, "hollow.slices", (long long)o->opt.slices);
	rc |= metrics_int(m, "hollow.smooth_passes", s->cfg.opt.smooth_passes);
	rc |= metrics_str(m, "hollow.objective", objective_names[s->objective]);
	rc |= metrics_int(m, "hollow.solver_iterations", o->opt.iterations);
	rc |= metrics_int(m, "hollow.voids_optimised", (long long)o->voids_optimised);
	rc |= metrics_int(m, "hollow.voids_fill", (long long)o->fill.voids);
	rc |= metrics_num(m, "hollow.fill_volume_mm3", o->fill.volume_mm3);
	rc |= metrics_int(m, "hollow.fill_walls_cut_px", o->fill.apart_cut_px);
	rc |= metrics_int(m, "hollow.fill_walls_left_layers", o->fill.apart_left_layers);
	rc |= metrics_int(m, "hollow.voids_fallback", (long long)o->voids_fallback);
	rc |= metrics_int(m, "hollow.groups_failed", (long long)o->opt.groups_failed);
	rc |= metrics_int(m, "hollow.groups_small", (long long)o->opt.groups_small);
	rc |= metrics_int(m, "hollow.groups_unbuilt", (long long)o->opt.groups_unbuilt);
	rc |= metrics_int(m, "hollow.voids_too_close", (long long)o->opt.voids_too_close);
	rc |= metrics_num(m, "hollow.optimised_volume_mm3", o->opt.volume_mm3);
	rc |= metrics_num(m, "hollow.fill_alone_volume_mm3", o->fill_alone_mm3);
	rc |= metrics_num(m, "hollow.optimised_and_fill_volume_mm3", o->opt_fill_mm3);
	rc |= metrics_int(m, "hollow.voids_dropped_for_fill", (long long)o->voids_dropped_for_fill);
	rc |= metrics_num(m, "hollow.optimise_s", s->cfg.opt.optimise_s);
	if (o->has_com)
		rc |= metrics_int(m, "hollow.voids_against_com", (long long)o->opt.voids_against_com);
	rc |= metrics_bool(m, "hollow.budget_spent", o->opt.budget_spent);
	rc |= metrics_num(m, "hollow.optimise_work", s->cfg.opt.optimise_work);
	rc |= metrics_num(m, "hollow.solver_work", o->opt.work_s);
	rc |= metrics_bool(m, "hollow.work_spent", o->opt.work_spent);
	rc |= metrics_num(m, "hollow.seconds.offset", o->opt.s_offset);
	rc |= metrics_num(m, "hollow.seconds.groups", o->opt.s_groups);
	rc |= metrics_num(m, "hollow.seconds.optimise", o->opt.s_solve);
	rc |= metrics_num(m, "hollow.seconds.mesh", o->opt.s_mesh);
	rc |= metrics_num(m, "hollow.seconds.fill", o->s_fill);
	rc |= metrics_num(m, "hollow.seconds.prepare", s->t_prepare);
	rc |= metrics_num(m, "hollow.seconds.verify", s->t_verify);
	rc |= metrics_bool(m, "hollow.fill_applied", s->cfg.fill);
	if (s->result) {
		rc |= metrics_int(m, "hollow.mesh.void_triangles", (long long)s->result_void_nt);
		rc |= metrics_num(m, "hollow.mesh.seconds", s->t_mesh);
	}
	if (o->note[0]) {
		rc |= metrics_str(m, "hollow.note", o->note);
	}
	if (o->has_com) {
		rc |= metrics_num(m, "hollow.com_before_mm", o->com_before_mm);
		rc |= metrics_num(m, "hollow.com_after_mm", o->com_after_mm);
		rc |= metrics_bool(m, "hollow.stands_before", o->stands_before);
		rc |= metrics_bool(m, "hollow.com_inside_hull", o->com_inside);
		rc |= metrics_num(m, "hollow.hull_offset_mm", o->hull_offset_mm);
	}
	if (rc)
		return ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	return verify_report_metrics(&s->rep, "hollow.verify", m, e);
}

static int hollow_result_mesh(void *state, const struct mesh **out, struct err *e)
{
	struct hollow_state *s = state;

	if (!s->result) {
		double t0 = progress_now_s();
		int rc = hl_mesh_build(s->out.mesh, s->part_nv, s->part_nt, &s->out.fill, &s->frag,
				       &s->repair, &s->cfg.fill_map, s->layer_mm, &s->result,
				       &s->result_void_nt, e);
		if (rc)
			return rc;
		s->t_mesh = progress_now_s() - t0;
	}
	*out = s->result;
	return 0;
}

static void hollow_release(void *state)
{
	struct hollow_state *s = state;

	if (!s)
		return;
	hl_outcome_fini(&s->out);
	mesh_free(s->result);
	hl_fill_fini(&s->frag);
	hl_repair_fini(&s->repair);
	slice_free(s->slicer);
	slice_free(s->part_slicer);
	raster_free(s->part_img);
	paths_fini(&s->part_region);
	verify_free(s->ver);
	verify_report_fini(&s->rep);
	raster_free(s->own);
	mem_free(s);
}

const struct engine_ops hollow_engine = {
	.name = "hollow",
	.summary = "Support-free hollowing: voids that print without inner supports, for weight "
		   "or for standing.",
	.paper = "W. Wang, Y.-J. Liu, J. Wu, S. Tian, C. C. L. Wang, L. Liu, X. Liu: Support-Free "
		 "Hollowing. IEEE TVCG 24(10), 2018.",
	.params = {"hollow", hollow_desc, sizeof hollow_desc / sizeof hollow_desc[0]},
	.params_size = sizeof(struct hollow_params),
	.flags = ENGINE_F_MESH_OUTPUT,
	.prepare_share = 0.8,
	.validate = hollow_validate,
	.prepare = hollow_prepare,
	.layer = hollow_layer,
	.metrics = hollow_metrics,
	.result_mesh = hollow_result_mesh,
	.release = hollow_release,
};
