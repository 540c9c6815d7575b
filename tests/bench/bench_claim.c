/* bench_claim.c - claim latency of the SQLite queue with N jobs queued
 * (tests/bench/service.sh builds and runs it).  Prints median and p99 of
 * queue_claim() + queue_succeed() over 2,000 claims with synchronous=FULL.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sqlite3.h>

#include "db/db.h"
#include "db/queue.h"
#include "db/tenants.h"
#include "engine/core/err.h"

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

int main(int argc, char **argv)
{
	const char *path = argc > 1 ? argv[1] : "/tmp/bench_claim.db";
	long queued = argc > 2 ? atol(argv[2]) : 10000;
	enum { CLAIMS = 2000 };
	static double lat[CLAIMS];
	struct tenant_limits l;
	struct tenant t;
	struct job_row j;
	struct err e;
	struct db *db;
	sqlite3 *sq;
	char key[API_KEY_MAX], sql[512];
	double t0;

	unlink(path);
	if (db_open(path, &db, &e)) {
		fprintf(stderr, "%s\n", e.msg);
		return 1;
	}
	db_tenant_limits_default(&l);
	l.max_jobs = 1000000;
	/* 10 tenants; the queue filled in bulk (one transaction). */
	for (int i = 0; i < 10; i++) {
		char name[16];
		snprintf(name, sizeof name, "t%d", i);
		db_tenant_add(db, name, &l, &t, key, &e);
	}
	sqlite3_open(path, &sq);
	sqlite3_exec(sq, "BEGIN", NULL, NULL, NULL);
	snprintf(sql, sizeof sql,
		 "WITH RECURSIVE n(i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM n WHERE i < %ld)"
		 " INSERT INTO jobs(id, tenant_id, mesh_id, engine, format, printer, params,"
		 " max_attempts, created_at) SELECT 'j_' || printf('%%020d', i), 1 + i %% 10,"
		 " 'm_x', 'solid', 'sl1', 'sl1', '{}', 3, 0 FROM n",
		 queued - 1);
	if (sqlite3_exec(sq, sql, NULL, NULL, NULL) != SQLITE_OK) {
		fprintf(stderr, "fill: %s\n", sqlite3_errmsg(sq));
		return 1;
	}
	sqlite3_exec(sq, "COMMIT; ANALYZE", NULL, NULL, NULL);
	sqlite3_close(sq);
	for (int i = 0; i < CLAIMS; i++) {
		struct job_artifact a = {"x", 1, "00", NULL};
		int got;
		t0 = now_s();
		if (queue_claim(db, "bench", 60000, &j, &got, &e) || !got) {
			fprintf(stderr, "claim failed: %s\n", e.msg);
			return 1;
		}
		lat[i] = now_s() - t0;
		queue_succeed(db, j.seq, j.attempt, &a, "{}", &e);
		queue_job_row_fini(&j);
	}
	qsort(lat, CLAIMS, sizeof lat[0], cmp);
	printf("claim latency with %ld queued jobs (10 tenants, synchronous=FULL): "
	       "median %.3f ms, p99 %.3f ms\n",
	       queued, lat[CLAIMS / 2] * 1e3, lat[CLAIMS * 99 / 100] * 1e3);
	db_close(db);
	unlink(path);
	return 0;
}
