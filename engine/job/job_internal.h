/* job_internal.h - internal to engine/job/: shared steps of run and analyze. */
#ifndef INFILLD_JOB_INTERNAL_H
#define INFILLD_JOB_INTERNAL_H

#include "engine/engine.h"

struct job_mesh_info {
	struct mesh_read_info read;
	struct mesh_report repair; /* as repaired, file units */
	struct mesh_report placed; /* printer frame, mm, with the repair counts */
};

/* Read, repair and place js's input.  *out: new mesh, caller frees. */
int job_load_mesh(const struct job_spec *js, struct mesh **out, struct job_mesh_info *mi,
		  struct err *e);
/* ERR_FIT saying by how much part exceeds p's build volume, else 0. */
int job_check_fit(const struct box3 *part, const struct printer *p, struct err *e);
int job_record_mesh_metrics(struct metrics *m, const struct job_mesh_info *mi);
/* Parts whose largest placed extent is below this (mm) get a warning. */
#define JOB_SMALL_PART_MM 5.0
/* When part (placed, mm) is too small to print sensibly, append a warning
 * suggesting height_mm or units to m's "warnings" list (docs/metrics.md);
 * 0 or ERR_NOMEM. */
int job_warn_small_part(struct metrics *m, const struct box3 *part);
/* key.min.x ... key.max.z */
int job_record_bbox(struct metrics *m, const char *key, const struct box3 *b);

#endif
