/* engine.h - the one header service/ and api/ include.
 *
 * An engine designs a part's interior.  Each exports one const struct
 * engine_ops (its name, parameter description and lifecycle); the
 * registry lists them.  A job (struct job_spec) names an input file, an
 * engine with its parameters, the common placement keys, an output
 * format and a printer profile; engine_run() executes it end to end:
 * read -> repair -> place -> fit check -> engine prepare -> layers ->
 * output writer -> metrics.  Design: docs/architecture.md.
 */
#ifndef INFILLD_ENGINE_H
#define INFILLD_ENGINE_H

#include <stddef.h>
#include <stdint.h>

#include "engine/core/err.h"
#include "engine/core/metrics.h"
#include "engine/core/param.h"
#include "engine/core/progress.h"
#include "engine/core/sink.h"
#include "engine/geom/vec.h"
#include "engine/mesh/mesh.h"
#include "engine/output/output.h"
#include "engine/output/printer/printer.h"
#include "engine/slice/layer.h"

#define INFILLD_VERSION "0.1.0"

/* Keys every job accepts (docs/parameters.md). */
struct common_params {
	int units;          /* enum mesh_units of the input file */
	double scale;       /* uniform factor after units */
	double height_mm;   /* > 0: scale so the printed height is this; 0 = keep */
	int up;             /* enum mesh_up: file axis pointing up in the printer */
	double layer_mm;    /* 0 = printer profile default (0.05 resin, 0.2 FDM) */
	double shell_mm;    /* solid skin kept by engines that hollow or fill */
	double alpha_deg;   /* largest self-supporting overhang, from the vertical */
};

const struct param_table *common_param_table(void);

struct engine_ctx {
	const struct mesh *mesh;           /* placed part (printer frame, mm);
					      NULL when the input is not a mesh */
	const struct mesh_report *report;  /* analysis of mesh, NULL with it */
	const char *input_path;            /* the job's input file */
	const struct common_params *common;
	const struct printer *printer;
	double layer_mm;                   /* resolved layer height */
	int threads;                       /* worker threads the engine may use */
	int want_raster;                   /* output consumes pixels */
	int want_region;                   /* output consumes polygons (G-code);
					      a mesh output consumes neither */
	const struct raster_map *map;      /* pixel map when want_raster */
	struct progress *progress;         /* stage already set to "prepare" */
	const char *scratch_dir;           /* where engines may keep unlinked temporary
					      files (job_spec.scratch_dir); NULL = system's */
	struct metrics *metrics;           /* engines may record as they go */
};

#define ENGINE_F_LATTICE_INPUT 0x1u /* accepts a lattice file instead of a mesh */
#define ENGINE_F_MESH_OUTPUT 0x2u   /* can write its result as a mesh (stl/obj) */

struct engine_ops {
	const char *name;    /* "solid", "lattice", ... */
	const char *summary; /* one line for `infilld engines` */
	const char *paper;   /* citation of the method, NULL for solid */
	struct param_table params; /* the engine's own keys */
	size_t params_size;        /* sizeof the engine's parameter struct */
	unsigned flags;
	double prepare_share;      /* typical fraction of a job spent in prepare()
				      (progress weighting), 0..0.95 */

	/* ENGINE_F_LATTICE_INPUT: nonzero when the engine reads this input
	 * file itself (e.g. a lattice file, by magic number or extension);
	 * the driver then reads no mesh and ctx.mesh is NULL.  NULL = never. */
	int (*owns_input)(const char *path);
	/* Cross-field checks beyond the table's ranges.  NULL = none. */
	int (*validate)(const void *params, const struct common_params *common,
			const struct printer *printer, struct err *e);
	/* Build per-job state (all heavy generation happens here, with
	 * progress).  *state is the engine's; freed by release(). */
	int (*prepare)(const struct engine_ctx *ctx, const void *params, void **state,
		       struct err *e);
	/* Printed extent in the printer frame (mm), when it differs from the
	 * placed mesh's bbox or there is no mesh.  NULL = mesh bbox. */
	int (*extent)(void *state, struct box3 *bbox, struct err *e);
	/* Fill layer ly (index, z, raster set by the caller; see layer.h).
	 * Called once per layer in increasing order on the job's thread. */
	int (*layer)(void *state, struct layer *ly, struct err *e);
	/* Record the engine's figures under "<name>." into m.  NULL = none. */
	int (*metrics)(void *state, struct metrics *m, struct err *e);
	/* ENGINE_F_MESH_OUTPUT: the designed part as a mesh, borrowed from
	 * state.  NULL otherwise. */
	int (*result_mesh)(void *state, const struct mesh **out, struct err *e);
	void (*release)(void *state);
};

/* Registry: NULL-terminated array of every engine. */
const struct engine_ops *const *engine_list(void);
const struct engine_ops *engine_find(const char *name);

