/* test_db_pg.c - what only the PostgreSQL backend (db/pg/) has to show:
 * many connections at once (threads, each its own connection) never
 * claim a job twice nor pass a tenant's max_jobs, race idempotency keys,
 * quota charges and migrations safely; LISTEN/NOTIFY wakes a waiter; a
 * connection killed by the server reconnects.
 *
 * Needs INFILLD_TEST_DB_URL (tests/service/test_db_pg.py starts a server
 * and runs this); without it the program says so and passes.  With the
 * argument "restart" it runs one phase of test_db_pg.py's restart test:
 * it opens connections, prints "ready", waits for a line on stdin (the
 * server restarts meanwhile) and checks they work again.
 */
#include "harness.h"

#include <libpq-fe.h>
#include <pthread.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

#include "db/db.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "db/tenants.h"
#include "engine/core/err.h"

static const char *url;

static void raw_sql(const char *sql)
{
	PGconn *c = PQconnectdb(url);
	PGresult *r;

	PQclear(PQexec(c, "SET client_min_messages = warning"));
	r = PQexec(c, sql);
	if (PQresultStatus(r) != PGRES_COMMAND_OK && PQresultStatus(r) != PGRES_TUPLES_OK)
		fprintf(stderr, "raw_sql %s: %s", sql, PQerrorMessage(c));
	PQclear(r);
	PQfinish(c);
}

static void empty_schema(void)
{
	raw_sql("DROP SCHEMA public CASCADE; CREATE SCHEMA public");
}

static struct db *open_db(void)
{
	struct db *db = NULL;
	struct err e;

	err_clear(&e);
	if (db_open(url, &db, &e)) {
		fprintf(stderr, "db_open: %s\n", e.msg);
		return NULL;
	}
	return db;
}

static struct db *fresh(void)
{
	empty_schema();
	return open_db();
}

static int64_t add_tenant(struct db *db, const char *name, int max_jobs, int64_t quota)
{
	struct tenant_limits l;
	struct tenant t;
	struct err e;
	char k[API_KEY_MAX];

	db_tenant_limits_default(&l);
	l.max_jobs = max_jobs;
	l.quota_bytes = quota;
	if (db_tenant_add(db, name, &l, &t, k, &e)) {
		fprintf(stderr, "tenant add: %s\n", e.msg);
		return -1;
	}
	return t.id;
}

static int add_mesh(struct db *db, int64_t tenant, int64_t bytes, char *id, struct err *e)
{
	struct mesh_rec m = {0};

	db_make_id("m_", m.id, e);
	m.tenant_id = tenant;
	snprintf(m.name, sizeof m.name, "part.stl");
	snprintf(m.format, sizeof m.format, "stl");
	m.size_bytes = bytes;
	snprintf(m.sha256, sizeof m.sha256, "%064d", 0);
	m.created_ms = db_now_ms();
	if (id)
		strcpy(id, m.id);
	return db_mesh_add(db, &m, e);
}

static int submit(struct db *db, int64_t tenant, const char *mesh, const char *idem,
		  const char *hash, struct job_row *out, int *replayed, struct err *e)
{
	struct job_new jn = {tenant, mesh, "solid", "sl1", "sl1", "{}", idem, hash, NULL, 3};

	return queue_submit(db, &jn, out, replayed, e);
}

/* ---- concurrent claims ---- */

#define CT_TENANTS 3
#define CT_JOBS 30 /* per tenant */
#define CT_THREADS 6

struct claim_run {
	pthread_mutex_t mu;
	int64_t tenant[CT_TENANTS];
	int max_jobs[CT_TENANTS];
	int64_t first_seq;
	int claimed[CT_TENANTS * CT_JOBS + 1]; /* times each job was claimed */
	int inflight[CT_TENANTS], max_inflight[CT_TENANTS];
	int done, errors, over_cap_seen;
};

static int tenant_index(struct claim_run *cr, int64_t id)
{
	for (int i = 0; i < CT_TENANTS; i++)
		if (cr->tenant[i] == id)
			return i;
	return -1;
}

