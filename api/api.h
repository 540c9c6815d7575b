/* api.h - the HTTP front end (libmicrohttpd): /v1 resources, health,
 * metrics.  service/serve.c starts it; openapi.yaml is its contract and
 * docs/service.md its design (threads, suspend/resume, limits).
 */
#ifndef INFILLD_API_H
#define INFILLD_API_H

#include <stddef.h>
#include <stdint.h>

struct err;

struct api_config {
	const char *host;          /* listen address (IPv4/IPv6 literal) */
	int port;                  /* 0 = ephemeral */
	const char *db_url;        /* db_open() URL */
	const char *store_dir;     /* uploads and artifacts, db/store.h layout; shared by
				      every machine of a cluster */
	const char *self_exe;      /* this binary, for sandboxed mesh analysis */
	int threads;               /* libmicrohttpd thread pool */
	int max_connections;
	int per_ip_connections;
	int conn_timeout_s;        /* idle connections are closed after this */
	int head_timeout_s;        /* whole request head must arrive within this */
	int64_t min_body_bps;      /* bytes/s a request body must average ... */
	int body_grace_s;          /* ... once it has taken this long; 0 bps = off */
	size_t conn_memory_bytes;  /* per-connection buffer limit */
	size_t json_max_bytes;     /* request bodies other than uploads */
	int max_attempts;          /* per job */
	int analyze_timeout_s;     /* mesh analysis child */
	int analyze_mem_mb;
	int64_t min_free_bytes;    /* /readyz fails below this free disk */
	int fault_injection;       /* accept "fault" in job bodies (tests only) */
	int workers;               /* this process's worker processes, on /metrics */
	const char *cors_origin;   /* NULL, or the origin whose pages may call the API
				      (Access-Control-Allow-Origin; preflights answered) */
};

struct api_server;

/* Bind and start serving.  Caller stops with api_server_stop(). */
int api_server_start(const struct api_config *c, struct api_server **out, struct err *e);
/* The bound port (useful with port 0). */
int api_server_port(const struct api_server *s);
/* Stop accepting new connections; requests in progress continue. */
void api_server_quiesce(struct api_server *s);
/* Stop everything and free (NULL-safe). */
void api_server_stop(struct api_server *s);
/* Live worker processes, set by the supervisor (gauge on /metrics). */
void api_server_set_workers_alive(struct api_server *s, int n);

#endif
