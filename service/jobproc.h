/* jobproc.h - the job process: one attempt of one job, forked by a
 * worker, under resource limits, reporting over a pipe.
 *
 * The child applies RLIMIT_AS / RLIMIT_CPU / RLIMIT_FSIZE, runs
 * engine_run() into DATA/tmp/<job>-a<n>.part (hashing as it writes),
 * fsyncs it and sends a result record.  Progress records flow while it
 * runs; SIGUSR1 asks it to stop (the engine's cancel hook).  Engine
 * crashes, hangs and limits end only this process.
 */
#ifndef INFILLD_SERVICE_JOBPROC_H
#define INFILLD_SERVICE_JOBPROC_H

#include <stdint.h>

#include "engine/core/err.h"

struct service_config;
struct job_row;

enum jobmsg_type { JOBMSG_PROGRESS = 1, JOBMSG_RESULT = 2 };

struct jobmsg_head {
	uint32_t type, len; /* len = payload bytes after the head */
};

struct jobmsg_progress {
	double fraction;
	int32_t layers_done, layers_total;
	char stage[32];
};

/* Followed by metrics JSON (len - sizeof(struct jobmsg_result) bytes). */
struct jobmsg_result {
	int32_t code;              /* 0 or enum err_code */
	char type[24];             /* err_code_name() */
	char message[ERR_MSG_MAX + 128];
	char field[ERR_FIELD_MAX];
	uint64_t bytes;
	char sha256[65];
};

struct jobproc_args {
	const struct service_config *cfg;
	const struct job_row *job;
	const char *mesh_path;
	const char *out_tmp;       /* where the output goes */
	int fd;                    /* write end of the report pipe */
	int64_t quota_bytes;       /* tenant's storage quota, 0 = none ... */
	int64_t quota_left_bytes;  /* ... and what was left of it at the claim */
	char output_name[64];      /* store_output_name() of the mesh: SL1 jobDir, G-code job */
};

/* Runs in the forked child; never returns. */
void jobproc_main(const struct jobproc_args *a) __attribute__((noreturn));

#endif
