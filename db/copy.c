/* copy.c - db_copy(): every row of one database into another, either
 * backend to either (`infilld migrate-db`).  The tables are listed here
 * once, parents before children so foreign keys hold row by row; each
 * backend reads and writes them with its copy ops (db_ops.h).  The
 * target is written in one transaction, so a failed copy leaves it empty.
 */
#include "db/db_ops.h"
#include "engine/core/err.h"

#include <stdlib.h>
#include <string.h>

static const char *const tenant_cols[] = {"id",          "name",           "key_id",
					  "key_hash",    "max_jobs",       "max_upload_bytes",
					  "quota_bytes", "used_bytes",     "served_seq",
					  "created_at"};
static const char *const admin_cols[] = {"key_id", "key_hash", "created_at"};
static const char *const mesh_cols[] = {"id",     "tenant_id", "name",     "format",
					"size_bytes", "sha256", "analysis", "created_at"};
static const char *const job_cols[] = {
	"seq",          "id",           "tenant_id",      "mesh_id",         "engine",
	"format",       "printer",      "params",         "idem_key",        "request_hash",
	"fault",        "state",        "stage",          "progress",        "layers_done",
	"layers_total", "attempt",      "max_attempts",   "run_after",       "lease_expires",
	"worker",       "error_type",   "error",          "error_field",     "metrics",
	"artifact",     "artifact_bytes", "artifact_sha256", "event_seq",    "created_at",
	"started_at",   "finished_at",  "artifact_damaged_at", "mesh_name"};
static const char *const event_cols[] = {"job_seq", "n", "type", "data"};
static const char *const duration_cols[] = {"state", "le", "count"};
static const char *const sum_cols[] = {"state", "count", "sum_s"};

#define TABLE(name, cols, types, order) {name, sizeof cols / sizeof cols[0], cols, types, order}

static const struct db_table tables[] = {
	TABLE("tenants", tenant_cols, "ittbiiiiii", "id"),
	TABLE("admin_keys", admin_cols, "tbi", "key_id"),
	TABLE("meshes", mesh_cols, "tittitti", "id"),
	TABLE("jobs", job_cols, "itittttttttttriiiiiittttttitiiiiit", "seq"),
	TABLE("job_events", event_cols, "iitt", "job_seq, n"),
	TABLE("job_durations", duration_cols, "tri", "state, le"),
	TABLE("job_duration_sums", sum_cols, "tir", "state"),
};

struct copy_ctx {
	struct db *dst;
	const struct db_table *t;
	int64_t rows;
	struct err *e;
};

static int copy_row(void *cls, const struct db_val *v)
{
	struct copy_ctx *c = cls;
	int rc = c->dst->ops->copy_in(c->dst, c->t, v, c->e);

	if (!rc)
		c->rows++;
	return rc;
}

int db_copy(struct db *src, struct db *dst, int64_t *rows, struct err *e)
{
	struct copy_ctx c = {dst, NULL, 0, e};
	int64_t counts[JOB_STATE_COUNT], jobs = 0;
	struct tenant *tv = NULL;
	int n = 0, rc;

	*rows = 0;
	if ((rc = db_tenant_list(dst, &tv, &n, e)) || (rc = queue_counts(dst, counts, e)))
		return rc;
	free(tv);
	for (int i = 0; i < JOB_STATE_COUNT; i++)
		jobs += counts[i];
	if (n || jobs)
		return ERR_FIELD(e, "to",
				 "the target database holds data (%d tenant(s), %lld job(s)); "
				 "migrate-db copies into an empty one only",
				 n, (long long)jobs);
	if ((rc = db_begin(dst, e)))
		return rc;
	for (size_t i = 0; i < sizeof tables / sizeof tables[0]; i++) {
		if ((int)strlen(tables[i].types) != tables[i].ncols) {
			rc = ERR_SET(e, ERR_INTERNAL, "copy: table %s lists %d columns, %d types",
				     tables[i].name, tables[i].ncols, (int)strlen(tables[i].types));
			break;
		}
		c.t = &tables[i];
		rc = src->ops->copy_out(src, &tables[i], copy_row, &c, e);
		if (rc) {
			err_prefix(e, "copying table %s", tables[i].name);
			break;
		}
	}
	if (!rc)
		rc = dst->ops->copy_done(dst, e);
	if (!rc)
		rc = db_commit(dst, e);
	if (rc) {
		db_rollback(dst);
		return rc;
	}
	*rows = c.rows;
	/* A bulk load leaves the planner's statistics describing an empty
	 * database until the next automatic ANALYZE. */
	return db_analyze(dst, e);
}
