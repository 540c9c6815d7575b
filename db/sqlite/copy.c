/* copy.c - the SQLite backend's copy ops for `infilld migrate-db` (see
 * db_copy() in db.h): rows out in a table's order, rows in as given.
 * The SQL is built from the table lists of db/copy.c (static names, never
 * user input), so it is prepared per call rather than cached.
 */
#include "db/sqlite/sq_internal.h"
#include "engine/core/err.h"

#include <stdio.h>
#include <string.h>

/* "a, b, c" of t's columns into buf. */
static int col_list(const struct db_table *t, char *buf, size_t len)
{
	size_t k = 0;

	buf[0] = '\0';
	for (int i = 0; i < t->ncols; i++) {
		int w = snprintf(buf + k, len - k, "%s%s", i ? ", " : "", t->cols[i]);
		if (w < 0 || (size_t)w >= len - k)
			return -1;
		k += (size_t)w;
	}
	return 0;
}

int sq_copy_out(struct db *db, const struct db_table *t,
		int (*row)(void *ctx, const struct db_val *v), void *ctx, struct err *e)
{
	char cols[1024], sql[1400];
	struct db_val v[64];
	sqlite3_stmt *st;
	int rc = 0, step;

	if (t->ncols > 64 || col_list(t, cols, sizeof cols) ||
	    snprintf(sql, sizeof sql, "SELECT %s FROM %s ORDER BY %s", cols, t->name,
		     t->order_by) >= (int)sizeof sql)
		return ERR_SET(e, ERR_INTERNAL, "copy: table %s too wide", t->name);
	if (sqlite3_prepare_v2(SQ(db), sql, -1, &st, NULL) != SQLITE_OK)
		return sq_fail(db, e, "reading rows to copy");
	while (!rc && (step = sqlite3_step(st)) == SQLITE_ROW) {
		for (int i = 0; i < t->ncols; i++) {
			memset(&v[i], 0, sizeof v[i]);
			if (sqlite3_column_type(st, i) == SQLITE_NULL)
				continue;
			v[i].type = t->types[i];
			switch (t->types[i]) {
			case 'i':
				v[i].i = sqlite3_column_int64(st, i);
				break;
			case 'r':
				v[i].r = sqlite3_column_double(st, i);
				break;
			case 'b':
				v[i].p = sqlite3_column_blob(st, i);
				v[i].len = (size_t)sqlite3_column_bytes(st, i);
				break;
			default:
				v[i].p = sqlite3_column_text(st, i);
				v[i].len = (size_t)sqlite3_column_bytes(st, i);
				break;
			}
		}
		rc = row(ctx, v);
	}
	if (!rc && step != SQLITE_DONE)
		rc = sq_fail(db, e, "reading rows to copy");
	sqlite3_finalize(st);
	return rc;
}

int sq_copy_in(struct db *db, const struct db_table *t, const struct db_val *v, struct err *e)
{
	char cols[1024], sql[1600];
	size_t k;
	sqlite3_stmt *st;
	int rc;

	if (col_list(t, cols, sizeof cols))
		return ERR_SET(e, ERR_INTERNAL, "copy: table %s too wide", t->name);
	k = (size_t)snprintf(sql, sizeof sql, "INSERT INTO %s(%s) VALUES (", t->name, cols);
	for (int i = 0; i < t->ncols && k < sizeof sql; i++)
		k += (size_t)snprintf(sql + k, sizeof sql - k, "%s?", i ? ", " : "");
	if (k + 2 > sizeof sql)
		return ERR_SET(e, ERR_INTERNAL, "copy: table %s too wide", t->name);
	memcpy(sql + k, ")", 2);
	if (sqlite3_prepare_v2(SQ(db), sql, -1, &st, NULL) != SQLITE_OK)
		return sq_fail(db, e, "writing copied rows");
	for (int i = 0; i < t->ncols; i++) {
		switch (v[i].type) {
		case 0:
			sqlite3_bind_null(st, i + 1);
			break;
		case 'i':
			sqlite3_bind_int64(st, i + 1, v[i].i);
			break;
		case 'r':
			sqlite3_bind_double(st, i + 1, v[i].r);
			break;
		case 'b':
			sqlite3_bind_blob(st, i + 1, v[i].p, (int)v[i].len, SQLITE_STATIC);
			break;
		default:
			sqlite3_bind_text(st, i + 1, v[i].p, (int)v[i].len, SQLITE_STATIC);
			break;
		}
	}
	rc = sqlite3_step(st) == SQLITE_DONE ? 0 : sq_fail(db, e, "writing copied rows");
	sqlite3_finalize(st);
	return rc;
}
