/* tenant_cmd.c - `infilld tenant add|list|key-rotate|remove` and
 * `infilld admin-key`: tenant administration on the database of --db
 * (default: the data directory's SQLite file) and, for remove, the store
 * (safe while serve runs: the database serialises the writes).  A new key is
 * printed once, alone on the last line of stdout, for scripts.
 */
#include "db/db.h"
#include "db/store.h"
#include "db/tenants.h"
#include "engine/core/err.h"
#include "service/commands.h"
#include "service/config.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char tenant_usage[] =
	"usage: infilld tenant add NAME [--max-jobs N] [--max-upload-mb N] [--quota-gb N] [LOCATION]\n"
	"       infilld tenant list [LOCATION]\n"
	"       infilld tenant key-rotate NAME [LOCATION]\n"
	"       infilld tenant remove NAME [LOCATION]\n"
	"LOCATION: [--data DIR] [--db URL] [--store DIR], as serve takes them\n";

/* The database of c (creating the directories an SQLite default needs). */
static int open_db(struct service_config *c, const char *cmd, struct db **db)
{
	struct err e;

	err_clear(&e);
	if (config_resolve(c, cmd))
		return 2;
	if ((!strncmp(c->db_url, "sqlite:", 7) && store_init(c->data_dir, &e)) ||
	    db_open(c->db_url, db, &e)) {
		fprintf(stderr, "infilld %s: %s\n", cmd, e.msg[0] ? e.msg : "cannot open the database");
		return 1;
	}
	return 0;
}

static int parse_num(const char *opt, const char *v, long long lo, long long hi, long long *out)
{
	char *end;
	long long x = strtoll(v, &end, 10);

	if (*end || end == v || x < lo || x > hi) {
		fprintf(stderr, "infilld tenant: %s wants an integer in [%lld, %lld], got '%s'\n", opt,
			lo, hi, v);
		return 2;
	}
	*out = x;
	return 0;
}

int cmd_tenant(int argc, char **argv)
{
	const char *sub = argc > 1 ? argv[1] : NULL, *name = NULL;
	struct service_config c;
	struct tenant_limits l;
	struct db *db;
	struct err e;
	char key[API_KEY_MAX];
	int rc = 0;

	config_defaults(&c);
	db_tenant_limits_default(&l);
	if (!sub || !strcmp(sub, "-h") || !strcmp(sub, "--help")) {
		fputs(tenant_usage, sub ? stdout : stderr);
		return sub ? 0 : 2;
	}
	for (int i = 2; i < argc; i++) {
		const char *a = argv[i];
		long long x;
		int took = config_take_location(&c, "tenant", argc, argv, &i);
		if (took < 0)
			return 2;
		if (took)
			continue;
		if (a[0] != '-') {
			if (name) {
				fprintf(stderr, "infilld tenant: unexpected argument '%s'\n%s", a, tenant_usage);
				return 2;
			}
			name = a;
			continue;
		}
		if (i + 1 >= argc) {
			fprintf(stderr, "infilld tenant: %s needs a value\n", a);
			return 2;
		}
		if (!strcmp(a, "--max-jobs")) {
			if ((rc = parse_num(a, argv[++i], 1, 1024, &x)))
				return rc;
			l.max_jobs = (int)x;
		} else if (!strcmp(a, "--max-upload-mb")) {
			if ((rc = parse_num(a, argv[++i], 1, 1 << 20, &x)))
				return rc;
			l.max_upload_bytes = x << 20;
		} else if (!strcmp(a, "--quota-gb")) {
			if ((rc = parse_num(a, argv[++i], 0, 1 << 20, &x)))
				return rc;
			l.quota_bytes = x << 30;
		} else {
			fprintf(stderr, "infilld tenant: unknown option %s\n%s", a, tenant_usage);
			return 2;
		}
	}
	if (strcmp(sub, "list") != 0 && !name) {
		fprintf(stderr, "infilld tenant %s: NAME is required\n%s", sub, tenant_usage);
		return 2;
	}
	if (strcmp(sub, "add") && strcmp(sub, "list") && strcmp(sub, "key-rotate") &&
	    strcmp(sub, "remove")) {
		fprintf(stderr, "infilld tenant: unknown sub-command '%s'\n%s", sub, tenant_usage);
		return 2;
	}
	if ((rc = open_db(&c, "tenant", &db)))
		return rc;
	err_clear(&e);
	if (!strcmp(sub, "add")) {
		struct tenant t;
		if (!(rc = db_tenant_add(db, name, &l, &t, key, &e))) {
			printf("tenant %s added: max_jobs=%d max_upload_mb=%lld quota_gb=%lld\n", t.name,
			       t.max_jobs, (long long)(t.max_upload_bytes >> 20),
			       (long long)(t.quota_bytes >> 30));
			printf("API key (shown once; store it now):\n%s\n", key);
		}
	} else if (!strcmp(sub, "list")) {
		struct tenant *v;
		int n;
		if (!(rc = db_tenant_list(db, &v, &n, &e))) {
			printf("%-24s %8s %14s %12s %14s\n", "NAME", "MAX_JOBS", "MAX_UPLOAD_MB",
			       "QUOTA_GB", "USED_MB");
			for (int i = 0; i < n; i++)
				printf("%-24s %8d %14lld %12lld %14.1f\n", v[i].name, v[i].max_jobs,
				       (long long)(v[i].max_upload_bytes >> 20),
				       (long long)(v[i].quota_bytes >> 30), v[i].used_bytes / 1048576.0);
			free(v);
		}
	} else if (!strcmp(sub, "key-rotate")) {
		if (!(rc = db_tenant_rotate(db, name, key, &e)))
			printf("new API key of %s (the old one no longer works):\n%s\n", name, key);
	} else {
		int64_t id;
		if (!(rc = db_tenant_remove(db, name, &id, &e))) {
			char dir[STORE_PATH_MAX];
			store_tenant_dir(c.store_dir, id, dir, sizeof dir);
			store_remove_tree(dir, &e);
			printf("tenant %s removed with its meshes, jobs and outputs\n", name);
		}
	}
	db_close(db);
	if (rc) {
		fprintf(stderr, "infilld tenant %s: %s\n", sub, e.msg);
		return 1;
	}
	return 0;
}

int cmd_admin_key(int argc, char **argv)
{
	struct service_config c;
	char key[API_KEY_MAX];
	struct db *db;
	struct err e;
	int rc;

	config_defaults(&c);
	for (int i = 1; i < argc; i++) {
		int took = config_take_location(&c, "admin-key", argc, argv, &i);
		if (took <= 0) {
			if (!took)
				fprintf(stderr, "usage: infilld admin-key [--data DIR] [--db URL]\n");
			return 2;
		}
	}
	if ((rc = open_db(&c, "admin-key", &db)))
		return rc;
	err_clear(&e);
	if (db_admin_key_rotate(db, key, &e)) {
		fprintf(stderr, "infilld admin-key: %s\n", e.msg);
		db_close(db);
		return 1;
	}
	db_close(db);
	printf("new admin key (replaces any previous one; shown once):\n%s\n", key);
	return 0;
}
