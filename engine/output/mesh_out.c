/* mesh_out.c - the STL and OBJ writers: an engine's result mesh, not layers.
 *
 * A mesh writer takes no layers (out_layer refuses them); it takes one mesh
 * through out_mesh() and records that mesh's own figures at out_close():
 * material_volume_mm3 (the mesh's signed volume, mm^3, printer frame),
 * result_mesh.triangles and result_mesh.watertight.  STL is written binary.
 */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/mesh/mesh.h"
#include "engine/output/writer.h"

struct mesh_out {
	enum out_format format; /* OUT_STL or OUT_OBJ */
	struct sink *sink;      /* borrowed */
	struct mesh_report report;
	int written;            /* out_mesh ran */
};

static int mesh_open(const struct out_info *info, struct sink *s, void **state, struct err *e)
{
	struct mesh_out *mo = mem_calloc(1, sizeof *mo);

	if (!mo)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the %s writer",
			       out_format_name(info->format));
	mo->format = info->format;
	mo->sink = s;
	*state = mo;
	return 0;
}

static int mesh_layer(void *state, struct layer *ly, struct err *e)
{
	(void)state;
	(void)ly;
	return ERR_SET(e, ERR_INTERNAL, "a mesh writer takes no layers");
}

static int mesh_take(void *state, const struct mesh *m, struct err *e)
{
	struct mesh_out *mo = state;
	int rc;

	if (mo->written)
		return ERR_SET(e, ERR_INTERNAL, "a mesh writer takes one mesh");
	rc = mo->format == OUT_STL ? mesh_write_stl(m, 1, mo->sink, e)
				   : mesh_write_obj(m, mo->sink, e);
	if (rc)
		return rc;
	rc = mesh_analyze(m, &mo->report, e);
	if (rc)
		return rc;
	mo->written = 1;
	return 0;
}

static int mesh_close(void *state, struct metrics *m, struct err *e)
{
	struct mesh_out *mo = state;

	if (!mo->written)
		return ERR_SET(e, ERR_INTERNAL, "the %s writer was closed without a mesh",
			       out_format_name(mo->format));
	if (metrics_num(m, "material_volume_mm3", mo->report.volume_mm3) ||
	    metrics_int(m, "result_mesh.triangles", (long long)mo->report.triangles) ||
	    metrics_bool(m, "result_mesh.watertight", mo->report.watertight))
		return ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	return 0;
}

static void mesh_free_state(void *state)
{
	mem_free(state);
}

const struct writer_ops out_mesh_writer_ops = {
	.name = "mesh",
	.open = mesh_open,
	.layer = mesh_layer,
	.mesh = mesh_take,
	.close = mesh_close,
	.free_state = mesh_free_state,
};
