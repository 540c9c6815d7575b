/* db.c - SQLite connection set-up, transactions, statement cache, the
 * connection pool and public ids (see db.h).
 */
#include "db/db_internal.h"
#include "engine/core/err.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

int db_fail(struct db *db, struct err *e, const char *what)
{
	return ERR_SET(e, ERR_IO, "%s: %s", what, db && db->sq ? sqlite3_errmsg(db->sq) : "no database");
}

int db_exec(struct db *db, const char *sql, struct err *e)
{
	char *msg = NULL;

	if (sqlite3_exec(db->sq, sql, NULL, NULL, &msg) != SQLITE_OK) {
		ERR_SET(e, ERR_IO, "sql failed: %s", msg ? msg : sqlite3_errmsg(db->sq));
		sqlite3_free(msg);
		return ERR_IO;
	}
	return 0;
}

int db_open(const char *path, struct db **out, struct err *e)
{
	struct db *db = calloc(1, sizeof *db);
	int rc;

	if (!db)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the database");
	rc = sqlite3_open_v2(path, &db->sq,
			     SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, NULL);
	if (rc != SQLITE_OK) {
		rc = ERR_SET(e, ERR_IO, "cannot open database %s: %s", path,
			     db->sq ? sqlite3_errmsg(db->sq) : sqlite3_errstr(rc));
		goto out;
	}
	sqlite3_busy_timeout(db->sq, DB_BUSY_TIMEOUT_MS);
	/* WAL: readers never block the writer.  synchronous=FULL: a commit is
	 * on disk before we acknowledge it (NORMAL could lose the last
	 * transactions on power loss).  The WAL is checkpointed by SQLite's
	 * auto-checkpoint at 1000 pages; journal_size_limit truncates it. */
	rc = db_exec(db,
		     "PRAGMA journal_mode=WAL;"
		     "PRAGMA synchronous=FULL;"
		     "PRAGMA foreign_keys=ON;"
		     "PRAGMA journal_size_limit=67108864;"
		     "PRAGMA temp_store=MEMORY;",
		     e);
	if (rc)
		goto out;
	rc = db_migrate(db, e);
out:
	if (rc) {
		db_close(db);
		return rc;
	}
	*out = db;
	return 0;
}

void db_close(struct db *db)
{
	if (!db)
		return;
	for (int i = 0; i < db->ncache; i++)
		sqlite3_finalize(db->cache[i].st);
	sqlite3_close_v2(db->sq);
	free(db);
}

int db_schema_version(struct db *db)
{
	sqlite3_stmt *st = db_stmt(db, "PRAGMA user_version", NULL);
	int v = -1;

	if (st && sqlite3_step(st) == SQLITE_ROW)
		v = sqlite3_column_int(st, 0);
	if (st)
		sqlite3_reset(st);
	return v;
}

sqlite3_stmt *db_stmt(struct db *db, const char *sql, struct err *e)
{
	sqlite3_stmt *st;

	for (int i = 0; i < db->ncache; i++)
		if (db->cache[i].sql == sql) {
			st = db->cache[i].st;
			sqlite3_reset(st);
			sqlite3_clear_bindings(st);
			return st;
		}
	if (sqlite3_prepare_v3(db->sq, sql, -1, SQLITE_PREPARE_PERSISTENT, &st, NULL) != SQLITE_OK) {
		db_fail(db, e, "prepare");
		return NULL;
	}
	if (db->ncache == DB_STMT_CACHE) {
		/* Full: evict the oldest (statements are few and static). */
		sqlite3_finalize(db->cache[0].st);
		memmove(db->cache, db->cache + 1, sizeof db->cache[0] * (DB_STMT_CACHE - 1));
		db->ncache--;
	}
	db->cache[db->ncache].sql = sql;
	db->cache[db->ncache].st = st;
	db->ncache++;
	return st;
}

static int step_done(struct db *db, const char *sql, struct err *e)
{
	sqlite3_stmt *st = db_stmt(db, sql, e);
	int rc;

	if (!st)
		return ERR_IO;
	rc = sqlite3_step(st);
	sqlite3_reset(st);
	if (rc != SQLITE_DONE)
		return db_fail(db, e, sql);
	return 0;
}

int db_begin(struct db *db, struct err *e)
{
	return step_done(db, "BEGIN IMMEDIATE", e);
}

int db_commit(struct db *db, struct err *e)
{
	int rc = step_done(db, "COMMIT", e);

	if (rc)
		db_rollback(db);
	return rc;
}