static void *claim_worker(void *arg)
{
	struct claim_run *cr = arg;
	struct db *db = open_db();
	struct job_artifact art = {"x.sl1", 0, "ab", NULL};
	char name[32];
	struct err e;
	int idle = 0;

	if (!db) {
		pthread_mutex_lock(&cr->mu);
		cr->errors++;
		pthread_mutex_unlock(&cr->mu);
		return NULL;
	}
	snprintf(name, sizeof name, "w%p", (void *)&e);
	while (idle < 200) {
		struct job_row j, *v;
		int got, ti, n, more, stop;

		if (queue_claim(db, name, 60000, &j, &got, &e)) {
			fprintf(stderr, "claim: %s\n", e.msg);
			pthread_mutex_lock(&cr->mu);
			cr->errors++;
			pthread_mutex_unlock(&cr->mu);
			break;
		}
		if (!got) {
			pthread_mutex_lock(&cr->mu);
			stop = cr->done == CT_TENANTS * CT_JOBS;
			pthread_mutex_unlock(&cr->mu);
			if (stop)
				break;
			idle++;
			usleep(2000);
			continue;
		}
		idle = 0;
		ti = tenant_index(cr, j.tenant_id);
		pthread_mutex_lock(&cr->mu);
		if (j.seq - cr->first_seq >= 0 && j.seq - cr->first_seq <= CT_TENANTS * CT_JOBS)
			cr->claimed[j.seq - cr->first_seq]++;
		/* This count is at most the database's running count (raised
		 * after the claim committed, lowered before the job finishes). */
		if (ti >= 0 && ++cr->inflight[ti] > cr->max_inflight[ti])
			cr->max_inflight[ti] = cr->inflight[ti];
		pthread_mutex_unlock(&cr->mu);
		/* And what the database says now. */
		if (!queue_list(db, j.tenant_id, JOB_RUNNING, 0, 1000, &v, &n, &more, &e)) {
			if (ti >= 0 && n > cr->max_jobs[ti]) {
				pthread_mutex_lock(&cr->mu);
				cr->over_cap_seen++;
				pthread_mutex_unlock(&cr->mu);
			}
			queue_job_rows_free(v, n);
		}
		usleep(500); /* "work" */
		pthread_mutex_lock(&cr->mu);
		if (ti >= 0)
			cr->inflight[ti]--;
		pthread_mutex_unlock(&cr->mu);
		if (queue_succeed(db, j.seq, j.attempt, &art, "{}", &e) != 1) {
			fprintf(stderr, "succeed: %s\n", e.msg);
			pthread_mutex_lock(&cr->mu);
			cr->errors++;
			pthread_mutex_unlock(&cr->mu);
		}
		pthread_mutex_lock(&cr->mu);
		cr->done++;
		pthread_mutex_unlock(&cr->mu);
		queue_job_row_fini(&j);
	}
	db_close(db);
	return NULL;
}

static void test_concurrent_claims(void)
{
	static struct claim_run cr;
	pthread_t th[CT_THREADS];
	struct db *db = fresh();
	int64_t counts[JOB_STATE_COUNT];
	struct err e;
	int once = 1;

	REQUIRE(db);
	memset(&cr, 0, sizeof cr);
	pthread_mutex_init(&cr.mu, NULL);
	for (int t = 0; t < CT_TENANTS; t++) {
		char name[16], mesh[DB_ID_MAX];
		snprintf(name, sizeof name, "t%d", t);
		cr.max_jobs[t] = t + 1;
		cr.tenant[t] = add_tenant(db, name, cr.max_jobs[t], 0);
		REQUIRE(cr.tenant[t] > 0);
		REQUIRE_OK(add_mesh(db, cr.tenant[t], 10, mesh, &e), &e);
		for (int i = 0; i < CT_JOBS; i++) {
			struct job_row j;
			int rp;
			REQUIRE_OK(submit(db, cr.tenant[t], mesh, NULL, NULL, &j, &rp, &e), &e);
			if (!cr.first_seq)
				cr.first_seq = j.seq;
			queue_job_row_fini(&j);
		}
	}
	for (int i = 0; i < CT_THREADS; i++)
		pthread_create(&th[i], NULL, claim_worker, &cr);
	for (int i = 0; i < CT_THREADS; i++)
		pthread_join(th[i], NULL);
	CHECK_EQ_INT(cr.errors, 0);
	CHECK_EQ_INT(cr.done, CT_TENANTS * CT_JOBS);
	for (int i = 0; i < CT_TENANTS * CT_JOBS; i++)
		if (cr.claimed[i] != 1 && once) {
			CHECK_EQ_INT(cr.claimed[i], 1);
			once = 0;
		}
	CHECK_EQ_INT(cr.over_cap_seen, 0);
	for (int t = 0; t < CT_TENANTS; t++) {
		CHECK_INT(cr.max_inflight[t], <=, cr.max_jobs[t]);
		CHECK_INT(cr.max_inflight[t], >=, 1);
	}
	REQUIRE_OK(queue_counts(db, counts, &e), &e);
	CHECK_EQ_INT(counts[JOB_SUCCEEDED], CT_TENANTS * CT_JOBS);
	CHECK_EQ_INT(counts[JOB_RUNNING], 0);
	fprintf(stderr, "claims: max in flight per tenant %d/%d %d/%d %d/%d\n", cr.max_inflight[0],
		cr.max_jobs[0], cr.max_inflight[1], cr.max_jobs[1], cr.max_inflight[2],
		cr.max_jobs[2]);
	pthread_mutex_destroy(&cr.mu);
	db_close(db);
}

