/* config.h - options of `infilld serve` (and of the worker processes it
 * starts, which receive the same command line).  Defaults and meaning:
 * docs/operations.md.  Configuration travels in this struct; there are
 * no configuration globals.
 */
#ifndef INFILLD_SERVICE_CONFIG_H
#define INFILLD_SERVICE_CONFIG_H

#include <stddef.h>
#include <stdint.h>

#define CONFIG_DEFAULT_DATA "var/infilld"

struct service_config {
	char host[64];
	int port;
	char data_dir[512];      /* --data: this process's own directory (lock, default db) */
	char db_url[1024];       /* --db (or $INFILLD_DB); default sqlite:DATA/infilld.db */
	char store_dir[512];     /* --store (or $INFILLD_STORE): uploads, artifacts; default DATA */
	int store_shared;        /* --store was given: other machines may use it too */
	int workers;             /* serve: job worker processes (0 = API only) */
	int slots;               /* worker: jobs at once (worker processes it starts) */
	int http_threads;
	int max_connections, per_ip_connections, conn_timeout_s;
	int head_timeout_s;      /* deadline for a whole request head */
	int min_body_rate_kbps;  /* kilobits/s a body must average after the grace; 0 = off */
	int body_grace_s;
	int conn_memory_kb;
	int json_max_kb;
	int lease_s;             /* worker lease; heartbeats every lease/3 */
	int max_attempts;
	int drain_s;             /* SIGTERM: how long running jobs may finish */
	int job_timeout_s;       /* wall clock per attempt */
	int job_mem_mb;          /* RLIMIT_AS of the job process */
	int job_cpu_s;           /* RLIMIT_CPU of the job process */
	int output_limit_mb;     /* engine sink limit and RLIMIT_FSIZE */
	int job_threads;         /* threads per job, 0 = cores / workers */
	int retention_days;      /* artifacts; 0 = keep */
	int min_free_mb;         /* /readyz */
	int analyze_timeout_s, analyze_mem_mb;
	int fault_injection;     /* env INFILLD_FAULT_INJECTION=1 (tests only) */
	char cors_origin[256];   /* --cors-origin: the one other origin allowed to call the API */
	char worker_name[32];    /* set for worker processes */
	char self_exe[512];      /* this binary (re-executed for workers) */
};

#define CONFIG_HELP 3 /* config_parse(): --help was printed; exit 0 */

/* Defaults, then argv (argv[0] = command name).  Returns 0, 2 with a
 * message on stderr for a usage error, or CONFIG_HELP.  extra_ok: also accept the
 * internal --worker-name.  After it, db_url and store_dir are set (from
 * data_dir when not given). */
int config_parse(struct service_config *c, int argc, char **argv, int extra_ok);
/* Every option's default (environment included), before parsing. */
void config_defaults(struct service_config *c);
/* For the admin commands: when argv[*i] is --data, --db or --store (with
 * its value, either form), store it in c, advance *i past it and return
 * 1; 0 when it is another argument; -1 (message on stderr) for a bad or
 * missing value.  Call config_resolve() after the last argument. */
int config_take_location(struct service_config *c, const char *cmd, int argc, char **argv,
			 int *i);
/* The defaults that depend on other options: db_url from data_dir when
 * empty, store_dir = data_dir when empty (store_shared = 0).  0, or 2
 * with a message naming cmd on stderr.  config_parse() calls it. */
int config_resolve(struct service_config *c, const char *cmd);
/* Usage text of the serve options. */
const char *config_usage(void);

#endif
