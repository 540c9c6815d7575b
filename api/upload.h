/* upload.h - mesh uploads between api/meshes.c (HTTP side) and
 * api/analyze.c (sandboxed analysis).
 */
#ifndef INFILLD_API_UPLOAD_H
#define INFILLD_API_UPLOAD_H

#include "engine/core/sink.h"

struct api_req;
struct api_config;

struct analyze_result {
	struct buf out, err; /* child's stdout (JSON) and stderr, NUL-terminated */
	int exited, exit_code, signal, timed_out;
};

/* Queue r's finished upload for analysis and park its connection. */
int api_analyze_submit(struct api_req *r);
/* Run the sandboxed analysis of path (its extension names the format).
 * 0 when the child ran, whatever it said; negative when it could not be
 * started.  res owns buffers: api_analyze_result_fini(). */
int api_analyze_run(const struct api_config *c, const char *path, struct analyze_result *res);
void api_analyze_result_fini(struct analyze_result *res);
/* On an analysis thread: analyse, publish, record, set r->pending. */
void api_upload_complete(struct api_req *r);

#endif
