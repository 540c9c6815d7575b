/* config.c - command-line options of serve and its workers (config.h). */
#include "db/db.h"
#include "service/config.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

struct int_opt {
	const char *name;
	size_t offset;
	int min, max;
};

#define OPT(n, field, lo, hi) {n, offsetof(struct service_config, field), lo, hi}
static const struct int_opt int_opts[] = {
	OPT("--workers", workers, 0, 256),
	OPT("--slots", slots, 1, 256),
	OPT("--http-threads", http_threads, 1, 64),
	OPT("--max-connections", max_connections, 16, 100000),
	OPT("--per-ip-connections", per_ip_connections, 1, 100000),
	OPT("--conn-timeout-s", conn_timeout_s, 1, 3600),
	OPT("--head-timeout-s", head_timeout_s, 1, 3600),
	OPT("--min-body-rate-kbps", min_body_rate_kbps, 0, 1 << 20),
	OPT("--body-grace-s", body_grace_s, 1, 3600),
	OPT("--conn-memory-kb", conn_memory_kb, 32, 65536),
	OPT("--json-max-kb", json_max_kb, 1, 65536),
	OPT("--lease-s", lease_s, 1, 3600),
	OPT("--max-attempts", max_attempts, 1, 20),
	OPT("--drain-s", drain_s, 0, 86400),
	OPT("--job-timeout-s", job_timeout_s, 1, 7 * 86400),
	OPT("--job-mem-mb", job_mem_mb, 64, 1 << 24),
	OPT("--job-cpu-s", job_cpu_s, 1, 30 * 86400),
	OPT("--output-limit-mb", output_limit_mb, 1, 1 << 24),
	OPT("--job-threads", job_threads, 0, 256),
	OPT("--retention-days", retention_days, 0, 36500),
	OPT("--min-free-mb", min_free_mb, 0, 1 << 30),
	OPT("--analyze-timeout-s", analyze_timeout_s, 1, 3600),
	OPT("--analyze-mem-mb", analyze_mem_mb, 64, 1 << 24),
};
#undef OPT

const char *config_usage(void)
{
	return "serve [--listen HOST:PORT] [--data DIR] [--db URL] [--store DIR] [--workers N]\n"
	       "              [--http-threads N] [--max-connections N] [--per-ip-connections N]\n"
	       "              [--conn-timeout-s N]"
	       " [--head-timeout-s N] [--min-body-rate-kbps N] [--body-grace-s N]\n"
	       "              [--lease-s N] [--max-attempts N] [--drain-s N] [--job-timeout-s N]\n"
	       "              [--job-mem-mb N] [--job-cpu-s N] [--output-limit-mb N]\n"
	       "              [--job-threads N] [--retention-days N] [--min-free-mb N]\n"
	       "              [--cors-origin ORIGIN]";
}

/* `serve --help`: the usage and what the HTTP limits mean (all options:
 * docs/operations.md). */
static void print_help(void)
{
	printf("usage: infilld %s\n\n"
	       "Where things live (defaults):\n"
	       "  --data DIR               this process's directory ($INFILLD_DATA, var/infilld)\n"
	       "  --db URL                 sqlite:PATH or postgresql://... ($INFILLD_DB,\n"
	       "                           sqlite:DATA/infilld.db)\n"
	       "  --store DIR              uploads and artifacts, shared by a cluster's machines\n"
	       "                           ($INFILLD_STORE, DATA)\n"
	       "  --workers N              worker processes; 0 = API only (cluster workers run\n"
	       "                           `infilld worker --db URL --store DIR --slots N`)\n\n"
	       "HTTP limits (defaults):\n"
	       "  --max-connections N      connections libmicrohttpd serves at once (2048); past it,\n"
	       "                           503 + Retry-After (16 more for GET /livez, /readyz)\n"
	       "  --per-ip-connections N   of them from one address (256); past it, 503\n"
	       "  --conn-timeout-s N       idle connection timeout (30)\n"
	       "  --head-timeout-s N       the whole request head must arrive within N s (of the accept or\n"
	       "                           of the previous response when kept alive), else 408\n"
	       "                           and close (10); heads wait outside the connection limit\n"
	       "  --min-body-rate-kbps N   a request body must average N kilobits/s once it has\n"
	       "                           taken --body-grace-s (8; 0 = off), else it is closed\n"
	       "  --body-grace-s N         (10)\n"
	       "  --cors-origin ORIGIN     let pages of ORIGIN (scheme://host[:port]) call the API\n"
	       "                           from a browser (CORS; off by default)\n"
	       "See docs/operations.md for every option.\n",
	       config_usage());
}

