/* schema.c - versioned schema migrations.
 *
 * migrations[i] moves the schema from version i to i+1 (PRAGMA
 * user_version), each in one BEGIN IMMEDIATE transaction, so a crash
 * mid-migration leaves the previous version intact.  Append only: never
 * edit a migration that has shipped.  Times are milliseconds since the
 * Unix epoch.  Table design: docs/service.md ("Queue and storage").
 */
#include "db/sqlite/sq_internal.h"
#include "engine/core/err.h"

#include <stdio.h>

static const char *const migrations[] = {
	/* 1: tenants, keys, meshes, jobs, events, duration histogram. */
	"CREATE TABLE meta(key TEXT PRIMARY KEY, value INTEGER NOT NULL) WITHOUT ROWID;"
	"INSERT INTO meta VALUES ('serve_seq', 0);"
	"CREATE TABLE tenants("
	"  id INTEGER PRIMARY KEY,"
	"  name TEXT NOT NULL UNIQUE,"
	"  key_id TEXT NOT NULL UNIQUE,"       /* public half of the API key */
	"  key_hash BLOB NOT NULL,"            /* SHA-256 of the whole key */
	"  max_jobs INTEGER NOT NULL,"         /* concurrently running jobs */
	"  max_upload_bytes INTEGER NOT NULL,"
	"  quota_bytes INTEGER NOT NULL,"      /* meshes + artifacts, 0 = none */
	"  used_bytes INTEGER NOT NULL DEFAULT 0,"
	"  served_seq INTEGER NOT NULL DEFAULT 0," /* round-robin position */
	"  created_at INTEGER NOT NULL);"
	"CREATE INDEX tenants_served ON tenants(served_seq);"
	"CREATE TABLE admin_keys("
	"  key_id TEXT PRIMARY KEY, key_hash BLOB NOT NULL, created_at INTEGER NOT NULL"
	") WITHOUT ROWID;"
	"CREATE TABLE meshes("
	"  id TEXT PRIMARY KEY,"
	"  tenant_id INTEGER NOT NULL REFERENCES tenants(id) ON DELETE CASCADE,"
	"  name TEXT NOT NULL,"
	"  format TEXT NOT NULL,"
	"  size_bytes INTEGER NOT NULL,"
	"  sha256 TEXT NOT NULL,"
	"  analysis TEXT NOT NULL,"            /* JSON of engine_analyze() */
	"  created_at INTEGER NOT NULL);"
	"CREATE INDEX meshes_tenant ON meshes(tenant_id, created_at);"
	"CREATE TABLE jobs("
	"  seq INTEGER PRIMARY KEY AUTOINCREMENT," /* queue order, list cursor */
	"  id TEXT NOT NULL UNIQUE,"
	"  tenant_id INTEGER NOT NULL REFERENCES tenants(id) ON DELETE CASCADE,"
	"  mesh_id TEXT NOT NULL,"
	"  engine TEXT NOT NULL,"
	"  format TEXT NOT NULL,"
	"  printer TEXT NOT NULL,"
	"  params TEXT NOT NULL,"              /* JSON object of KEY: text value */
	"  idem_key TEXT,"
	"  request_hash TEXT,"
	"  fault TEXT,"                        /* test builds only (docs) */
	"  state TEXT NOT NULL DEFAULT 'queued'"
	"    CHECK (state IN ('queued','running','succeeded','failed','cancelled')),"
	"  stage TEXT NOT NULL DEFAULT 'queued',"
	"  progress REAL NOT NULL DEFAULT 0,"
	"  layers_done INTEGER NOT NULL DEFAULT 0,"
	"  layers_total INTEGER NOT NULL DEFAULT 0,"
	"  attempt INTEGER NOT NULL DEFAULT 0,"     /* fencing token */
	"  max_attempts INTEGER NOT NULL,"
	"  run_after INTEGER NOT NULL DEFAULT 0,"   /* backoff */
	"  lease_expires INTEGER,"
	"  worker TEXT,"
	"  error_type TEXT, error TEXT, error_field TEXT,"
	"  metrics TEXT,"
	"  artifact TEXT, artifact_bytes INTEGER, artifact_sha256 TEXT,"
	"  event_seq INTEGER NOT NULL DEFAULT 0,"
	"  created_at INTEGER NOT NULL, started_at INTEGER, finished_at INTEGER);"
	"CREATE INDEX jobs_lease ON jobs(lease_expires) WHERE state = 'running';"
	"CREATE INDEX jobs_tenant ON jobs(tenant_id, seq);"
	/* The claim walks this per tenant in queue order and counts running
	 * jobs with it (queue.c; test_db.c checks the plan); lists use it too. */
	"CREATE INDEX jobs_tenant_state ON jobs(tenant_id, state, seq);"
	"CREATE INDEX jobs_mesh ON jobs(mesh_id) WHERE state IN ('queued','running');"
	"CREATE INDEX jobs_finished ON jobs(finished_at) WHERE artifact IS NOT NULL;"
	"CREATE UNIQUE INDEX jobs_idem ON jobs(tenant_id, idem_key) WHERE idem_key IS NOT NULL;"
	"CREATE TABLE job_events("
	"  job_seq INTEGER NOT NULL REFERENCES jobs(seq) ON DELETE CASCADE,"
	"  n INTEGER NOT NULL,"
	"  type TEXT NOT NULL,"
	"  data TEXT NOT NULL,"
	"  PRIMARY KEY (job_seq, n)) WITHOUT ROWID;"
	"CREATE TABLE job_durations("            /* Prometheus histogram */
	"  state TEXT NOT NULL, le REAL NOT NULL, count INTEGER NOT NULL DEFAULT 0,"
	"  PRIMARY KEY (state, le)) WITHOUT ROWID;"
	"CREATE TABLE job_duration_sums("
	"  state TEXT PRIMARY KEY, count INTEGER NOT NULL, sum_s REAL NOT NULL) WITHOUT ROWID;",
	/* 2: `infilld fsck --quarantine` marks damaged artifacts (their
	 * downloads answer 410). */
	"ALTER TABLE jobs ADD COLUMN artifact_damaged_at INTEGER;",
	/* 3: the mesh's name as the job ran it, for the download's file name
	 * (the mesh may be deleted later). */
	"ALTER TABLE jobs ADD COLUMN mesh_name TEXT;",
};

int sq_schema_latest(void)
{
	return (int)(sizeof migrations / sizeof migrations[0]);
}

int sq_migrate(struct db *db, struct err *e)
{
	int latest = sq_schema_latest();

	for (;;) {
		int v, rc;
		char pragma[48];

		rc = sq_begin(db, e);
		if (rc)
			return rc;
		v = sq_schema_version(db);
		if (v < 0 || v > latest) {
			sq_rollback(db);
			return ERR_SET(e, ERR_UNSUPPORTED,
				       "database schema version %d is newer than this build's %d", v,
				       latest);
		}
		if (v == latest) {
			sq_rollback(db);
			return 0;
		}
		snprintf(pragma, sizeof pragma, "PRAGMA user_version = %d", v + 1);
		rc = sq_exec(db, migrations[v], e);
		if (!rc)
			rc = sq_exec(db, pragma, e);
		if (!rc)
			rc = sq_commit(db, e);
		if (rc) {
			sq_rollback(db);
			err_prefix(e, "migrating the schema to version %d", v + 1);
			return rc;
		}
	}
}
