/* meshes.h - the index of uploaded meshes (files live in
 * DATA/tenants/<tenant id>/meshes/<mesh id>.<format>).
 */
#ifndef INFILLD_DB_MESHES_H
#define INFILLD_DB_MESHES_H

#include <stdint.h>

#include "db/db.h"

struct err;

struct mesh_rec {
	char id[DB_ID_MAX];
	int64_t tenant_id;
	char name[128];     /* client's file name or "upload" */
	char format[8];     /* stl, obj, off, ply */
	int64_t size_bytes;
	char sha256[65];
	char *analysis;     /* JSON text, owned */
	int64_t created_ms;
};

void db_mesh_rec_fini(struct mesh_rec *m);
void db_mesh_recs_free(struct mesh_rec *v, int n);

/* Record an uploaded mesh (id made by the caller with db_make_id("m_"))
 * and charge its size to the tenant's usage, in one transaction.
 * ERR_LIMIT (nothing recorded or charged; e says the usage) when the size
 * would take the tenant past its quota: the caller removes the file. */
int db_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e);
/* ERR_NOTFOUND for a missing mesh or another tenant's. */
int db_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		struct err *e);
/* Newest first, created before before_ms/id cursor (0/"" = newest). */
int db_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		 int limit, struct mesh_rec **v, int *n, int *more, struct err *e);
/* Delete the row (the caller removes the file).  ERR_NOTFOUND; ERR_LIMIT
 * when queued or running jobs still use it. */
int db_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		   struct err *e);

#endif