static int parse_listen(struct service_config *c, const char *v)
{
	const char *colon = strrchr(v, ':');
	const char *h = v;
	size_t hl;
	char *end;
	long port;

	if (!colon)
		return -1;
	hl = (size_t)(colon - v);
	if (h[0] == '[' && hl >= 2 && h[hl - 1] == ']') {
		h++;
		hl -= 2;
	}
	if (hl == 0 || hl >= sizeof c->host)
		return -1;
	port = strtol(colon + 1, &end, 10);
	if (*end || end == colon + 1 || port < 0 || port > 65535)
		return -1;
	memcpy(c->host, h, hl);
	c->host[hl] = '\0';
	if (!strcmp(c->host, "localhost"))
		strcpy(c->host, "127.0.0.1");
	c->port = (int)port;
	return 0;
}

/* An origin as browsers send it (RFC 6454): http:// or https://, a
 * host of letters, digits, '-', '.', '[', ']', ':' (IPv6, port), no path. */
static int origin_valid(const char *v)
{
	const char *h = !strncmp(v, "http://", 7) ? v + 7 : !strncmp(v, "https://", 8) ? v + 8 : NULL;

	if (!h || !*h)
		return 0;
	for (; *h; h++)
		if (!((*h >= 'a' && *h <= 'z') || (*h >= 'A' && *h <= 'Z') || (*h >= '0' && *h <= '9') ||
		      strchr("-.[]:", *h)))
			return 0;
	return 1;
}

void config_defaults(struct service_config *c)
{
	long cores = sysconf(_SC_NPROCESSORS_ONLN);
	const char *env;
	ssize_t n;

	memset(c, 0, sizeof *c);
	strcpy(c->host, "127.0.0.1");
	c->port = 8080;
	snprintf(c->data_dir, sizeof c->data_dir, "%s",
		 (env = getenv("INFILLD_DATA")) && *env ? env : CONFIG_DEFAULT_DATA);
	c->workers = cores > 0 ? (int)cores : 2;
	c->slots = c->workers;
	if ((env = getenv("INFILLD_DB")) && *env)
		snprintf(c->db_url, sizeof c->db_url, "%s", env);
	if ((env = getenv("INFILLD_STORE")) && *env)
		snprintf(c->store_dir, sizeof c->store_dir, "%s", env);
	c->http_threads = 4;
	c->max_connections = 2048;
	c->per_ip_connections = 256;
	c->conn_timeout_s = 30;
	c->head_timeout_s = 10;
	c->min_body_rate_kbps = 8;
	c->body_grace_s = 10;
	c->conn_memory_kb = 256;
	c->json_max_kb = 1024;
	c->lease_s = 30;
	c->max_attempts = 3;
	c->drain_s = 30;
	c->job_timeout_s = 3600;
	c->job_mem_mb = 8192;
	c->job_cpu_s = 4 * 3600;
	c->output_limit_mb = 4096;
	c->retention_days = 7;
	c->min_free_mb = 512;
	c->analyze_timeout_s = 60;
	c->analyze_mem_mb = 4096;
	env = getenv("INFILLD_FAULT_INJECTION");
	c->fault_injection = env && !strcmp(env, "1");
	n = readlink("/proc/self/exe", c->self_exe, sizeof c->self_exe - 1);
	c->self_exe[n > 0 ? n : 0] = '\0';
}

int config_resolve(struct service_config *c, const char *cmd)
{
	if (c->db_url[0] && !db_url_valid(c->db_url)) {
		fprintf(stderr, "infilld %s: $INFILLD_DB wants sqlite:PATH or postgresql://...\n", cmd);
		return 2;
	}
	if (!c->db_url[0] && (size_t)snprintf(c->db_url, sizeof c->db_url, "sqlite:%s/infilld.db",
					      c->data_dir) >= sizeof c->db_url) {
		fprintf(stderr, "infilld %s: --data path too long\n", cmd);
		return 2;
	}
	c->store_shared = c->store_dir[0] && strcmp(c->store_dir, c->data_dir) != 0;
	if (!c->store_dir[0])
		snprintf(c->store_dir, sizeof c->store_dir, "%s", c->data_dir);
	return 0;
}

/* --data, --db, --store: where things live (serve, worker and the admin
 * commands take them alike). */
static const struct {
	const char *name;
	size_t off, len;
} location_opts[] = {
#define LOC(n, field) \
	{n, offsetof(struct service_config, field), sizeof(((struct service_config *)0)->field)}
	LOC("--data", data_dir),
	LOC("--db", db_url),
	LOC("--store", store_dir),
#undef LOC
};

