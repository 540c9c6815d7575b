/* store.h - the store's files and how they are published.  The store is
 * --store (default: the data directory), shared by every machine of a
 * cluster; the SQLite database (db.h) and serve.lock stay in --data.
 *
 *   STORE/tmp/                         uploads and outputs being written
 *   STORE/tenants/<tenant id>/meshes/<mesh id>.<format>
 *   STORE/tenants/<tenant id>/artifacts/<job id>-a<attempt>.<ext>
 *
 * A file becomes visible only whole: written under tmp/, fsync()ed,
 * renamed into place, directory fsync()ed (store_publish).  Artifact names
 * carry the attempt, so a fenced-out worker never replaces a re-run's.
 */
#ifndef INFILLD_DB_STORE_H
#define INFILLD_DB_STORE_H

#include <stddef.h>
#include <stdint.h>

struct err;

#define STORE_PATH_MAX 1024

/* Create a store (or data) directory and its fixed sub-directories (mode 0750). */
int store_init(const char *store_dir, struct err *e);
/* mkdir -p with mode 0750. */
int store_mkdirs(const char *path, struct err *e);

int store_tmp_path(const char *store_dir, const char *name, char *buf, size_t len);
int store_mesh_path(const char *store_dir, int64_t tenant_id, const char *mesh_id,
		    const char *format, char *buf, size_t len);
int store_artifact_dir(const char *store_dir, int64_t tenant_id, char *buf, size_t len);
int store_artifact_path(const char *store_dir, int64_t tenant_id, const char *name, char *buf,
			size_t len);
int store_tenant_dir(const char *store_dir, int64_t tenant_id, char *buf, size_t len);

/* fsync(tmp_path), rename to final_path (creating its directory), fsync
 * the directory.  On failure tmp_path is left for the caller to unlink. */
int store_publish(const char *tmp_path, const char *final_path, struct err *e);
/* rm -r of a tenant's directory (after its rows are gone). */
int store_remove_tree(const char *path, struct err *e);
/* Make msg (NUL-terminated, cap bytes) fit for a client: every mention of
 * path, or of its file name, becomes name (the client's name for the
 * file), and what remains of store_dir becomes "DATA" (path and name may
 * be NULL).  Messages from readers and the store name our files. */
void store_redact(char *msg, size_t cap, const char *store_dir, const char *path,
		  const char *name);
/* The name outputs carry (an SL1's jobDir and layer names, the download's
 * file name) from the mesh's name: its stem without the extension, other
 * characters than ASCII letters, digits, '-' and '_' made '_', never
 * containing "thumbnail" in any case (PrusaSlicer's SL1 importer skips
 * entries whose name does), at most 63 bytes; fallback when nothing is
 * left (then "part").  buf holds at least 64 bytes. */
#define STORE_OUTPUT_NAME_MAX 64
void store_output_name(const char *mesh_name, const char *fallback, char *buf, size_t len);
/* Free bytes available to us on the file system of store_dir, -1 on error. */
/* Readiness of the store: create, write, fsync and remove a probe file
 * in STORE/tmp (a name of this host and process).  0, or ERR_IO naming
 * the store and the reason (a shared store that went away). */
int store_check(const char *store_dir, struct err *e);
int64_t store_free_bytes(const char *store_dir);
/* Size (bytes) and SHA-256 (64 hex digits) of what fd holds, read with
 * pread() from offset 0 (fd's position is untouched; thread-safe).  0, or
 * -1 with errno. */
int store_fd_sha256(int fd, int64_t *bytes, char hex[65]);

#endif
