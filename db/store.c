/* store.c - data-directory layout and atomic publication (see store.h). */
#define _XOPEN_SOURCE 700
#include "db/store.h"
#include "db/tenants.h"
#include "engine/core/err.h"

#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

static int fmt_ok(int n, size_t len)
{
	return n > 0 && (size_t)n < len ? 0 : ERR_LIMIT;
}

int store_mkdirs(const char *path, struct err *e)
{
	char p[STORE_PATH_MAX];
	size_t n = strlen(path);

	if (n == 0 || n >= sizeof p)
		return ERR_SET(e, ERR_LIMIT, "path too long: %s", path);
	memcpy(p, path, n + 1);
	for (size_t i = 1; i <= n; i++) {
		if (p[i] != '/' && p[i] != '\0')
			continue;
		p[i] = '\0';
		if (mkdir(p, 0750) != 0 && errno != EEXIST)
			return ERR_SET(e, ERR_IO, "mkdir %s: %s", p, strerror(errno));
		p[i] = i == n ? '\0' : '/';
	}
	return 0;
}

int store_init(const char *store_dir, struct err *e)
{
	char p[STORE_PATH_MAX];
	int rc = store_mkdirs(store_dir, e);

	if (rc)
		return rc;
	if (fmt_ok(snprintf(p, sizeof p, "%s/tmp", store_dir), sizeof p) ||
	    (rc = store_mkdirs(p, e)))
		return rc ? rc : ERR_SET(e, ERR_LIMIT, "data directory path too long");
	if (fmt_ok(snprintf(p, sizeof p, "%s/tenants", store_dir), sizeof p))
		return ERR_SET(e, ERR_LIMIT, "data directory path too long");
	return store_mkdirs(p, e);
}

int store_tmp_path(const char *store_dir, const char *name, char *buf, size_t len)
{
	return fmt_ok(snprintf(buf, len, "%s/tmp/%s", store_dir, name), len);
}

int store_tenant_dir(const char *store_dir, int64_t tenant_id, char *buf, size_t len)
{
	return fmt_ok(snprintf(buf, len, "%s/tenants/%lld", store_dir, (long long)tenant_id), len);
}

int store_mesh_path(const char *store_dir, int64_t tenant_id, const char *mesh_id,
		    const char *format, char *buf, size_t len)
{
	return fmt_ok(snprintf(buf, len, "%s/tenants/%lld/meshes/%s.%s", store_dir,
			       (long long)tenant_id, mesh_id, format),
		      len);
}

int store_artifact_dir(const char *store_dir, int64_t tenant_id, char *buf, size_t len)
{
	return fmt_ok(snprintf(buf, len, "%s/tenants/%lld/artifacts", store_dir,
			       (long long)tenant_id),
		      len);
}

int store_artifact_path(const char *store_dir, int64_t tenant_id, const char *name, char *buf,
			size_t len)
{
	return fmt_ok(snprintf(buf, len, "%s/tenants/%lld/artifacts/%s", store_dir,
			       (long long)tenant_id, name),
		      len);
}

static int fsync_path(const char *path, int flags, struct err *e)
{
	int fd = open(path, flags | O_CLOEXEC);
	int rc = 0;

	if (fd < 0)
		return ERR_SET(e, ERR_IO, "open %s: %s", path, strerror(errno));
	if (fsync(fd) != 0)
		rc = ERR_SET(e, ERR_IO, "fsync %s: %s", path, strerror(errno));
	close(fd);
	return rc;
}

int store_publish(const char *tmp_path, const char *final_path, struct err *e)
{
	char dir[STORE_PATH_MAX];
	char *slash;
	int rc;

	if (strlen(final_path) >= sizeof dir)
		return ERR_SET(e, ERR_LIMIT, "path too long: %s", final_path);
	strcpy(dir, final_path);
	slash = strrchr(dir, '/');
	if (!slash)
		return ERR_SET(e, ERR_INTERNAL, "not an absolute or relative path: %s", final_path);
	*slash = '\0';
	if ((rc = store_mkdirs(dir, e)) || (rc = fsync_path(tmp_path, O_RDONLY, e)))
		return rc;
	if (rename(tmp_path, final_path) != 0)
		return ERR_SET(e, ERR_IO, "rename %s -> %s: %s", tmp_path, final_path,
			       strerror(errno));
	return fsync_path(dir, O_RDONLY | O_DIRECTORY, e);
}

static int rm_one(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
	(void)st;
	(void)ftw;
	if (flag == FTW_DP)
		return rmdir(path) == 0 || errno == ENOENT ? 0 : -1;
	return unlink(path) == 0 || errno == ENOENT ? 0 : -1;
}

int store_remove_tree(const char *path, struct err *e)
{
	if (nftw(path, rm_one, 16, FTW_DEPTH | FTW_PHYS) != 0 && errno != ENOENT)
		return ERR_SET(e, ERR_IO, "removing %s: %s", path, strerror(errno));
	return 0;
}