/* Location option k (location_opts) := v.  0, or -1 with a message. */
static int set_location(struct service_config *c, const char *cmd, size_t k, const char *v)
{
	if (k == 1 && !db_url_valid(v)) {
		fprintf(stderr, "infilld %s: --db wants sqlite:PATH or postgresql://..., got '%s'\n",
			cmd, v);
		return -1;
	}
	if (!*v || strlen(v) >= location_opts[k].len) {
		fprintf(stderr, "infilld %s: bad %s '%s'\n", cmd, location_opts[k].name, v);
		return -1;
	}
	snprintf((char *)c + location_opts[k].off, location_opts[k].len, "%s", v);
	return 0;
}

/* Index in location_opts of option name, or -1. */
static int location_index(const char *name, size_t len)
{
	for (size_t k = 0; k < sizeof location_opts / sizeof location_opts[0]; k++)
		if (strlen(location_opts[k].name) == len && !strncmp(name, location_opts[k].name, len))
			return (int)k;
	return -1;
}

int config_take_location(struct service_config *c, const char *cmd, int argc, char **argv,
			 int *i)
{
	const char *a = argv[*i], *eq = strchr(a, '=');
	int k = location_index(a, eq ? (size_t)(eq - a) : strlen(a));
	const char *v;

	if (k < 0)
		return 0;
	if (eq) {
		v = eq + 1;
	} else if (*i + 1 < argc) {
		v = argv[++*i];
	} else {
		fprintf(stderr, "infilld %s: %s needs a value\n", cmd, location_opts[k].name);
		return -1;
	}
	return set_location(c, cmd, (size_t)k, v) ? -1 : 1;
}

int config_parse(struct service_config *c, int argc, char **argv, int extra_ok)
{
	config_defaults(c);
	for (int i = 1; i < argc; i++) {
		const char *a = argv[i], *v = NULL;
		const char *eq = strchr(a, '=');
		char name[64];
		int found = 0;

		/* --opt VALUE and --opt=VALUE */
		if (eq && eq - a < (long)sizeof name) {
			memcpy(name, a, (size_t)(eq - a));
			name[eq - a] = '\0';
			v = eq + 1;
		} else {
			snprintf(name, sizeof name, "%s", a);
		}
		if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
			print_help();
			return CONFIG_HELP;
		}
		if (strncmp(name, "--", 2) != 0) {
			fprintf(stderr, "infilld %s: unexpected argument '%s'\n", argv[0], a);
			return 2;
		}
		if (!v) {
			if (i + 1 >= argc) {
				fprintf(stderr, "infilld %s: %s needs a value\n", argv[0], name);
				return 2;
			}
			v = argv[++i];
		}
		if (!strcmp(name, "--listen")) {
			if (parse_listen(c, v)) {
				fprintf(stderr, "infilld %s: --listen wants HOST:PORT, got '%s'\n", argv[0], v);
				return 2;
			}
			continue;
		}
		if (location_index(name, strlen(name)) >= 0) {
			if (set_location(c, argv[0], (size_t)location_index(name, strlen(name)), v))
				return 2;
			continue;
		}
		if (!strcmp(name, "--cors-origin")) {
			if (!origin_valid(v) || strlen(v) >= sizeof c->cors_origin) {
				fprintf(stderr,
					"infilld %s: --cors-origin wants scheme://host[:port] (no path), "
					"got '%s'\n", argv[0], v);
				return 2;
			}
			snprintf(c->cors_origin, sizeof c->cors_origin, "%s", v);
			continue;
		}
		if (extra_ok && !strcmp(name, "--worker-name")) {
			snprintf(c->worker_name, sizeof c->worker_name, "%s", v);
			continue;
		}
		for (size_t k = 0; k < sizeof int_opts / sizeof int_opts[0]; k++) {
			char *end;
			long x;
			if (strcmp(name, int_opts[k].name))
				continue;
			errno = 0;
			x = strtol(v, &end, 10);
			if (errno || *end || end == v || x < int_opts[k].min || x > int_opts[k].max) {
				fprintf(stderr, "infilld %s: %s wants an integer in [%d, %d], got '%s'\n",
					argv[0], name, int_opts[k].min, int_opts[k].max, v);
				return 2;
			}
			*(int *)((char *)c + int_opts[k].offset) = (int)x;
			found = 1;
			break;
		}
		if (!found) {
			fprintf(stderr, "infilld %s: unknown option %s\n", argv[0], name);
			return 2;
		}
	}
	if (config_resolve(c, argv[0]))
		return 2;
	if (c->job_threads == 0) {
		long cores = sysconf(_SC_NPROCESSORS_ONLN);
		int w = c->workers > 0 ? c->workers : 1;
		c->job_threads = cores > w ? (int)(cores / w) : 1;
	}
	return 0;
}
