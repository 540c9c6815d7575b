/* serve.c - `infilld serve`: the HTTP front end (api/), the worker
 * processes (supervisor.c; none with --workers 0, the API servers of a
 * cluster), the rescuer for expired leases, retention, and graceful
 * shutdown on SIGTERM/SIGINT.  One serve per data directory (flock on
 * DATA/serve.lock).  With the SQLite backend the database is this
 * machine's alone, so at start-up every job still marked running is an
 * orphan of a previous run and is re-queued at once; with PostgreSQL other
 * machines' workers may hold running jobs, and only expired leases are.
 */
#include "api/api.h"
#include "api/log.h"
#include "db/db.h"
#include "db/queue.h"
#include "db/store.h"
#include "engine/core/err.h"
#include "engine/engine.h"
#include "service/commands.h"
#include "service/config.h"
#include "service/supervisor.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* A shared store's tmp/ files younger than this may be another
 * machine's uploads or outputs in progress (longer than any attempt). */
#define SERVE_TMP_SHARED_AGE_S (24 * 3600)

/* Remove half-written files a crash left in STORE/tmp: all of them when
 * the store is this serve's alone, else those older than min_age_s
 * (another machine may be writing the younger ones). */
static void clean_tmp(const char *store_dir, int64_t min_age_s)
{
	time_t now = time(NULL);
	char dir[STORE_PATH_MAX], path[STORE_PATH_MAX];
	struct stat st;
	struct dirent *d;
	DIR *dp;

	store_tmp_path(store_dir, "", dir, sizeof dir);
	if (!(dp = opendir(dir)))
		return;
	while ((d = readdir(dp)) != NULL) {
		if (d->d_name[0] == '.')
			continue;
		if (snprintf(path, sizeof path, "%s%s", dir, d->d_name) >= (int)sizeof path)
			continue;
		if (min_age_s > 0 && (stat(path, &st) != 0 || now - st.st_mtime < min_age_s))
			continue;
		unlink(path);
	}
	closedir(dp);
}

static void retention(const struct service_config *c, struct db *db)
{
	struct expired_artifact *v;
	struct err e;
	int n;

	if (c->retention_days <= 0)
		return;
	err_clear(&e);
	if (queue_expire_artifacts(db, db_now_ms() - (int64_t)c->retention_days * 86400000, 500, &v,
				   &n, &e)) {
		log_msg(LOG_ERROR, "serve", "retention: %s", e.msg);
		return;
	}
	for (int i = 0; i < n; i++) {
		char path[STORE_PATH_MAX];
		store_artifact_path(c->store_dir, v[i].tenant_id, v[i].name, path, sizeof path);
		unlink(path);
	}
	if (n)
		log_msg(LOG_INFO, "serve", "retention: %d artifact(s) older than %d days deleted", n,
			c->retention_days);
	free(v);
}

