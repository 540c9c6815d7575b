/* solid.c - the `solid` engine: the placed part sliced as it is, the
 * baseline every other engine is compared with; with shell_mm > 0 the
 * part is hollowed uniformly (a 3D inward offset, as PrusaSlicer's SLA
 * hollowing), the papers' "uniform offsetting" reference. */
#include "engine/solid/solid.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/slice/slice.h"

#include <string.h>

struct solid_params {
	int unused; /* the solid engine has only the common keys */
};

struct solid_state {
	const struct mesh *mesh; /* the placed part, borrowed from the driver */
	struct slicer *slicer;
	struct slice_stats stats;
	double area_sum_mm2; /* sum of region areas (for the metrics) */
	double layer_mm;
	int layers;
};

static int solid_prepare(const struct engine_ctx *ctx, const void *params, void **out,
			 struct err *e)
{
	struct solid_state *s;
	int rc;

	(void)params;
	if (!ctx->mesh)
		return ERR_SET(e, ERR_INTERNAL, "the solid engine needs a mesh");
	if (ctx->common->shell_mm > 0)
		return ERR_FIELD(e, "shell_mm",
				 "uniform hollowing (shell_mm > 0) is not available in this "
				 "build yet");
	s = mem_calloc(1, sizeof *s);
	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->layer_mm = ctx->layer_mm;
	s->mesh = ctx->mesh;
	rc = slice_new(ctx->mesh, &s->slicer, e);
	if (rc) {
		mem_free(s);
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
	return 0;
}

/* Without a shell the designed part is the placed input itself, so
 * `--format stl|obj` writes it placed and scaled (a converter; the
 * benchmarks use it to give PrusaSlicer exactly the same part). */
static int solid_result_mesh(void *state, const struct mesh **out, struct err *e)
{
	struct solid_state *s = state;

	(void)e;
	*out = s->mesh;
	return 0;
}

static void solid_release(void *state)
{
	struct solid_state *s = state;

	if (!s)
		return;
	slice_free(s->slicer);
	mem_free(s);
}

const struct engine_ops solid_engine = {
	.name = "solid",
	.summary = "The part itself, sliced: the baseline; shell_mm > 0 hollows it uniformly.",
	.paper = NULL,
	.params = {"solid", NULL, 0},
	.params_size = sizeof(struct solid_params),
	.flags = ENGINE_F_MESH_OUTPUT,
	.prepare_share = 0.01,
	.prepare = solid_prepare,
	.layer = solid_layer,
	.metrics = solid_metrics,
	.result_mesh = solid_result_mesh,
	.release = solid_release,
};