/* ---- races on one key, one quota, one schema ---- */

#define RACE_THREADS 8

struct race {
	pthread_barrier_t go;
	int64_t tenant;
	char mesh[DB_ID_MAX];
	int same_hash;
	int rc[RACE_THREADS], replayed[RACE_THREADS], charged[RACE_THREADS];
	char id[RACE_THREADS][DB_ID_MAX];
	int kind; /* 0 submit, 1 mesh charges, 2 open (migrate) */
};

struct race_arg {
	struct race *r;
	int k;
};

static void *race_thread(void *arg)
{
	struct race_arg *a = arg;
	struct race *r = a->r;
	struct db *db = r->kind == 2 ? NULL : open_db();
	char hash[16];
	struct err e;

	pthread_barrier_wait(&r->go);
	if (r->kind == 2) {
		r->rc[a->k] = db_open(url, &db, &e);
		if (r->rc[a->k])
			fprintf(stderr, "open: %s\n", e.msg);
		else
			r->replayed[a->k] = db_schema_version(db) == db_schema_latest(db);
	} else if (!db) {
		r->rc[a->k] = ERR_IO;
	} else if (r->kind == 0) {
		struct job_row j;
		snprintf(hash, sizeof hash, "h%d", r->same_hash ? 0 : a->k);
		r->rc[a->k] = submit(db, r->tenant, r->mesh, "race-key", hash, &j, &r->replayed[a->k],
				     &e);
		if (!r->rc[a->k]) {
			strcpy(r->id[a->k], j.id);
			queue_job_row_fini(&j);
		}
	} else {
		for (int i = 0; i < 5; i++)
			r->charged[a->k] += add_mesh(db, r->tenant, 1000, NULL, &e) == 0;
	}
	db_close(db);
	return NULL;
}

static void run_race(struct race *r)
{
	pthread_t th[RACE_THREADS];
	struct race_arg a[RACE_THREADS];

	pthread_barrier_init(&r->go, NULL, RACE_THREADS);
	for (int i = 0; i < RACE_THREADS; i++) {
		a[i].r = r;
		a[i].k = i;
		pthread_create(&th[i], NULL, race_thread, &a[i]);
	}
	for (int i = 0; i < RACE_THREADS; i++)
		pthread_join(th[i], NULL);
	pthread_barrier_destroy(&r->go);
}

static void test_idempotency_race(void)
{
	static struct race r;
	struct db *db = fresh();
	struct job_row *v;
	struct err e;
	int fresh_jobs, n, more;

	REQUIRE(db);
	for (int round = 0; round < 2; round++) {
		char name[8];
		memset(&r, 0, sizeof r);
		snprintf(name, sizeof name, "i%d", round);
		r.tenant = add_tenant(db, name, 2, 0);
		REQUIRE_OK(add_mesh(db, r.tenant, 10, r.mesh, &e), &e);
		r.same_hash = round == 0;
		run_race(&r);
		fresh_jobs = 0;
		for (int i = 0; i < RACE_THREADS; i++) {
			if (r.same_hash) {
				CHECK_EQ_INT(r.rc[i], 0);
				CHECK_STR(r.id[i], r.id[0]);
			} else {
				CHECK(r.rc[i] == 0 || r.rc[i] == ERR_PARAM);
			}
			fresh_jobs += r.rc[i] == 0 && !r.replayed[i];
		}
		CHECK_EQ_INT(fresh_jobs, 1); /* one submission made the job */
		REQUIRE_OK(queue_list(db, r.tenant, -1, 0, 100, &v, &n, &more, &e), &e);
		CHECK_EQ_INT(n, 1);
		queue_job_rows_free(v, n);
	}
	db_close(db);
}