struct job_spec {
	const char *input_path;            /* borrowed */
	enum mesh_format input_format;     /* MESH_FMT_AUTO unless told */
	const struct engine_ops *engine;
	void *engine_params;               /* owned, engine->params_size bytes */
	struct common_params common;
	enum out_format format;
	struct printer printer;            /* profile with overrides applied */
	int threads;                       /* 0 = all online CPUs */
	uint64_t output_limit_bytes;       /* 0 = none */
	const char *job_name;              /* borrowed; NULL = from input name */
	const char *scratch_dir;           /* borrowed; where writers may keep unlinked
					      temporary files (the output's directory);
					      NULL = the system's */
	int64_t created_unix;              /* 0 = now; fixed by tests */
};

/* Set up a job with defaults: engine by name (NULL = "solid"), format by
 * name (NULL = from output path, or "sl1"), printer by name (NULL = the
 * format's default).  Caller calls job_spec_fini() even on failure. */
int job_spec_init(struct job_spec *js, const char *engine, const char *format,
		  const char *printer, struct err *e);
void job_spec_fini(struct job_spec *js);

/* Apply KEY=VALUE: the common table, then the engine's, then the
 * printer's.  Unknown key: ERR_PARAM with field = key and a message that
 * says which tables were searched. */
int job_spec_set(struct job_spec *js, const char *key, const char *value, struct err *e);

/* The description of key in the table job_spec_set() would use, or NULL. */
const struct param_desc *job_spec_param(const struct job_spec *js, const char *key);

/* Ranges, cross-field rules, engine validate().  Everything that can be
 * known before reading the input. */
int job_spec_validate(const struct job_spec *js, struct err *e);

/* The layer height the job prints with (mm): its layer_mm, or its
 * printer's when that is 0 (auto). */
double job_spec_layer_mm(const struct job_spec *js);

/* Run a job end to end, streaming the output to out.  m receives the
 * metrics (docs/metrics.md); progress/cancel through hooks (may be NULL). */
int engine_run(const struct job_spec *js, struct sink *out, const struct progress_hooks *hooks,
	       struct metrics *m, struct err *e);

/* Read, repair and place a mesh as a job would, and describe it in m
 * (`infilld analyze`, POST /v1/meshes). */
int engine_analyze(const struct job_spec *js, struct metrics *m, struct err *e);

/* Would a mesh whose extent is size (mm, as `infilld analyze` reports it
 * with the default placement: units mm, scale 1, up z; the stored analysis
 * of an uploaded mesh) fit js's printer once placed by js's units, scale,
 * height_mm and up, as engine_run() places it?  0, or ERR_FIT saying by
 * how much and along which axis, field "height_mm" when js sets one, else
 * "scale".  Placement is a rotation by a multiple of 90 degrees and a
 * uniform scale, so the extent decides the fit exactly. */
int engine_check_fit_size(const struct job_spec *js, struct vec3 size, struct err *e);

/* `infilld fea` (docs/fea_cli.md): the stiffness of a part under a load
 * case.  The keys beyond the job's placement (engine_fea_param_table). */
struct engine_fea_params {
	double voxel_mm; /* fea_voxel_mm: voxel edge, 0 = automatic */
	int supersample; /* fea_supersample: mesh samples per voxel edge */
	double tol;      /* tol: relative residual of the solve */
	int max_iter;    /* fea_max_iter: CG iterations */
	double penal;    /* fea_penal: stiffness exponent p of rho^p */
	int levels;      /* fea_levels: multigrid levels, 0 = automatic */
};

/* Voxels (grid cells, present or not) an FEA model may have. */
#define ENGINE_FEA_MAX_ELEMENTS 2000000

const struct param_table *engine_fea_param_table(void);
void engine_fea_defaults(struct engine_fea_params *p);
/* KEY=VALUE for `infilld fea`: the placement keys units, scale,
 * height_mm, up (into js->common), printer (a profile name: its kind
 * chooses the default material, resin or PLA) and the fea table's keys.
 * ERR_PARAM naming the key, listing the accepted ones when unknown. */
int engine_fea_set(struct job_spec *js, struct engine_fea_params *p, const char *key,
		   const char *value, struct err *e);

/* Analyse js->input_path: a layer archive infilld wrote (SL1, SL1S, zip
 * stack; recognised by its zip signature), voxel density = the mean
 * material of its pixels and layers, or a mesh read, repaired and placed
 * as engine_run() places it, then voxelised.  Solves the load case
 * loads_text (the FEA engine's text form, api_loads_text() makes it from
 * JSON; NULL or "" = the default case) with the material of the load case,
 * else resin for a resin printer or an archive and PLA for an FDM
 * printer.  Records the results into m (compliance_nmm, ...: the list is
 * in docs/fea_cli.md) and, when vtk_path is not NULL, writes the model and
 * solution there (VTK ImageData).  Errors: one line; ERR_PARAM field
 * "loads" (a box without material, a force on a fixed node, no
 * constraint), ERR_GEOMETRY (not held against rigid motion), ERR_LIMIT
 * field fea_voxel_mm (over ENGINE_FEA_MAX_ELEMENTS voxels), the reader's
 * codes for unreadable input. */
int engine_fea(const struct job_spec *js, const struct engine_fea_params *p,
	       const char *loads_text, const char *vtk_path, struct metrics *m, struct err *e);

#endif
