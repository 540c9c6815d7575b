/* db.c - the backend-independent part of the connection (see db.h): the
 * URL that picks a backend, the calls into its ops, the connection pool
 * and public ids.
 */
#include "db/db_ops.h"
#include "engine/core/err.h"

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <time.h>

/* ---- connection: the URL picks the backend ---- */

/* The backend for url and what its open() takes, or NULL. */
static const struct db_ops *backend_of(const char *url, const char **target)
{
	if (!url || !url[0])
		return NULL;
	if (!strncmp(url, "sqlite:", 7)) {
		*target = url + 7;
		return url[7] ? &db_sqlite_ops : NULL;
	}
	if (!strncmp(url, "postgresql://", 13) || !strncmp(url, "postgres://", 11)) {
		*target = url;
		return &db_pg_ops;
	}
	if (strstr(url, "://"))
		return NULL;
	*target = url; /* a bare path */
	return &db_sqlite_ops;
}

int db_url_valid(const char *url)
{
	const char *t;

	return backend_of(url, &t) != NULL;
}

void db_url_redact(const char *url, char *buf, size_t len)
{
	const char *scheme = url ? strstr(url, "://") : NULL;
	const char *at = scheme ? strchr(scheme + 3, '@') : NULL;
	const char *colon = at ? memchr(scheme + 3, ':', (size_t)(at - scheme - 3)) : NULL;
	const char *p = url ? url : "";
	size_t k = 0;

	if (!len)
		return;
	/* Passwords come as user:PASSWORD@ or as a password= parameter. */
	while (*p && k + 13 < len) {
		if (colon && p == colon + 1) {
			memcpy(buf + k, "***", 3);
			k += 3;
			p = at;
		} else if (!strncmp(p, "password=", 9) && p > url && (p[-1] == '?' || p[-1] == '&')) {
			memcpy(buf + k, "password=***", 12);
			k += 12;
			p += 9 + strcspn(p + 9, "&");
		} else {
			buf[k++] = *p++;
		}
	}
	buf[k] = '\0';
}

int db_open(const char *url, struct db **out, struct err *e)
{
	const char *target = NULL;
	const struct db_ops *ops = backend_of(url, &target);
	char shown[256];

	if (!ops) {
		db_url_redact(url, shown, sizeof shown);
		return ERR_FIELD(e, "db",
				 "'%s' is not a database URL this build knows "
				 "(sqlite:PATH or postgresql://...)",
				 shown);
	}
	return ops->open(target, out, e);
}

void db_close(struct db *db)
{
	if (db)
		db->ops->close(db);
}

const char *db_backend(const struct db *db)
{
	return db->ops->name;
}

int db_schema_version(struct db *db)
{
	return db->ops->schema_version(db);
}

int db_schema_latest(const struct db *db)
{
	return db->ops->schema_latest();
}

int db_begin(struct db *db, struct err *e)
{
	return db->ops->begin(db, e);
}

int db_commit(struct db *db, struct err *e)
{
	return db->ops->commit(db, e);
}

void db_rollback(struct db *db)
{
	db->ops->rollback(db);
}

int db_check_writable(struct db *db, struct err *e)
{
	return db->ops->check_writable(db, e);
}

int db_analyze(struct db *db, struct err *e)
{
	return db->ops->analyze(db, e);
}

int db_listen(struct db *db, struct err *e)
{
	return db->ops->listen(db, e);
}

int db_wait(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e)
{
	return db->ops->wait(db, timeout_ms, seqs, cap, n, e);
}

int64_t db_now_ms(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
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

int db_pool_new(const char *url, int size, struct db_pool **out, struct err *e)
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
		rc = db_open(url, &p->free_v[i], e);
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
