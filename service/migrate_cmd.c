/* migrate_cmd.c - `infilld migrate-db --from URL --to URL`: copy a whole
 * installation's database into an empty one of either backend (SQLite to
 * PostgreSQL when one machine grows into many; docs/operations.md).  Run
 * it with the service stopped; the target is written in one transaction,
 * so a failed copy leaves it empty and can simply be repeated.  Files in
 * the store are not touched: they move with the directory.
 */
#include "db/db.h"
#include "engine/core/err.h"
#include "service/commands.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

static const char migrate_usage[] = "usage: infilld migrate-db --from URL --to URL\n";

int cmd_migrate_db(int argc, char **argv)
{
	const char *from = NULL, *to = NULL;
	char shown_from[256], shown_to[256];
	struct db *src = NULL, *dst = NULL;
	int64_t rows = 0;
	struct err e;
	int rc = 1;

	for (int i = 1; i < argc; i++) {
		const char **slot = !strcmp(argv[i], "--from") ? &from : !strcmp(argv[i], "--to") ? &to
												       : NULL;
		if (!slot || i + 1 >= argc) {
			fputs(migrate_usage, stderr);
			return 2;
		}
		*slot = argv[++i];
	}
	if (!from || !to || !db_url_valid(from) || !db_url_valid(to)) {
		fprintf(stderr, "infilld migrate-db: --from and --to want sqlite:PATH or "
				"postgresql://...\n%s",
			migrate_usage);
		return 2;
	}
	db_url_redact(from, shown_from, sizeof shown_from);
	db_url_redact(to, shown_to, sizeof shown_to);
	if (!strcmp(from, to)) {
		fprintf(stderr, "infilld migrate-db: --from and --to name the same database\n");
		return 2;
	}
	err_clear(&e);
	/* The source must exist: opening a missing SQLite file would create
	 * an empty database and "migrate" nothing. */
	if (!strncmp(from, "sqlite:", 7) && access(from + 7, R_OK) != 0) {
		fprintf(stderr, "infilld migrate-db: no database at %s\n", shown_from);
		return 1;
	}
	if (db_open(from, &src, &e)) {
		fprintf(stderr, "infilld migrate-db: %s: %s\n", shown_from, e.msg);
		return 1;
	}
	if (db_open(to, &dst, &e)) {
		fprintf(stderr, "infilld migrate-db: %s: %s\n", shown_to, e.msg);
		goto out;
	}
	if (db_copy(src, dst, &rows, &e)) {
		fprintf(stderr, "infilld migrate-db: %s\n", e.msg);
		goto out;
	}
	printf("copied %lld row(s) from %s (%s) to %s (%s)\n", (long long)rows, shown_from,
	       db_backend(src), shown_to, db_backend(dst));
	rc = 0;
out:
	db_close(dst);
	db_close(src);
	return rc;
}
