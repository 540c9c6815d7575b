/* meshes.c - the uploaded-mesh and artifact indexes, backend-independent
 * part (see meshes.h, artifacts.h): record ownership and the calls into
 * the backend's ops.
 */
#include "db/meshes.h"
#include "db/db_ops.h"

#include <stdlib.h>

void db_mesh_rec_fini(struct mesh_rec *m)
{
	if (m) {
		free(m->analysis);
		m->analysis = NULL;
	}
}

void db_mesh_recs_free(struct mesh_rec *v, int n)
{
	for (int i = 0; v && i < n; i++)
		db_mesh_rec_fini(&v[i]);
	free(v);
}

int db_mesh_add(struct db *db, const struct mesh_rec *m, struct err *e)
{
	return db->ops->mesh_add(db, m, e);
}

int db_mesh_get(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		struct err *e)
{
	return db->ops->mesh_get(db, tenant_id, id, out, e);
}

int db_mesh_list(struct db *db, int64_t tenant_id, int64_t before_ms, const char *before_id,
		 int limit, struct mesh_rec **v, int *n, int *more, struct err *e)
{
	return db->ops->mesh_list(db, tenant_id, before_ms, before_id, limit, v, n, more, e);
}

int db_mesh_delete(struct db *db, int64_t tenant_id, const char *id, struct mesh_rec *out,
		   struct err *e)
{
	return db->ops->mesh_delete(db, tenant_id, id, out, e);
}

int db_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		     int *n, struct err *e)
{
	return db->ops->artifact_list(db, after_seq, limit, v, n, e);
}

int db_artifact_quarantine(struct db *db, int64_t seq, struct err *e)
{
	return db->ops->artifact_quarantine(db, seq, e);
}
