/* db.h - the service's SQLite database: connection, transactions, pool.
 *
 * One file (DATA/infilld.db) in WAL mode holds tenants, keys, meshes, the
 * job queue and its events.  Every connection runs synchronous=FULL (a
 * job the client was told about survives power loss), a busy timeout and
 * foreign keys; every write is a BEGIN IMMEDIATE transaction.  The schema
 * is migrated on open (schema.c).  Design: docs/service.md.
 */
#ifndef INFILLD_DB_H
#define INFILLD_DB_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* One connection; used by one thread at a time. */
struct db;

#define DB_BUSY_TIMEOUT_MS 5000

/* Open (creating) the database at path and migrate it to the current
 * schema.  Caller frees with db_close().  ERR_IO on failure. */
int db_open(const char *path, struct db **out, struct err *e);
void db_close(struct db *db);

/* Schema version after migrations (PRAGMA user_version). */
int db_schema_version(struct db *db);
/* Number of migrations this build knows (schema.c). */
int db_schema_latest(void);

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

/* Fixed set of connections shared by threads (HTTP handlers). */
struct db_pool;

int db_pool_new(const char *path, int size, struct db_pool **out, struct err *e);
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
