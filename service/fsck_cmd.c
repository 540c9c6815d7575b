/* fsck_cmd.c - `infilld fsck [--data DIR] [--db URL] [--store DIR]
 * [--quarantine]`: check every artifact against the size and SHA-256 the
 * database recorded when it was published; report missing and damaged
 * ones; with --quarantine move the damaged files to
 * STORE/quarantine/<tenant id>/ and mark their jobs, so downloads answer
 * 410 (db/artifacts.h).  Exit 0 when all are intact, 1
 * when any is missing or damaged, 2 for usage.  Safe while serve runs.
 */
#include "db/artifacts.h"
#include "db/db.h"
#include "db/store.h"
#include "db/tenants.h"
#include "engine/core/err.h"
#include "service/commands.h"
#include "service/config.h"

#include <errno.h>
#include <fcntl.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char fsck_usage[] =
	"usage: infilld fsck [--data DIR] [--db URL] [--store DIR] [--quarantine]\n";

/* Size and SHA-256 (hex) of path: 0, or -1 with errno when unreadable. */
static int digest_file(const char *path, int64_t *bytes, char hex[65])
{
	int rc, fd = open(path, O_RDONLY | O_CLOEXEC), saved;

	if (fd < 0)
		return -1;
	rc = store_fd_sha256(fd, bytes, hex);
	saved = errno;
	close(fd);
	errno = saved;
	return rc;
}

/* Move a damaged file aside and mark its job; 0 or -1 (printed). */
static int quarantine(struct db *db, const char *data, const struct artifact_rec *a,
		      const char *path)
{
	char dir[STORE_PATH_MAX], dest[STORE_PATH_MAX];
	struct err e;

	err_clear(&e);
	snprintf(dir, sizeof dir, "%s/quarantine/%lld", data, (long long)a->tenant_id);
	if (snprintf(dest, sizeof dest, "%s/%s", dir, a->name) >= (int)sizeof dest ||
	    store_mkdirs(dir, &e) || rename(path, dest) != 0) {
		fprintf(stderr, "infilld fsck: cannot move %s aside: %s\n", path,
			e.msg[0] ? e.msg : strerror(errno));
		return -1;
	}
	if (db_artifact_quarantine(db, a->seq, &e)) {
		fprintf(stderr, "infilld fsck: cannot mark job %s: %s\n", a->job_id, e.msg);
		return -1;
	}
	printf("quarantined %s -> %s\n", a->job_id, dest);
	return 0;
}

int cmd_fsck(int argc, char **argv)
{
	struct service_config c;
	const char *data;
	char path[STORE_PATH_MAX];
	int64_t after = 0;
	long checked = 0, missing = 0, damaged = 0;
	int quarantine_on = 0, failed = 0;
	struct db *db;
	struct err e;

	config_defaults(&c);
	for (int i = 1; i < argc; i++) {
		int took = config_take_location(&c, "fsck", argc, argv, &i);
		if (took < 0)
			return 2;
		if (took)
			continue;
		if (!strcmp(argv[i], "--quarantine")) {
			quarantine_on = 1;
		} else {
			fputs(fsck_usage, stderr);
			return 2;
		}
	}
	err_clear(&e);
	if (config_resolve(&c, "fsck"))
		return 2;
	data = c.store_dir;
	/* Never create a database: fsck checks an existing installation. */
	if ((!strncmp(c.db_url, "sqlite:", 7) && access(c.db_url + 7, F_OK) != 0) ||
	    db_open(c.db_url, &db, &e)) {
		char shown[256];
		db_url_redact(c.db_url, shown, sizeof shown);
		fprintf(stderr, "infilld fsck: no database at %s%s%s\n", shown, e.msg[0] ? ": " : "",
			e.msg);
		return 1;
	}
	for (;;) {
		struct artifact_rec *v;
		int n;

		if (db_artifact_list(db, after, 256, &v, &n, &e)) {
			fprintf(stderr, "infilld fsck: %s\n", e.msg);
			db_close(db);
			return 1;
		}
		for (int i = 0; i < n; i++) {
			const struct artifact_rec *a = &v[i];
			char hex[65];
			int64_t bytes;

			checked++;
			store_artifact_path(data, a->tenant_id, a->name, path, sizeof path);
			if (digest_file(path, &bytes, hex) != 0) {
				missing++;
				printf("missing %s %s: %s\n", a->job_id, path, strerror(errno));
				/* Downloads already answer 410 for a missing file. */
				continue;
			}
			if (bytes == a->bytes && !strcmp(hex, a->sha256))
				continue;
			damaged++;
			if (bytes != a->bytes)
				printf("damaged %s %s: %lld bytes, %lld recorded\n", a->job_id, path,
				       (long long)bytes, (long long)a->bytes);
			else
				printf("damaged %s %s: SHA-256 %s, %s recorded\n", a->job_id, path, hex,
				       a->sha256);
			if (quarantine_on && quarantine(db, data, a, path))
				failed = 1;
		}
		if (n > 0)
			after = v[n - 1].seq;
		free(v);
		if (n < 256)
			break;
	}
	printf("%ld artifact(s) checked: %ld damaged, %ld missing%s\n", checked, damaged, missing,
	       quarantine_on && damaged ? (failed ? " (some not quarantined)" : ", damaged quarantined")
					: "");
	db_close(db);
	return damaged || missing ? 1 : 0;
}
