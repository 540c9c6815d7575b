/* layers.c - GET /v1/jobs/{id}/layers/{k}: layer k (from 0) of a finished
 * job's output as a PNG, for the portal's layer slider (docs/portal.md).
 *
 * Tenant-scoped through api_load_job() like every job route.  The image
 * comes from engine/output (out_layer_png): a resin archive's own layer
 * PNG, byte for byte, or a drawing of a G-code layer's moves by role.
 * The handler reads the artifact on the calling MHD thread: one zip
 * directory walk and one entry, or one pass over the G-code text.
 */
#include "api/api_internal.h"
#include "db/queue.h"
#include "db/store.h"
#include "engine/core/mem.h"
#include "engine/engine.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LAYER_INDEX_MAX 10000000


enum MHD_Result api_job_layer(struct api_req *r)
{
	char path[STORE_PATH_MAX], count_text[16];
	const char *ks = r->arg[1];
	struct MHD_Response *resp;
	struct job_row j;
	enum MHD_Result ret;
	enum out_format f;
	struct buf png;
	struct err e;
	long k;
	int count = 0, rc;

	if (api_load_done_job(r, &j, &ret, "the job is still running; its layers can be shown once it has succeeded",
			      "the job did not succeed, so it has no layers"))
		return ret;
	err_clear(&e);
	if (out_format_parse(j.format, &f, &e) != 0 || out_format_is_mesh(f)) {
		queue_job_row_fini(&j);
		return api_problem(r, PROB_NOT_FOUND, NULL,
				   "job %s wrote a mesh (%s), which has no layers", r->arg[0],
				   j.format);
	}
	if (!j.artifact[0]) {
		queue_job_row_fini(&j);
		return api_problem(r, PROB_GONE, NULL, "the output of job %s is no longer stored",
				   r->arg[0]);
	}
	store_artifact_path(r->srv->cfg.store_dir, r->tenant.id, j.artifact, path, sizeof path);
	queue_job_row_fini(&j);
	if (!*ks || strspn(ks, "0123456789") != strlen(ks) || strlen(ks) > 8 ||
	    (k = atol(ks)) > LAYER_INDEX_MAX)
		return api_problem(r, PROB_NOT_FOUND, NULL,
				   "no layer '%s': layers are numbered 0, 1, ...", ks);
	buf_init(&png);
	rc = out_layer_png(path, f, (int)k, &png, &count, &e);
	if (rc == ERR_NOTFOUND) {
		buf_fini(&png);
		return api_problem(r, PROB_NOT_FOUND, NULL, "%s", e.msg);
	}
	if (rc == ERR_IO) {
		buf_fini(&png);
		return api_problem(r, PROB_GONE, NULL, "the output file of job %s is missing",
				   r->arg[0]);
	}
	if (rc) {
		buf_fini(&png);
		return api_problem(r, PROB_INTERNAL, NULL, "cannot read layer %ld: %s", k, e.msg);
	}
	resp = MHD_create_response_from_buffer_with_free_callback(png.len, png.data,
								 mem_free);
	if (!resp) {
		buf_fini(&png);
		return MHD_NO;
	}
	snprintf(count_text, sizeof count_text, "%d", count);
	MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "image/png");
	MHD_add_response_header(resp, "X-Layer-Count", count_text);
	atomic_fetch_add(&r->srv->bytes_out, (long long)png.len);
	return api_queue(r, MHD_HTTP_OK, resp);
}
