/* db_internal.h - what the files of db/ share: the connection struct and
 * the prepared-statement cache.  Nothing outside db/ includes it.
 */
#ifndef INFILLD_DB_INTERNAL_H
#define INFILLD_DB_INTERNAL_H

#include <sqlite3.h>

#include "db/db.h"

#define DB_STMT_CACHE 48

struct db_stmt_slot {
	const char *sql; /* static string: the cache key is the pointer */
	sqlite3_stmt *st;
};

struct db {
	sqlite3 *sq;
	struct db_stmt_slot cache[DB_STMT_CACHE];
	int ncache;
};

/* Prepared statement for a static SQL string, reset and unbound, owned by
 * the cache (never finalize it).  NULL with e filled (ERR_IO/ERR_INTERNAL). */
sqlite3_stmt *db_stmt(struct db *db, const char *sql, struct err *e);

/* Fill e from the connection's last error: "what: sqlite message". */
int db_fail(struct db *db, struct err *e, const char *what);

/* Run SQL with no result rows (one or more statements). */
int db_exec(struct db *db, const char *sql, struct err *e);

/* sqlite3_column_text() as a C string, "" for NULL. */
const char *db_col_text(sqlite3_stmt *st, int col);
/* Copy column text into buf (truncated to len-1). */
void db_col_copy(sqlite3_stmt *st, int col, char *buf, size_t len);
/* Heap copy of column text (NULL for SQL NULL); caller frees with free(). */
char *db_col_dup(sqlite3_stmt *st, int col);

/* Migrations (schema.c): apply everything past PRAGMA user_version. */
int db_migrate(struct db *db, struct err *e);

#endif