void db_rollback(struct db *db)
{
	if (!sqlite3_get_autocommit(db->sq))
		sqlite3_exec(db->sq, "ROLLBACK", NULL, NULL, NULL);
}

int db_check_writable(struct db *db, struct err *e)
{
	int rc = db_begin(db, e);

	if (rc)
		return rc;
	rc = step_done(db, "UPDATE meta SET value = value WHERE key = 'serve_seq'", e);
	if (rc) {
		db_rollback(db);
		return rc;
	}
	return db_commit(db, e);
}

int64_t db_now_ms(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

const char *db_col_text(sqlite3_stmt *st, int col)
{
	const unsigned char *t = sqlite3_column_text(st, col);

	return t ? (const char *)t : "";
}

void db_col_copy(sqlite3_stmt *st, int col, char *buf, size_t len)
{
	const char *t = db_col_text(st, col);
	size_t n = strlen(t);

	if (n >= len)
		n = len - 1;
	memcpy(buf, t, n);
	buf[n] = '\0';
}

char *db_col_dup(sqlite3_stmt *st, int col)
{
	if (sqlite3_column_type(st, col) == SQLITE_NULL)
		return NULL;
	return strdup(db_col_text(st, col));
}

/* ---- ids ---- */

static const char id_alphabet[] = "abcdefghijklmnopqrstuvwxyz234567";
#define ID_CHARS 20

int db_make_id(const char *prefix, char *buf, struct err *e)
{
	unsigned char rnd[ID_CHARS];
	size_t pl = strlen(prefix), got = 0;

	if (pl + ID_CHARS + 1 > DB_ID_MAX)
		return ERR_SET(e, ERR_INTERNAL, "id prefix too long");
	while (got < sizeof rnd) {
		ssize_t n = getrandom(rnd + got, sizeof rnd - got, 0);
		if (n < 0) {
			if (errno == EINTR)
				continue;
			return ERR_SET(e, ERR_IO, "getrandom: %s", strerror(errno));
		}
		got += (size_t)n;
	}
	memcpy(buf, prefix, pl);
	for (int i = 0; i < ID_CHARS; i++)
		buf[pl + (size_t)i] = id_alphabet[rnd[i] & 31];
	buf[pl + ID_CHARS] = '\0';
	return 0;
}

int db_id_valid(const char *prefix, const char *id)
{
	size_t pl = strlen(prefix);

	if (!id || strncmp(id, prefix, pl) != 0 || strlen(id) != pl + ID_CHARS)
		return 0;
	for (size_t i = pl; i < pl + ID_CHARS; i++)
		if (!strchr(id_alphabet, id[i]) || id[i] == '\0')
			return 0;
	return 1;
}

/* ---- pool ---- */

struct db_pool {
	pthread_mutex_t mu;
	pthread_cond_t cv;
	struct db **free_v;
	int nfree, size;
};

int db_pool_new(const char *path, int size, struct db_pool **out, struct err *e)
{
	struct db_pool *p = calloc(1, sizeof *p);
	int rc = 0;

	if (!p || size < 1 || !(p->free_v = calloc((size_t)size, sizeof *p->free_v))) {
		free(p);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the connection pool");
	}
	pthread_mutex_init(&p->mu, NULL);
	pthread_cond_init(&p->cv, NULL);
	p->size = size;
	for (int i = 0; i < size; i++) {
		rc = db_open(path, &p->free_v[i], e);
		if (rc)
			break;
		p->nfree++;
	}
	if (rc) {
		db_pool_free(p);
		return rc;
	}
	*out = p;
	return 0;
}

void db_pool_free(struct db_pool *p)
{
	if (!p)
		return;
	for (int i = 0; i < p->nfree; i++)
		db_close(p->free_v[i]);
	free(p->free_v);
	pthread_mutex_destroy(&p->mu);
	pthread_cond_destroy(&p->cv);
	free(p);
}

struct db *db_pool_get(struct db_pool *p)
{
	struct db *db;

	pthread_mutex_lock(&p->mu);
	while (p->nfree == 0)
		pthread_cond_wait(&p->cv, &p->mu);
	db = p->free_v[--p->nfree];
	pthread_mutex_unlock(&p->mu);
	return db;
}

void db_pool_put(struct db_pool *p, struct db *db)
{
	if (!db)
		return;
	db_rollback(db); /* a handler that bailed out mid-transaction */
	pthread_mutex_lock(&p->mu);
	p->free_v[p->nfree++] = db;
	pthread_cond_signal(&p->cv);
	pthread_mutex_unlock(&p->mu);
}
