/* bench_queue.c URL QUEUED - the job queue straight on libdb, either
 * backend (tests/bench/service.sh runs it on SQLite and on PostgreSQL):
 *   - submissions/s one per transaction (500) and in group-commit batches
 *     of 100 (the HTTP committer's way), filling the queue to QUEUED jobs;
 *   - claim latency (median, p99) of queue_claim() with QUEUED jobs
 *     waiting, 2,000 claims each followed by queue_succeed();
 *   - claims/s of 4 claimers at once, each on its own connection (the
 *     workers of a cluster), 2,000 claim + succeed pairs in all.
 * The filled queue is ANALYZEd before the claims (statistics as after
 * autovacuum; a bulk load is the bench's shortcut, not the service's
 * way).  The database must be empty (SQLite: the file is removed first).
 */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "db/db.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "db/tenants.h"
#include "engine/core/err.h"

#define TENANTS 10
#define CLAIMS 2000
#define CLAIMERS 4

static const char *url;
static char mesh_ids[TENANTS][DB_ID_MAX];
static int64_t tenant_ids[TENANTS];

static double now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static int cmp(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;

	return x < y ? -1 : x > y;
}

static void die(const char *what, const struct err *e)
{
	fprintf(stderr, "bench_queue: %s: %s\n", what, e->msg);
	exit(1);
}

static void job_of(long i, struct job_new *jn)
{
	memset(jn, 0, sizeof *jn);
	jn->tenant_id = tenant_ids[i % TENANTS];
	jn->mesh_id = mesh_ids[i % TENANTS];
	jn->engine = "solid";
	jn->format = "sl1";
	jn->printer = "sl1";
	jn->params = "{}";
	jn->max_attempts = 3;
}

static void claim_and_finish(struct db *db, const char *worker, struct err *e)
{
	struct job_artifact a = {"x.sl1", 1, "00", NULL};
	struct job_row j;
	int got;

	if (queue_claim(db, worker, 60000, &j, &got, e) || !got)
		die(got ? "claim" : "claim found nothing", e);
	if (queue_succeed(db, j.seq, j.attempt, &a, "{}", e) != 1)
		die("succeed", e);
	queue_job_row_fini(&j);
}

static void *claimer(void *arg)
{
	int k = (int)(long)arg;
	char name[16];
	struct db *db;
	struct err e;

	snprintf(name, sizeof name, "bench%d", k);
	if (db_open(url, &db, &e))
		die("open", &e);
	for (int i = 0; i < CLAIMS / CLAIMERS; i++)
		claim_and_finish(db, name, &e);
	db_close(db);
	return NULL;
}

int main(int argc, char **argv)
{
	static double lat[CLAIMS];
	static struct job_new batch[100];
	static struct job_submit res[100];
	long queued = argc > 2 ? atol(argv[2]) : 10000;
	struct tenant_limits l;
	struct job_row j;
	pthread_t th[CLAIMERS];
	struct err e;
	struct db *db;
	double t0, single_s, batch_s, par_s;
	long n = 0;

	url = argc > 1 ? argv[1] : "sqlite:/tmp/bench_queue.db";
	if (!strncmp(url, "sqlite:", 7))
		unlink(url + 7);
	if (db_open(url, &db, &e))
		die("open", &e);
	db_tenant_limits_default(&l);
	l.max_jobs = 1000000;
	l.quota_bytes = 0;
	for (int i = 0; i < TENANTS; i++) {
		struct mesh_rec m;
		struct tenant t;
		char name[16], key[API_KEY_MAX];
		snprintf(name, sizeof name, "t%d", i);
		if (db_tenant_add(db, name, &l, &t, key, &e))
			die("tenant", &e);
		tenant_ids[i] = t.id;
		memset(&m, 0, sizeof m);
		if (db_make_id("m_", m.id, &e))
			die("id", &e);
		m.tenant_id = t.id;
		snprintf(m.name, sizeof m.name, "bench.stl");
		snprintf(m.format, sizeof m.format, "stl");
		m.size_bytes = 1;
		snprintf(m.sha256, sizeof m.sha256, "%064d", 0);
		m.analysis = (char *)"{}";
		m.created_ms = db_now_ms();
		if (db_mesh_add(db, &m, &e))
			die("mesh", &e);
		memcpy(mesh_ids[i], m.id, DB_ID_MAX);
	}
	t0 = now_s();
	for (; n < 500; n++) {
		struct job_new jn;
		int replayed;
		job_of(n, &jn);
		if (queue_submit(db, &jn, &j, &replayed, &e))
			die("submit", &e);
		queue_job_row_fini(&j);
	}
	single_s = now_s() - t0;
	t0 = now_s();
	while (n < queued) {
		int k = 0;
		for (; k < 100 && n < queued; k++, n++)
			job_of(n, &batch[k]);
		if (queue_submit_batch(db, batch, k, res, &e))
			die("submit batch", &e);
		for (int i = 0; i < k; i++)
			if (res[i].rc)
				die("submit in batch", &res[i].err);
	}
	batch_s = now_s() - t0;
	/* As after any bulk load (migrate-db does the same). */
	if (db_analyze(db, &e))
		die("analyze", &e);
	for (int i = 0; i < CLAIMS; i++) {
		t0 = now_s();
		claim_and_finish(db, "bench", &e);
		lat[i] = now_s() - t0;
	}
	qsort(lat, CLAIMS, sizeof lat[0], cmp);
	t0 = now_s();
	for (long k = 0; k < CLAIMERS; k++)
		pthread_create(&th[k], NULL, claimer, (void *)k);
	for (int k = 0; k < CLAIMERS; k++)
		pthread_join(th[k], NULL);
	par_s = now_s() - t0;
	printf("queue on %s, %ld queued (%d tenants):\n"
	       "  submissions/s: %.0f one per transaction, %.0f in batches of 100\n"
	       "  claim + succeed latency (1 claimer): median %.3f ms, p99 %.3f ms\n"
	       "  claims/s with %d claimers on their own connections: %.0f\n",
	       db_backend(db), queued, TENANTS, 500 / single_s,
	       (double)(queued - 500) / (batch_s > 0 ? batch_s : 1e-9), lat[CLAIMS / 2] * 1e3,
	       lat[CLAIMS * 99 / 100] * 1e3, CLAIMERS, CLAIMS / par_s);
	db_close(db);
	if (!strncmp(url, "sqlite:", 7))
		unlink(url + 7);
	return 0;
}