int cmd_serve(int argc, char **argv)
{
	struct service_config c;
	struct api_config ac;
	struct api_server *srv = NULL;
	struct supervisor sup;
	char lock_path[STORE_PATH_MAX], shown_db[256];
	sigset_t set;
	struct db *db = NULL;
	struct err e;
	time_t last_retention = 0;
	int lock_fd, n, rc = config_parse(&c, argc, argv, 0);

	if (rc)
		return rc == CONFIG_HELP ? 0 : rc;
	if (getenv("INFILLD_LOG") && !strcmp(getenv("INFILLD_LOG"), "debug"))
		log_set_level(LOG_DEBUG);
	err_clear(&e);
	if (store_init(c.data_dir, &e) || store_init(c.store_dir, &e)) {
		fprintf(stderr, "infilld serve: %s\n", e.msg);
		return 1;
	}
	snprintf(lock_path, sizeof lock_path, "%s/serve.lock", c.data_dir);
	lock_fd = open(lock_path, O_RDWR | O_CREAT | O_CLOEXEC, 0640);
	if (lock_fd < 0 || flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
		fprintf(stderr, "infilld serve: %s is in use by another serve (%s)\n", c.data_dir,
			lock_fd < 0 ? strerror(errno) : "lock held");
		return 1;
	}
	db_url_redact(c.db_url, shown_db, sizeof shown_db);
	if (db_open(c.db_url, &db, &e)) {
		fprintf(stderr, "infilld serve: %s: %s\n", shown_db, e.msg);
		return 1;
	}
	if (!strcmp(db_backend(db), "sqlite") && queue_rescue(db, "*", &n, &e) == 0 && n)
		log_msg(LOG_WARN, "serve", "%d job(s) were running when the service stopped; re-queued",
			n);
	clean_tmp(c.store_dir, c.store_shared ? SERVE_TMP_SHARED_AGE_S : 0);
	if (c.fault_injection)
		log_msg(LOG_WARN, "serve",
			"INFILLD_FAULT_INJECTION=1: jobs may ask to crash (test use only)");

	/* Signals are taken synchronously by this thread; every thread
	 * started from here inherits the mask. */
	supervisor_block_signals(&set);

	memset(&ac, 0, sizeof ac);
	ac.host = c.host;
	ac.port = c.port;
	ac.db_url = c.db_url;
	ac.store_dir = c.store_dir;
	ac.self_exe = c.self_exe;
	ac.threads = c.http_threads;
	ac.max_connections = c.max_connections;
	ac.per_ip_connections = c.per_ip_connections;
	ac.conn_timeout_s = c.conn_timeout_s;
	ac.head_timeout_s = c.head_timeout_s;
	ac.min_body_bps = (int64_t)c.min_body_rate_kbps * 1000 / 8;
	ac.body_grace_s = c.body_grace_s;
	ac.conn_memory_bytes = (size_t)c.conn_memory_kb << 10;
	ac.json_max_bytes = (size_t)c.json_max_kb << 10;
	ac.max_attempts = c.max_attempts;
	ac.analyze_timeout_s = c.analyze_timeout_s;
	ac.analyze_mem_mb = c.analyze_mem_mb;
	ac.min_free_bytes = (int64_t)c.min_free_mb << 20;
	ac.fault_injection = c.fault_injection;
	ac.workers = c.workers;
	ac.cors_origin = c.cors_origin[0] ? c.cors_origin : NULL;
	if (api_server_start(&ac, &srv, &e)) {
		fprintf(stderr, "infilld serve: %s\n", e.msg);
		db_close(db);
		return 1;
	}
	supervisor_init(&sup, &c, c.workers, argc, argv);
	supervisor_start_due(&sup);
	printf("infilld %s: listening on http://%s%s%s:%d (data %s, db %s, store %s, %d workers)\n",
	       INFILLD_VERSION, strchr(c.host, ':') ? "[" : "", c.host, strchr(c.host, ':') ? "]" : "",
	       api_server_port(srv), c.data_dir, shown_db, c.store_dir, c.workers);
	fflush(stdout);
	log_msg(LOG_INFO, "serve", "listening on port %d", api_server_port(srv));

	for (;;) {
		struct timespec ts = {1, 0};
		int sig = sigtimedwait(&set, NULL, &ts);
		if (sig == SIGTERM || sig == SIGINT)
			break;
		supervisor_reap(&sup, supervisor_requeue, db);
		supervisor_start_due(&sup);
		api_server_set_workers_alive(srv, supervisor_alive(&sup));
		/* Rescuer: leases that ran out (a hung or stopped worker). */
		if (queue_rescue(db, NULL, &n, &e) == 0 && n)
			log_msg(LOG_WARN, "serve", "%d job lease(s) expired; re-queued or failed", n);
		if (time(NULL) - last_retention >= 60) {
			retention(&c, db);
			last_retention = time(NULL);
		}
	}
	log_msg(LOG_INFO, "serve", "stopping: no new connections; draining jobs for up to %d s",
		c.drain_s);
	api_server_quiesce(srv);
	supervisor_stop(&sup, c.drain_s + 10.0);
	api_server_stop(srv);
	db_close(db);
	close(lock_fd);
	log_msg(LOG_INFO, "serve", "stopped");
	return 0;
}