int store_check(const char *store_dir, struct err *e)
{
	char probe[STORE_PATH_MAX], host[64] = "host";
	int fd, rc = 0;

	gethostname(host, sizeof host - 1);
	host[sizeof host - 1] = '\0';
	if (fmt_ok(snprintf(probe, sizeof probe, "%s/tmp/.probe-%s-%d", store_dir, host,
			    (int)getpid()),
		   sizeof probe))
		return ERR_SET(e, ERR_LIMIT, "store path too long");
	fd = open(probe, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
	if (fd < 0)
		return ERR_SET(e, ERR_IO, "store %s is not writable: %s", store_dir, strerror(errno));
	if (write(fd, "ok\n", 3) != 3 || fsync(fd) != 0)
		rc = ERR_SET(e, ERR_IO, "store %s cannot write durably: %s", store_dir,
			     strerror(errno));
	close(fd);
	unlink(probe);
	return rc;
}

int64_t store_free_bytes(const char *store_dir)
{
	struct statvfs sv;

	if (statvfs(store_dir, &sv) != 0)
		return -1;
	return (int64_t)sv.f_bavail * (int64_t)sv.f_frsize;
}

/* Replace every occurrence of what in msg by with (within cap). */
static void replace_all(char *msg, size_t cap, const char *what, const char *with)
{
	size_t wl = strlen(what), nl = strlen(with);
	char *p = msg;

	if (!wl)
		return;
	while ((p = strstr(p, what)) != NULL) {
		size_t tail = strlen(p + wl);
		size_t at = (size_t)(p - msg);
		if (at + nl + tail + 1 > cap)
			tail = cap > at + nl + 1 ? cap - at - nl - 1 : 0;
		if (at + nl + 1 > cap)
			break;
		memmove(p + nl, p + wl, tail);
		p[nl + tail] = '\0';
		memcpy(p, with, nl);
		p += nl;
	}
}

void store_redact(char *msg, size_t cap, const char *store_dir, const char *path,
		  const char *name)
{
	char abs_dir[STORE_PATH_MAX];

	if (path && path[0]) {
		const char *base = strrchr(path, '/');
		replace_all(msg, cap, path, name ? name : "the file");
		if (base && base[1])
			replace_all(msg, cap, base + 1, name ? name : "the file");
	}
	if (store_dir && store_dir[0]) {
		if (realpath(store_dir, abs_dir))
			replace_all(msg, cap, abs_dir, "DATA");
		replace_all(msg, cap, store_dir, "DATA");
	}
}

/* Remove every (case-insensitive) "thumbnail" from s; removal may join
 * two halves into a new one, so repeat until none is left. */
static void drop_thumbnail(char *s)
{
	static const char word[] = "thumbnail";
	const size_t wl = sizeof word - 1;
	int found;

	do {
		found = 0;
		for (char *p = s; *p; p++) {
			if (!strncasecmp(p, word, wl)) {
				memmove(p, p + wl, strlen(p + wl) + 1);
				found = 1;
				break;
			}
		}
	} while (found);
}

static void sanitise_stem(const char *name, char *buf, size_t len)
{
	const char *dot = name ? strrchr(name, '.') : NULL;
	size_t n = 0, stem = name ? (dot && dot != name ? (size_t)(dot - name) : strlen(name)) : 0;

	for (size_t i = 0; i < stem && n + 1 < len && n + 1 < STORE_OUTPUT_NAME_MAX; i++) {
		unsigned char c = (unsigned char)name[i];
		int keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
			   c == '-' || c == '_';
		if (!keep && n > 0 && buf[n - 1] == '_')
			continue; /* one '_' per run of others */
		buf[n++] = keep ? (char)c : '_';
	}
	buf[n] = '\0';
	drop_thumbnail(buf);
	/* Nothing but separators left is no name. */
	if (strspn(buf, "_-") == strlen(buf))
		buf[0] = '\0';
}

void store_output_name(const char *mesh_name, const char *fallback, char *buf, size_t len)
{
	if (!len)
		return;
	sanitise_stem(mesh_name, buf, len);
	if (!buf[0])
		sanitise_stem(fallback, buf, len);
	if (!buf[0])
		snprintf(buf, len, "part");
}

int store_fd_sha256(int fd, int64_t *bytes, char hex[65])
{
	enum { BLOCK = 1 << 16 };
	unsigned char *block = malloc(BLOCK);
	struct sha256_ctx sha;
	uint8_t digest[SHA256_DIGEST_SIZE];
	int64_t total = 0;
	ssize_t n;

	if (!block) {
		errno = ENOMEM;
		return -1;
	}
	sha256_init(&sha);
	for (;;) {
		n = pread(fd, block, BLOCK, (off_t)total);
		if (n < 0 && errno == EINTR)
			continue;
		if (n <= 0)
			break;
		sha256_update(&sha, (size_t)n, block);
		total += n;
	}
	free(block);
	if (n < 0)
		return -1;
	sha256_digest(&sha, sizeof digest, digest);
	db_sha256_hex(digest, hex);
	*bytes = total;
	return 0;
}
