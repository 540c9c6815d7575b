/* copy.c - `infilld migrate-db` on PostgreSQL: every row of a table out
 * (streamed in libpq's single-row mode, so a large job_events table is
 * never held in memory), one row in as given (ids included), and moving
 * the identity sequences and the round-robin counter past the copied ids
 * at the end (see copy_out/copy_in/copy_done in db_ops.h).
 *
 * Table and column names come from the static table list of db/copy.c,
 * never from input, so they are spliced into the SQL as they are.
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define COPY_SQL_MAX 2048

/* "c1, c2, ..." of t into buf; 0 or ERR_INTERNAL when it does not fit. */
static int col_list(const struct db_table *t, const char *prefix, char *buf, size_t len,
		    struct err *e)
{
	size_t k = 0;

	for (int i = 0; i < t->ncols; i++) {
		int w = snprintf(buf + k, len - k, "%s%s%s", i ? ", " : "", prefix, t->cols[i]);
		if (w < 0 || (size_t)w >= len - k)
			return ERR_SET(e, ERR_INTERNAL, "copy: column list of %s too long", t->name);
		k += (size_t)w;
	}
	return 0;
}

/* Row i of r as values in t's column order; blobs decoded into blobs[]
 * (caller frees with PQfreemem()). */
static int to_vals(const struct db_table *t, PGresult *r, int i, struct db_val *v,
		   unsigned char **blobs, struct err *e)
{
	for (int c = 0; c < t->ncols; c++) {
		memset(&v[c], 0, sizeof v[c]);
		blobs[c] = NULL;
		if (PQgetisnull(r, i, c))
			continue;
		v[c].type = t->types[c];
		switch (t->types[c]) {
		case 'i': v[c].i = pgdb_i64(r, i, c); break;
		case 'r': v[c].r = pgdb_f64(r, i, c); break;
		case 'b': {
			size_t n = 0;
			blobs[c] = PQunescapeBytea((const unsigned char *)PQgetvalue(r, i, c), &n);
			if (!blobs[c])
				return ERR_SET(e, ERR_NOMEM, "copy: out of memory reading %s.%s",
					       t->name, t->cols[c]);
			v[c].p = blobs[c];
			v[c].len = n;
			break;
		}
		default:
			v[c].type = 't';
			v[c].p = PQgetvalue(r, i, c);
			v[c].len = (size_t)PQgetlength(r, i, c);
			break;
		}
	}
	return 0;
}

int pgdb_copy_out(struct db *db, const struct db_table *t,
		  int (*row)(void *ctx, const struct db_val *v), void *ctx, struct err *e)
{
	char sql[COPY_SQL_MAX], cols[COPY_SQL_MAX - 128];
	struct db_val v[PGDB_MAX_PARAMS];
	unsigned char *blobs[PGDB_MAX_PARAMS];
	PGconn *c = PGC(db);
	PGresult *r;
	int rc, stopped = 0;

	if (t->ncols > PGDB_MAX_PARAMS)
		return ERR_SET(e, ERR_INTERNAL, "copy: %s has too many columns", t->name);
	if ((rc = col_list(t, "", cols, sizeof cols, e)))
		return rc;
	snprintf(sql, sizeof sql, "SELECT %s FROM %s ORDER BY %s", cols, t->name, t->order_by);
	/* A large table may take longer than a statement may here. */
	if ((rc = pgdb_run(db, "SET statement_timeout = 0", NULL, "copy", e)))
		return rc;
	if (!PQsendQueryParams(c, sql, 0, NULL, NULL, NULL, NULL, 0) || !PQsetSingleRowMode(c)) {
		rc = pgdb_fail(db, NULL, e, "copy: reading a table");
		goto out;
	}
	while ((r = PQgetResult(c))) {
		ExecStatusType st = PQresultStatus(r);

		if (st == PGRES_SINGLE_TUPLE && !rc && !stopped) {
			rc = to_vals(t, r, 0, v, blobs, e);
			if (!rc && (rc = row(ctx, v)))
				stopped = 1;
			for (int k = 0; k < t->ncols; k++)
				PQfreemem(blobs[k]);
			if (rc) {
				/* Stop the server sending the rest. */
				PGcancel *cn = PQgetCancel(c);
				char buf[256];
				if (cn) {
					PQcancel(cn, buf, sizeof buf);
					PQfreeCancel(cn);
				}
			}
		} else if (st != PGRES_SINGLE_TUPLE && st != PGRES_TUPLES_OK && !rc) {
			rc = pgdb_fail(db, r, e, "copy: reading a table");
		}
		PQclear(r);
	}
out:
	/* The connection may now be idle or broken; best effort. */
	PQclear(PQexec(c, "SET statement_timeout = " PGDB_STATEMENT_TIMEOUT));
	return rc;
}

int pgdb_copy_in(struct db *db, const struct db_table *t, const struct db_val *v,
		 struct err *e)
{
	char sql[COPY_SQL_MAX], cols[COPY_SQL_MAX / 2], marks[COPY_SQL_MAX / 4];
	char *texts[PGDB_MAX_PARAMS] = {0};
	struct pgdb_params p;
	size_t k = 0;
	int rc = 0;

	if (t->ncols > PGDB_MAX_PARAMS)
		return ERR_SET(e, ERR_INTERNAL, "copy: %s has too many columns", t->name);
	if ((rc = col_list(t, "", cols, sizeof cols, e)))
		return rc;
	for (int i = 0; i < t->ncols; i++)
		k += (size_t)snprintf(marks + k, sizeof marks - k, "%s$%d", i ? ", " : "", i + 1);
	snprintf(sql, sizeof sql, "INSERT INTO %s (%s) VALUES (%s)", t->name, cols, marks);
	pgdb_p_init(&p);
	for (int i = 0; i < t->ncols && !rc; i++) {
		switch (v[i].type) {
		case 0: pgdb_p_text(&p, NULL); break;
		case 'i': pgdb_p_i64(&p, v[i].i); break;
		case 'r': pgdb_p_f64(&p, v[i].r); break;
		case 'b': pgdb_p_bin(&p, v[i].p, v[i].len); break;
		default:
			/* Text goes in text format (the server reads it as the
			 * column's type), which wants a C string. */
			if (!(texts[i] = malloc(v[i].len + 1))) {
				rc = ERR_SET(e, ERR_NOMEM, "copy: out of memory");
				break;
			}
			if (v[i].len)
				memcpy(texts[i], v[i].p, v[i].len);
			texts[i][v[i].len] = '\0';
			pgdb_p_text(&p, texts[i]);
			break;
		}
	}
	if (!rc) {
		PGresult *r = pgdb_q_once(db, sql, &p, "copy: inserting a row", e);
		if (r)
			PQclear(r);
		else
			rc = ERR_IO;
	}
	for (int i = 0; i < t->ncols; i++)
		free(texts[i]);
	return rc;
}

int pgdb_copy_done(struct db *db, struct err *e)
{
	/* setval(..., false): the next id handed out is max + 1; serve_seq's
	 * last value becomes the highest position copied (tenants added later
	 * start there, tenants.c). */
	static const char sql[] =
		"SELECT setval(pg_get_serial_sequence('tenants', 'id'),"
		" coalesce((SELECT max(id) FROM tenants), 0) + 1, false);"
		"SELECT setval(pg_get_serial_sequence('jobs', 'seq'),"
		" coalesce((SELECT max(seq) FROM jobs), 0) + 1, false);"
		"SELECT setval('serve_seq', m, true)"
		" FROM (SELECT max(served_seq) AS m FROM tenants) s WHERE m >= 1";

	return pgdb_exec(db, sql, e);
}
