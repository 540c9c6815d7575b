/* artifacts.h - the index of job outputs as `infilld fsck` walks it: each
 * succeeded job's artifact with the size and SHA-256 recorded when it was
 * published (files: store.h), and quarantine of damaged ones.
 */
#ifndef INFILLD_DB_ARTIFACTS_H
#define INFILLD_DB_ARTIFACTS_H

#include <stdint.h>

#include "db/db.h"

struct err;

struct artifact_rec {
	int64_t seq;              /* the job's row */
	char job_id[DB_ID_MAX];
	int64_t tenant_id;
	char name[128];           /* file name in the tenant's artifacts dir */
	int64_t bytes;
	char sha256[65];          /* lower-case hex */
};

/* Up to limit artifacts of jobs with seq > after_seq, in seq order, into
 * *v (caller frees with free()); *n of them. */
int db_artifact_list(struct db *db, int64_t after_seq, int limit, struct artifact_rec **v,
		     int *n, struct err *e);
/* Mark job seq's artifact damaged: the row forgets the file (downloads
 * answer 410) and the tenant is credited its bytes.  0, ERR_NOTFOUND when
 * the job holds no artifact (any more). */
int db_artifact_quarantine(struct db *db, int64_t seq, struct err *e);

#endif
