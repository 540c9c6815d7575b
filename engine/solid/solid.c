/* solid.c - the `solid` engine: the placed part sliced as it is, the
 * baseline every other engine is compared with; with shell_mm > 0 the
 * part is hollowed uniformly (a 3D inward offset, as PrusaSlicer's SLA
 * hollowing), the papers' "uniform offsetting" reference. */
#include "engine/solid/solid.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/slice/erode.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

struct solid_params {
	double shell_pixel_mm; /* erosion grid pitch; 0 = the printer's pixel (resin) or 0.05 mm */
};

static const struct param_desc solid_desc[] = {
	{.name = "shell_pixel_mm", .type = PARAM_NUM,
	 .offset = offsetof(struct solid_params, shell_pixel_mm), .min = 0, .max = 1, .def = 0,
	 .flags = PARAM_F_AUTO, .unit = "mm",
	 .help = "Grid pitch of the exact 3D offset used by shell_mm; the shell is exact to "
		 "this pixel. 0 = the resin printer's pixel, or 0.05 mm for FDM."},
};

/* Default erosion pitch for FDM printers (mm): well below any line width. */
#define SOLID_FDM_SHELL_PIXEL_MM 0.05

struct solid_state {
	const struct mesh *mesh; /* the placed part, borrowed from the driver */
	struct slicer *slicer;
	struct slice_stats stats;
	double area_sum_mm2; /* sum of region areas (for the metrics) */
	double layer_mm;
	int layers;
	/* shell_mm > 0: the cavity is the part eroded by a ball of radius
	 * shell_mm; the eroder pulls layers from its own slicer because it
	 * runs ahead of the layer being printed. */
	struct slice_mid_source src; /* its own slicer, owned */
	struct slice_eroder *eroder;
	struct paths cavity;
	double cavity_area_sum_mm2;
	double shell_mm, shell_pixel_mm;
};

static int setup_shell(struct solid_state *s, const struct engine_ctx *ctx,
		       const struct solid_params *p, struct err *e)
{
	const struct box3 *bb = &ctx->report->bbox;

	s->shell_mm = ctx->common->shell_mm;
	s->shell_pixel_mm = p->shell_pixel_mm;
	if (s->shell_pixel_mm <= 0)
		s->shell_pixel_mm = ctx->map ? sqrt(raster_map_pixel_area_mm2(ctx->map))
					     : SOLID_FDM_SHELL_PIXEL_MM;
	/* solid_release frees the eroder and the slicer, also on error */
	return slice_erode_mesh_new(ctx->mesh, s->shell_mm, s->shell_pixel_mm, s->layer_mm,
				    layer_count_for(bb->hi.z, s->layer_mm), bb, &s->src,
				    &s->eroder, e);
}

static void solid_release(void *state);

static int solid_prepare(const struct engine_ctx *ctx, const void *params, void **out,
			 struct err *e)
{
	struct solid_state *s;
	int rc;

	if (!ctx->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the solid engine needs a mesh");
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->layer_mm = ctx->layer_mm;
	s->mesh = ctx->mesh;
	paths_init(&s->cavity);
	rc = slice_new(ctx->mesh, &s->slicer, e);
	if (!rc && ctx->common->shell_mm > 0)
		rc = setup_shell(s, ctx, params, e);
	if (rc) {
		solid_release(s);
		return rc;
	}
	*out = s;
	return 0;
}

static int solid_layer(void *state, struct layer *ly, struct err *e)
{
	struct solid_state *s = state;
	int rc;

	rc = slice_at(s->slicer, ly->z_mm, &ly->region, &s->stats, e);
	if (rc)
		return rc;
	ly->fill = LAYER_FILL_PART;
	if (s->eroder) {
		/* Shell = part minus the eroded cavity: designed material, all of
		 * it deposited (FDM prints it solid). */
		rc = slice_erode_layer(s->eroder, ly->index, &s->cavity, e);
		if (!rc && s->cavity.n)
			rc = clip_boolean(CLIP_DIFFERENCE, &ly->region, &s->cavity,
					  CLIP_FILL_NONZERO, &ly->region, e);
		if (rc)
			return rc;
		s->cavity_area_sum_mm2 += paths_area_mm2(&s->cavity);
		ly->fill = LAYER_FILL_SOLID;
	}
	s->area_sum_mm2 += paths_area_mm2(&ly->region);
	s->layers++;
	return 0;
}

static int solid_metrics(void *state, struct metrics *m, struct err *e)
{
	struct solid_state *s = state;

	if (metrics_num(m, "solid.sliced_volume_mm3", s->area_sum_mm2 * s->layer_mm) ||
	    metrics_int(m, "solid.segments", (long long)s->stats.segments) ||
	    metrics_int(m, "solid.loops", (long long)s->stats.loops) ||
	    metrics_int(m, "solid.chains_closed", (long long)s->stats.chains_closed))
		return ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	if (s->eroder &&
	    (metrics_num(m, "solid.shell_mm", s->shell_mm) ||
	     metrics_num(m, "solid.shell_pixel_mm", s->shell_pixel_mm) ||
	     metrics_num(m, "solid.cavity_volume_mm3", s->cavity_area_sum_mm2 * s->layer_mm)))
		return ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	return 0;
}

/* Without a shell the designed part is the placed input itself, so
 * `--format stl|obj` writes it placed and scaled (a converter; the
 * benchmarks use it to give PrusaSlicer exactly the same part). */
static int solid_result_mesh(void *state, const struct mesh **out, struct err *e)
{
	struct solid_state *s = state;

	if (s->eroder)
		return ERR_SET(e, ERR_UNSUPPORTED,
			       "a uniformly hollowed part (shell_mm > 0) has no mesh form: its cavity "
			       "is an exact voxel offset; write a layer format instead");
	*out = s->mesh;
	return 0;
}

static void solid_release(void *state)
{
	struct solid_state *s = state;

	if (!s)
		return;
	slice_free(s->slicer);
	slice_free(s->src.slicer);
	slice_erode_free(s->eroder);
	paths_fini(&s->cavity);
	mem_free(s);
}

const struct engine_ops solid_engine = {
	.name = "solid",
	.summary = "The part itself, sliced: the baseline; shell_mm > 0 hollows it uniformly.",
	.paper = NULL,
	.params = {"solid", solid_desc, sizeof solid_desc / sizeof solid_desc[0]},
	.params_size = sizeof(struct solid_params),
	.flags = ENGINE_F_MESH_OUTPUT,
	.prepare_share = 0.01,
	.prepare = solid_prepare,
	.layer = solid_layer,
	.metrics = solid_metrics,
	.result_mesh = solid_result_mesh,
	.release = solid_release,
};