static void test_quota_race(void)
{
	static struct race r;
	struct db *db = fresh();
	struct tenant t;
	struct err e;
	int charged = 0;

	REQUIRE(db);
	memset(&r, 0, sizeof r);
	r.kind = 1;
	r.tenant = add_tenant(db, "q", 2, 10000);
	run_race(&r); /* 8 threads x 5 meshes of 1000 bytes against 10000 */
	for (int i = 0; i < RACE_THREADS; i++)
		charged += r.charged[i];
	CHECK_EQ_INT(charged, 10);
	REQUIRE_OK(db_tenant_get_id(db, r.tenant, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 10000);
	db_close(db);
}

static void test_concurrent_migrations(void)
{
	static struct race r;

	empty_schema();
	memset(&r, 0, sizeof r);
	r.kind = 2;
	run_race(&r); /* 8 connections open the empty database at once */
	for (int i = 0; i < RACE_THREADS; i++) {
		CHECK_EQ_INT(r.rc[i], 0);
		CHECK_EQ_INT(r.replayed[i], 1);
	}
}

/* ---- notifications ---- */

static int64_t mono_ms(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Wait up to ms for seq on l: 1 seen, 0 not, -1 when told to re-read all. */
static int wait_for(struct db *l, int64_t seq, int ms)
{
	int64_t end = mono_ms() + ms, seqs[16];
	struct err e;
	int n;

	while (mono_ms() < end) {
		if (db_wait(l, (int)(end - mono_ms()), seqs, 16, &n, &e)) {
			fprintf(stderr, "db_wait: %s\n", e.msg);
			return 0;
		}
		if (n < 0)
			return -1;
		for (int i = 0; i < n; i++)
			if (seqs[i] == seq)
				return 1;
	}
	return 0;
}

static void test_notify(void)
{
	struct db *db = fresh(), *l = open_db();
	struct job_progress p = {"layers", 0.25, 1, 4};
	struct job_row j, k;
	char mesh[DB_ID_MAX];
	int64_t a, seqs[2], t0;
	struct job_new jn[3];
	struct job_submit res[3];
	struct err e;
	int rp, got, n;

	REQUIRE(db && l);
	REQUIRE_OK(db_listen(l, &e), &e);
	a = add_tenant(db, "n", 2, 0);
	REQUIRE_OK(add_mesh(db, a, 10, mesh, &e), &e);
	REQUIRE_OK(submit(db, a, mesh, NULL, NULL, &j, &rp, &e), &e);
	CHECK_EQ_INT(wait_for(l, j.seq, 5000), 1); /* queued */
	REQUIRE_OK(queue_claim(db, "w", 30000, &k, &got, &e), &e);
	REQUIRE(got);
	CHECK_EQ_INT(wait_for(l, j.seq, 5000), 1); /* running */
	CHECK_EQ_INT(queue_progress(db, k.seq, k.attempt, &p, 30000, &e), 1);
	CHECK_EQ_INT(wait_for(l, j.seq, 5000), 1); /* progress */
	queue_job_row_fini(&k);
	queue_job_row_fini(&j);
	/* Nothing happens: a timeout, after about the time asked. */
	t0 = mono_ms();
	REQUIRE_OK(db_wait(l, 300, seqs, 2, &n, &e), &e);
	CHECK_EQ_INT(n, 0);
	CHECK_INT(mono_ms() - t0, >=, 250);
	/* More jobs than seqs has room for: -1, re-read everything. */
	for (int i = 0; i < 3; i++)
		jn[i] = (struct job_new){a, mesh, "solid", "sl1", "sl1", "{}", NULL, NULL, NULL, 3};
	REQUIRE_OK(queue_submit_batch(db, jn, 3, res, &e), &e);
	usleep(100000);
	REQUIRE_OK(db_wait(l, 2000, seqs, 2, &n, &e), &e);
	CHECK_EQ_INT(n, -1);
	db_close(l);
	db_close(db);
}

/* ---- reconnecting ---- */

/* Kill every other connection named infilld (ours, from db/pg). */
static void kill_connections(void)
{
	raw_sql("SELECT pg_terminate_backend(pid) FROM pg_stat_activity"
		" WHERE application_name = 'infilld' AND pid <> pg_backend_pid()");
	usleep(100000);
}

static void test_reconnect(void)
{
	struct db *db = fresh(), *l = open_db();
	struct tenant t;
	struct job_row j;
	char mesh[DB_ID_MAX];
	struct err e;
	int64_t a;
	int rp;

	REQUIRE(db && l);
	REQUIRE_OK(db_listen(l, &e), &e);
	a = add_tenant(db, "r", 2, 0);
	REQUIRE_OK(add_mesh(db, a, 10, mesh, &e), &e);
	kill_connections();
	/* A read, then a write transaction, on a fresh session. */
	REQUIRE_OK(db_tenant_get_id(db, a, &t, &e), &e);
	CHECK_STR(t.name, "r");
	kill_connections();
	REQUIRE_OK(submit(db, a, mesh, NULL, NULL, &j, &rp, &e), &e);
	CHECK_EQ_INT(db_check_writable(db, &e), 0);
	/* The listener reconnects, says it may have missed some, and hears
	 * the next change (LISTEN again). */
	CHECK_EQ_INT(wait_for(l, -7, 3000), -1);
	{
		struct job_row c;
		int got;
		REQUIRE_OK(queue_cancel(db, a, j.id, &c, &e), &e);
		CHECK_EQ_INT(c.state, JOB_CANCELLED);
		queue_job_row_fini(&c);
		(void)got;
	}
	CHECK_EQ_INT(wait_for(l, j.seq, 5000), 1);
	queue_job_row_fini(&j);
	db_close(l);
	db_close(db);
}

/* migrate-db: SQLite -> PostgreSQL keeps every row, the keys work, and
 * new ids come after the copied ones; PostgreSQL -> SQLite back. */
static void test_copy(void)
{
	struct db *sq = NULL, *db = fresh(), *back = NULL;
	struct job_artifact art = {"x.sl1", 77, "ab", "part.stl"};
	struct job_row j, k, *v;
	struct job_event *ev;
	struct tenant t;
	char tmpl[] = "/tmp/infilld-test-copy-XXXXXX", sq_url[128], mesh[DB_ID_MAX];
	char key[API_KEY_MAX], admin[API_KEY_MAX], cmd[200];
	struct tenant_limits l;
	struct err e;
	int64_t rows, a, seq1;
	int rp, got, n, more;

	REQUIRE(db);
	REQUIRE(mkdtemp(tmpl));
	snprintf(sq_url, sizeof sq_url, "sqlite:%s/src.db", tmpl);
	REQUIRE_OK(db_open(sq_url, &sq, &e), &e);
	db_tenant_limits_default(&l);
	REQUIRE_OK(db_tenant_add(sq, "c", &l, &t, key, &e), &e);
	a = t.id;
	REQUIRE_OK(db_admin_key_rotate(sq, admin, &e), &e);
	REQUIRE_OK(add_mesh(sq, a, 1000, mesh, &e), &e);
	REQUIRE_OK(submit(sq, a, mesh, "idem-1", "h", &j, &rp, &e), &e);
	seq1 = j.seq;
	queue_job_row_fini(&j);
	REQUIRE_OK(submit(sq, a, mesh, NULL, NULL, &j, &rp, &e), &e);
	queue_job_row_fini(&j);
	REQUIRE_OK(queue_claim(sq, "w", 30000, &j, &got, &e), &e);
	REQUIRE(got);
	CHECK_EQ_INT(queue_succeed(sq, j.seq, j.attempt, &art, "{\"layers\":2}", &e), 1);
	queue_job_row_fini(&j);
	REQUIRE_OK(db_copy(sq, db, &rows, &e), &e);
	/* tenant, admin key, mesh, 2 jobs, 4 events, 1 bucket, 1 sum */
	CHECK_EQ_INT(rows, 11);
	REQUIRE_OK(db_tenant_auth(db, key, &t, &e), &e);
	CHECK_EQ_INT(t.id, a);
	CHECK_EQ_INT(t.used_bytes, 1077);
	CHECK_EQ_INT(db_admin_auth(db, admin, &e), 0);
	REQUIRE_OK(queue_get_seq(db, seq1, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_SUCCEEDED);
	CHECK_STR(k.mesh_name, "part.stl");
	CHECK_EQ_INT(k.layers_total, 2);
	queue_job_row_fini(&k);
	REQUIRE_OK(queue_events(db, seq1, 0, 10, &ev, &n, &e), &e);
	CHECK_EQ_INT(n, 3);
	queue_events_free(ev, n);
	/* The idempotency key came along; new rows get new ids. */
	REQUIRE_OK(submit(db, a, mesh, "idem-1", "h", &j, &rp, &e), &e);
	CHECK_EQ_INT(rp, 1);
	queue_job_row_fini(&j);
	REQUIRE_OK(submit(db, a, mesh, NULL, NULL, &j, &rp, &e), &e);
	CHECK_INT(j.seq, >, seq1 + 1);
	queue_job_row_fini(&j);
	CHECK_INT(add_tenant(db, "d", 1, 0), >, a);
	/* And back into a new SQLite file. */
	snprintf(sq_url, sizeof sq_url, "sqlite:%s/back.db", tmpl);
	REQUIRE_OK(db_open(sq_url, &back, &e), &e);
	REQUIRE_OK(db_copy(db, back, &rows, &e), &e);
	REQUIRE_OK(db_tenant_auth(back, key, &t, &e), &e);
	REQUIRE_OK(queue_list(back, a, -1, 0, 100, &v, &n, &more, &e), &e);
	CHECK_EQ_INT(n, 3);
	queue_job_rows_free(v, n);
	/* A target that holds data is refused. */
	CHECK_EQ_INT(db_copy(sq, db, &rows, &e), ERR_PARAM);
	db_close(back);
	db_close(sq);
	db_close(db);
	snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpl);
	if (system(cmd) != 0)
		fprintf(stderr, "cleanup failed\n");
}

/* test_db_pg.py's restart test: connections made before the server
 * restarted work after it. */
static int restart_phase(void)
{
	struct db *db = fresh(), *l = open_db();
	struct job_row j;
	char mesh[DB_ID_MAX], line[16];
	struct tenant t;
	struct err e;
	int64_t a;
	int rp, ok = 1, r;

	if (!db || !l || db_listen(l, &e))
		return 1;
	a = add_tenant(db, "restart", 2, 0);
	if (a < 0 || add_mesh(db, a, 10, mesh, &e))
		return 1;
	printf("ready\n");
	fflush(stdout);
	if (!fgets(line, sizeof line, stdin))
		return 1;
	if (db_tenant_get_id(db, a, &t, &e)) {
		fprintf(stderr, "after restart, read: %s\n", e.msg);
		ok = 0;
	}
	if (submit(db, a, mesh, NULL, NULL, &j, &rp, &e)) {
		fprintf(stderr, "after restart, submit: %s\n", e.msg);
		ok = 0;
	} else {
		r = wait_for(l, j.seq, 5000);
		if (r == -1) /* first the "re-read everything" of the reconnect */
			r = wait_for(l, j.seq, 2000);
		if (r != 1) {
			/* the submit's notification came before the listener
			 * was back: a later change must arrive */
			struct job_row c;
			if (!queue_cancel(db, a, j.id, &c, &e)) {
				r = wait_for(l, j.seq, 5000);
				queue_job_row_fini(&c);
			}
		}
		if (r != 1) {
			fprintf(stderr, "after restart, no notification\n");
			ok = 0;
		}
		queue_job_row_fini(&j);
	}
	db_close(l);
	db_close(db);
	fprintf(stderr, "restart phase: %s\n", ok ? "ok" : "FAILED");
	return ok ? 0 : 1;
}

int main(int argc, char **argv)
{
	url = getenv("INFILLD_TEST_DB_URL");
	if (!url || !*url) {
		fprintf(stderr, "test_db_pg: INFILLD_TEST_DB_URL not set: run it through "
				"tests/service/test_db_pg.py, which starts a PostgreSQL\n");
		return 2;
	}
	if (argc > 1 && !strcmp(argv[1], "restart"))
		return restart_phase();
	RUN(test_concurrent_migrations);
	RUN(test_concurrent_claims);
	RUN(test_idempotency_race);
	RUN(test_quota_race);
	RUN(test_notify);
	RUN(test_reconnect);
	RUN(test_copy);
	return harness_report();
}
