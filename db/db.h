/* db.h - the service's database: connection, transactions, pool.
 *
 * Two backends behind one API (db_ops.h), chosen by the URL given to
 * db_open(): "sqlite:PATH" (the embedded default, one file in WAL mode,
 * db/sqlite/) or "postgresql://..." / "postgres://..." (many machines,
 * db/pg/).  Either holds tenants, keys, meshes, the job queue and its
 * events with the same meaning; every acknowledged write is durable
 * (SQLite synchronous=FULL, PostgreSQL synchronous_commit as the server
 * sets it, on by default).  The schema is migrated on open.  Design:
 * docs/service.md, docs/operations.md ("Many machines").
 */
#ifndef INFILLD_DB_H
#define INFILLD_DB_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* One connection; used by one thread at a time. */
struct db;

#define DB_BUSY_TIMEOUT_MS 5000

/* Open the database named by url ("sqlite:PATH", "postgresql://...";
 * a bare path means sqlite:PATH), creating an SQLite file, and migrate it
 * to the current schema.  Caller frees with db_close().  ERR_PARAM for an
 * unknown scheme, ERR_IO when the database cannot be reached. */
int db_open(const char *url, struct db **out, struct err *e);
void db_close(struct db *db);
/* "sqlite" or "postgresql". */
const char *db_backend(const struct db *db);
/* Nonzero when url names a database db_open() can try. */
int db_url_valid(const char *url);
/* url with any password replaced by "***" (for logs), into buf. */
void db_url_redact(const char *url, char *buf, size_t len);

/* Schema version after migrations. */
int db_schema_version(struct db *db);
/* Number of migrations this build knows for db's backend. */
int db_schema_latest(const struct db *db);

/* BEGIN IMMEDIATE / COMMIT / ROLLBACK.  db_rollback() never fails
 * (it is called on error paths). */
int db_begin(struct db *db, struct err *e);
int db_commit(struct db *db, struct err *e);
void db_rollback(struct db *db);

/* Wall clock, milliseconds since the Unix epoch (timestamps in rows). */
int64_t db_now_ms(void);

/* Cheap write probe for /readyz: a write transaction that changes
 * nothing.  0 or ERR_IO. */
int db_check_writable(struct db *db, struct err *e);

/* Job-change notifications (SSE across machines).  After db_listen(),
 * db_wait() blocks up to timeout_ms for jobs whose events changed and
 * puts their seqs in seqs[0..cap); *n = how many, 0 on timeout, or -1
 * when the backend cannot name them (SQLite: it sleeps timeout_ms; more
 * than cap at once): the caller then re-reads every job it watches.
 * PostgreSQL: LISTEN/NOTIFY on one dedicated connection. */
int db_listen(struct db *db, struct err *e);
int db_wait(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e);

/* Copy every row of src into dst, whose schema must be empty (no
 * tenants, no jobs): `infilld migrate-db`.  One transaction on dst;
 * *rows = rows copied.  ERR_PARAM when dst holds data. */
int db_copy(struct db *src, struct db *dst, int64_t *rows, struct err *e);

/* Refresh the query planner's statistics (ANALYZE), as after a bulk
 * load: db_copy() runs it on its target.  0 or ERR_IO. */
int db_analyze(struct db *db, struct err *e);

/* Fixed set of connections shared by threads (HTTP handlers). */
struct db_pool;

int db_pool_new(const char *url, int size, struct db_pool **out, struct err *e);
void db_pool_free(struct db_pool *p);
/* Borrow a connection (waits while all are lent).  Return it with
 * db_pool_put().  Never fails once the pool exists. */
struct db *db_pool_get(struct db_pool *p);
void db_pool_put(struct db_pool *p, struct db *db);

/* Random public id: prefix + 20 characters of [a-z2-7] (100 bits), e.g.
 * "j_..."; buf must hold DB_ID_MAX bytes.  0 or ERR_IO. */
#define DB_ID_MAX 32
int db_make_id(const char *prefix, char *buf, struct err *e);
/* Nonzero when id looks like one db_make_id(prefix) made (so hostile path
 * characters never reach SQL or the file system). */
int db_id_valid(const char *prefix, const char *id);

#endif
