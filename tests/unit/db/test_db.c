/* test_db.c - db/: migrations, tenants and keys, meshes, the job queue
 * (fair claims, fencing, rescue, backoff, idempotency, cancel, paging,
 * events) and the claim query's plan.
 *
 * On SQLite (a file per test) by default; with INFILLD_TEST_DB_URL set
 * (postgresql://..., tests/service/test_db_pg.py) the backend-independent
 * cases run on that database instead, its schema emptied before each;
 * the SQLite-only cases (the claim's query plan) are then skipped. */
#include "harness.h"

#include <libpq-fe.h>
#include <sqlite3.h>
#include <stdint.h>
#include <unistd.h>

#include "db/db.h"
#include "db/meshes.h"
#include "db/queue.h"
#include "db/store.h"
#include "db/tenants.h"
#include "engine/core/err.h"

static char dir[256];
static char path[1024]; /* what db_open() gets: the SQLite file or pg_url */
static const char *pg_url; /* INFILLD_TEST_DB_URL, NULL = SQLite */

/* Run sql on the test database behind the API's back. */
static void raw_sql(const char *sql)
{
	if (pg_url) {
		PGconn *c = PQconnectdb(pg_url);
		PGresult *r;

		PQclear(PQexec(c, "SET client_min_messages = warning"));
		r = PQexec(c, sql);
		if (PQresultStatus(r) != PGRES_COMMAND_OK && PQresultStatus(r) != PGRES_TUPLES_OK)
			fprintf(stderr, "raw_sql %s: %s", sql, PQerrorMessage(c));
		PQclear(r);
		PQfinish(c);
	} else {
		sqlite3 *sq;
		sqlite3_open(path, &sq);
		sqlite3_exec(sq, sql, NULL, NULL, NULL);
		sqlite3_close(sq);
	}
}

static struct db *fresh(void)
{
	struct db *db = NULL;
	struct err e;

	if (pg_url) {
		snprintf(path, sizeof path, "%s", pg_url);
		raw_sql("DROP SCHEMA public CASCADE; CREATE SCHEMA public");
	} else {
		snprintf(path, sizeof path, "%s/t%d.db", dir, harness_tests);
		unlink(path);
	}
	err_clear(&e);
	if (db_open(path, &db, &e)) {
		fprintf(stderr, "db_open: %s\n", e.msg);
		return NULL;
	}
	return db;
}

static int64_t add_tenant(struct db *db, const char *name, int max_jobs, char *key)
{
	struct tenant_limits l;
	struct tenant t;
	struct err e;
	char k[API_KEY_MAX];

	db_tenant_limits_default(&l);
	l.max_jobs = max_jobs;
	if (db_tenant_add(db, name, &l, &t, key ? key : k, &e)) {
		fprintf(stderr, "tenant add: %s\n", e.msg);
		return -1;
	}
	return t.id;
}

static void add_mesh(struct db *db, int64_t tenant, char *id)
{
	struct mesh_rec m = {0};
	struct err e;

	db_make_id("m_", m.id, &e);
	m.tenant_id = tenant;
	snprintf(m.name, sizeof m.name, "part.stl");
	snprintf(m.format, sizeof m.format, "stl");
	m.size_bytes = 1000;
	snprintf(m.sha256, sizeof m.sha256, "%064d", 0);
	m.created_ms = db_now_ms();
	if (db_mesh_add(db, &m, &e))
		fprintf(stderr, "mesh add: %s\n", e.msg);
	strcpy(id, m.id);
}

static int submit(struct db *db, int64_t tenant, const char *mesh, const char *idem,
		  const char *hash, struct job_row *out, int *replayed)
{
	struct job_new jn = {tenant, mesh, "solid", "sl1", "sl1", "{}", idem, hash, NULL, 3};
	struct err e;
	int rc = queue_submit(db, &jn, out, replayed, &e);

	if (rc && rc != ERR_PARAM && rc != ERR_NOTFOUND)
		fprintf(stderr, "submit: %s\n", e.msg);
	return rc;
}

static void test_migrate(void)
{
	struct db *db = fresh();
	struct err e;

	REQUIRE(db);
	CHECK_EQ_INT(db_schema_version(db), db_schema_latest(db));
	db_close(db);
	/* Re-opening is a no-op migration. */
	REQUIRE_OK(db_open(path, &db, &e), &e);
	CHECK_EQ_INT(db_schema_version(db), db_schema_latest(db));
	CHECK_EQ_INT(db_check_writable(db, &e), 0);
	db_close(db);
}

static void test_ids(void)
{
	char a[DB_ID_MAX], b[DB_ID_MAX];
	struct err e;

	REQUIRE_OK(db_make_id("j_", a, &e), &e);
	REQUIRE_OK(db_make_id("j_", b, &e), &e);
	CHECK(strcmp(a, b) != 0);
	CHECK(db_id_valid("j_", a));
	CHECK(!db_id_valid("m_", a));
	CHECK(!db_id_valid("j_", "j_../../../etc/passwd"));
	CHECK(!db_id_valid("j_", "j_aaaaaaaaaaaaaaaaaaa%"));
	CHECK(!db_id_valid("j_", ""));
}

static void test_tenants(void)
{
	struct db *db = fresh();
	struct tenant t, *v;
	struct tenant_limits l;
	char key[API_KEY_MAX], key2[API_KEY_MAX], admin[API_KEY_MAX];
	struct err e;
	int64_t id;
	int n;

	REQUIRE(db);
	db_tenant_limits_default(&l);
	REQUIRE_OK(db_tenant_add(db, "acme", &l, &t, key, &e), &e);
	CHECK_STR(t.name, "acme");
	CHECK(!strncmp(key, "ifk_", 4));
	CHECK_EQ_INT(db_tenant_add(db, "acme", &l, &t, key2, &e), ERR_PARAM);
	CHECK_STR(e.field, "name");
	CHECK_EQ_INT(db_tenant_add(db, "../x", &l, &t, key2, &e), ERR_PARAM);
	CHECK_EQ_INT(db_tenant_auth(db, key, &t, &e), 0);
	CHECK_STR(t.name, "acme");
	/* A key with the right id but a wrong secret fails. */
	strcpy(key2, key);
	key2[strlen(key2) - 1] = key2[strlen(key2) - 1] == 'a' ? 'b' : 'a';
	CHECK_EQ_INT(db_tenant_auth(db, key2, &t, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(db_tenant_auth(db, "", &t, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(db_tenant_auth(db, "Bearer", &t, &e), ERR_NOTFOUND);
	/* Rotation: the old key stops working. */
	REQUIRE_OK(db_tenant_rotate(db, "acme", key2, &e), &e);
	CHECK_EQ_INT(db_tenant_auth(db, key, &t, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(db_tenant_auth(db, key2, &t, &e), 0);
	CHECK_EQ_INT(db_tenant_rotate(db, "nobody", key, &e), ERR_NOTFOUND);
	/* Admin keys are separate: a tenant key is no admin key. */
	REQUIRE_OK(db_admin_key_rotate(db, admin, &e), &e);
	CHECK_EQ_INT(db_admin_auth(db, admin, &e), 0);
	CHECK_EQ_INT(db_admin_auth(db, key2, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(db_tenant_auth(db, admin, &t, &e), ERR_NOTFOUND);
	REQUIRE_OK(db_tenant_add(db, "beta", &l, &t, key, &e), &e);
	REQUIRE_OK(db_tenant_list(db, &v, &n, &e), &e);
	CHECK_EQ_INT(n, 2);
	CHECK_STR(v[0].name, "acme");
	free(v);
	REQUIRE_OK(db_tenant_remove(db, "acme", &id, &e), &e);
	CHECK_EQ_INT(db_tenant_auth(db, key2, &t, &e), ERR_NOTFOUND);
	CHECK_EQ_INT(db_tenant_remove(db, "acme", &id, &e), ERR_NOTFOUND);
	db_close(db);
}

static void test_meshes(void)
{
	struct db *db = fresh();
	struct mesh_rec m, *v;
	struct tenant t;
	struct job_row j;
	char mid[DB_ID_MAX];
	struct err e;
	int64_t a, b;
	int n, more, rp;

	REQUIRE(db);
	a = add_tenant(db, "a", 2, NULL);
	b = add_tenant(db, "b", 2, NULL);
	add_mesh(db, a, mid);
	REQUIRE_OK(db_tenant_get_id(db, a, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 1000);
	REQUIRE_OK(db_mesh_get(db, a, mid, &m, &e), &e);
	CHECK_STR(m.format, "stl");
	db_mesh_rec_fini(&m);
	CHECK_EQ_INT(db_mesh_get(db, b, mid, &m, &e), ERR_NOTFOUND);
	for (int i = 0; i < 4; i++)
		add_mesh(db, a, mid + 0 * i);
	REQUIRE_OK(db_mesh_list(db, a, 0, "", 3, &v, &n, &more, &e), &e);
	CHECK_EQ_INT(n, 3);
	CHECK_EQ_INT(more, 1);
	{
		int64_t ms = v[2].created_ms;
		char last[DB_ID_MAX];
		strcpy(last, v[2].id);
		db_mesh_recs_free(v, n);
		REQUIRE_OK(db_mesh_list(db, a, ms, last, 3, &v, &n, &more, &e), &e);
		CHECK_EQ_INT(n, 2);
		CHECK_EQ_INT(more, 0);
		db_mesh_recs_free(v, n);
	}
	/* A mesh used by a queued job cannot be deleted; once done it can. */
	REQUIRE_OK(submit(db, a, mid, NULL, NULL, &j, &rp), &e);
	CHECK_EQ_INT(db_mesh_delete(db, a, mid, &m, &e), ERR_LIMIT);
	CHECK_EQ_INT(db_mesh_delete(db, b, mid, &m, &e), ERR_NOTFOUND);
	queue_job_row_fini(&j);
	REQUIRE_OK(queue_cancel(db, a, j.id, &j, &e), &e);
	queue_job_row_fini(&j);
	REQUIRE_OK(db_mesh_delete(db, a, mid, &m, &e), &e);
	db_mesh_rec_fini(&m);
	REQUIRE_OK(db_tenant_get_id(db, a, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 4000);
	db_close(db);
}

/* The quota is checked where the mesh is recorded: a mesh that would pass
 * it is neither recorded nor charged; one that fills it exactly fits. */
static void test_mesh_quota(void)
{
	struct db *db = fresh();
	struct tenant_limits l;
	struct tenant t;
	struct mesh_rec m = {0}, *v;
	char k[API_KEY_MAX];
	struct err e;
	int n, more;

	REQUIRE(db);
	db_tenant_limits_default(&l);
	l.quota_bytes = 2500;
	REQUIRE_OK(db_tenant_add(db, "q", &l, &t, k, &e), &e);
	m.tenant_id = t.id;
	snprintf(m.name, sizeof m.name, "part.stl");
	snprintf(m.format, sizeof m.format, "stl");
	snprintf(m.sha256, sizeof m.sha256, "%064d", 0);
	m.size_bytes = 1000;
	for (int i = 0; i < 3; i++) {
		db_make_id("m_", m.id, &e);
		m.created_ms = db_now_ms();
		CHECK_EQ_INT(db_mesh_add(db, &m, &e), i < 2 ? 0 : ERR_LIMIT);
	}
	CHECK_CONTAINS(e.msg, "(2000 in use)");
	REQUIRE_OK(db_tenant_get_id(db, t.id, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 2000);
	REQUIRE_OK(db_mesh_list(db, t.id, 0, "", 10, &v, &n, &more, &e), &e);
	CHECK_EQ_INT(n, 2);
	db_mesh_recs_free(v, n);
	CHECK_EQ_INT(db_mesh_get(db, t.id, m.id, &m, &e), ERR_NOTFOUND);
	m.size_bytes = 500; /* exactly the rest */
	db_make_id("m_", m.id, &e);
	REQUIRE_OK(db_mesh_add(db, &m, &e), &e);
	REQUIRE_OK(db_tenant_get_id(db, t.id, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 2500);
	/* quota 0: no limit */
	l.quota_bytes = 0;
	REQUIRE_OK(db_tenant_add(db, "u", &l, &t, k, &e), &e);
	m.tenant_id = t.id;
	m.size_bytes = 1ll << 40;
	db_make_id("m_", m.id, &e);
	REQUIRE_OK(db_mesh_add(db, &m, &e), &e);
	db_close(db);
}

static void test_submit_idempotency(void)
{
	struct db *db = fresh();
	struct job_row j1, j2;
	char mid[DB_ID_MAX];
	struct err e;
	int64_t a;
	int rp;

	REQUIRE(db);
	a = add_tenant(db, "a", 2, NULL);
	add_mesh(db, a, mid);
	REQUIRE_OK(submit(db, a, mid, "k1", "h1", &j1, &rp), &e);
	CHECK_EQ_INT(rp, 0);
	CHECK_EQ_INT(j1.state, JOB_QUEUED);
	CHECK(db_id_valid("j_", j1.id));
	REQUIRE_OK(submit(db, a, mid, "k1", "h1", &j2, &rp), &e);
	CHECK_EQ_INT(rp, 1);
	CHECK_STR(j2.id, j1.id);
	queue_job_row_fini(&j2);
	CHECK_EQ_INT(submit(db, a, mid, "k1", "h2", &j2, &rp), ERR_PARAM);
	/* Unknown mesh. */
	CHECK_EQ_INT(submit(db, a, "m_aaaaaaaaaaaaaaaaaaaa", NULL, NULL, &j2, &rp), ERR_NOTFOUND);
	queue_job_row_fini(&j1);
	db_close(db);
}

/* One tenant with many queued jobs does not starve another's single job,
 * and max_jobs caps a tenant's running jobs. */
static void test_fair_claim(void)
{
	struct db *db = fresh();
	struct job_row j;
	char ma[DB_ID_MAX], mb[DB_ID_MAX], bid[DB_ID_MAX];
	struct err e;
	int64_t a, b;
	int rp, got, pos = -1;

	REQUIRE(db);
	a = add_tenant(db, "a", 3, NULL);
	b = add_tenant(db, "b", 3, NULL);
	add_mesh(db, a, ma);
	add_mesh(db, b, mb);
	for (int i = 0; i < 200; i++) {
		REQUIRE_OK(submit(db, a, ma, NULL, NULL, &j, &rp), &e);
		queue_job_row_fini(&j);
	}
	REQUIRE_OK(submit(db, b, mb, NULL, NULL, &j, &rp), &e);
	strcpy(bid, j.id);
	queue_job_row_fini(&j);
	for (int i = 0; i < 4; i++) {
		REQUIRE_OK(queue_claim(db, "w1", 30000, &j, &got, &e), &e);
		if (!got)
			break;
		if (!strcmp(j.id, bid))
			pos = i;
		CHECK_EQ_INT(j.state, JOB_RUNNING);
		CHECK_EQ_INT(j.attempt, 1);
		queue_job_row_fini(&j);
	}
	CHECK(pos >= 0 && pos <= 1);
	/* a has 3 running (cap), b has none queued: nothing runnable. */
	REQUIRE_OK(queue_claim(db, "w1", 30000, &j, &got, &e), &e);
	CHECK_EQ_INT(got, 0);
	db_close(db);
}

static void test_fencing_and_rescue(void)
{
	struct db *db = fresh();
	struct job_row j, k;
	struct job_progress p = {"layers", 0.5, 10, 20};
	struct job_failure lost = {"io", "disk hiccup", "", 1};
	struct job_artifact art = {"x.sl1", 42, "ab", NULL};
	char mid[DB_ID_MAX];
	struct err e;
	int64_t a;
	int rp, got, n;

	REQUIRE(db);
	a = add_tenant(db, "a", 2, NULL);
	add_mesh(db, a, mid);
	REQUIRE_OK(submit(db, a, mid, NULL, NULL, &j, &rp), &e);
	queue_job_row_fini(&j);
	REQUIRE_OK(queue_claim(db, "w1", 30000, &j, &got, &e), &e);
	REQUIRE(got);
	CHECK_EQ_INT(queue_progress(db, j.seq, 1, &p, 30000, &e), 1);
	p.fraction = 0.3; /* never goes back */
	CHECK_EQ_INT(queue_progress(db, j.seq, 1, &p, 30000, &e), 1);
	REQUIRE_OK(queue_get_seq(db, j.seq, &k, &e), &e);
	CHECK_NEAR(k.progress, 0.5, 1e-12);
	queue_job_row_fini(&k);
	/* Worker w1 dies: its job is re-queued with backoff (attempt 2 later). */
	REQUIRE_OK(queue_rescue(db, "w1", &n, &e), &e);
	CHECK_EQ_INT(n, 1);
	REQUIRE_OK(queue_get_seq(db, j.seq, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_QUEUED);
	CHECK_STR(k.error_type, "lost");
	CHECK(k.run_after_ms > db_now_ms() + 500);
	queue_job_row_fini(&k);
	/* The zombie's writes are fenced out. */
	CHECK_EQ_INT(queue_heartbeat(db, j.seq, 1, 30000, &e), 0);
	CHECK_EQ_INT(queue_progress(db, j.seq, 1, &p, 30000, &e), 0);
	CHECK_EQ_INT(queue_succeed(db, j.seq, 1, &art, "{}", &e), 0);
	/* Backoff: not claimable yet. */
	REQUIRE_OK(queue_claim(db, "w2", 30000, &k, &got, &e), &e);
	CHECK_EQ_INT(got, 0);
	raw_sql("UPDATE jobs SET run_after = 0");
	REQUIRE_OK(queue_claim(db, "w2", 30000, &k, &got, &e), &e);
	REQUIRE(got);
	CHECK_EQ_INT(k.attempt, 2);
	/* A retryable failure on attempt 2 re-queues; then the lease path. */
	CHECK_EQ_INT(queue_fail(db, k.seq, 2, &lost, &e), 1);
	queue_job_row_fini(&k);
	raw_sql("UPDATE jobs SET run_after = 0");
	REQUIRE_OK(queue_claim(db, "w3", -1, &k, &got, &e), &e); /* lease already expired */
	REQUIRE(got);
	CHECK_EQ_INT(k.attempt, 3);
	queue_job_row_fini(&k);
	REQUIRE_OK(queue_rescue(db, NULL, &n, &e), &e);
	CHECK_EQ_INT(n, 1);
	REQUIRE_OK(queue_get_seq(db, j.seq, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_FAILED); /* 3 of 3 attempts used */
	CHECK_STR(k.error_type, "lost");
	CHECK(k.finished_ms > 0);
	queue_job_row_fini(&k);
	queue_job_row_fini(&j);
	CHECK_EQ_INT(queue_backoff_ms(1), 1000);
	CHECK_EQ_INT(queue_backoff_ms(3), 4000);
	CHECK_EQ_INT(queue_backoff_ms(30), 60000);
	db_close(db);
}

static void test_succeed_cancel_events(void)
{
	struct db *db = fresh();
	struct job_row j, k;
	struct job_event *ev;
	struct job_artifact art = {"j.sl1", 4242, "abcd", "femur.off"};
	struct job_failure bad = {"parse", "facet 3: NaN", "", 0};
	struct tenant t;
	char mid[DB_ID_MAX];
	struct err e;
	int64_t a, counts[JOB_STATE_COUNT];
	struct queue_durations d;
	int rp, got, n;

	REQUIRE(db);
	a = add_tenant(db, "a", 5, NULL);
	add_mesh(db, a, mid);
	for (int i = 0; i < 3; i++) {
		REQUIRE_OK(submit(db, a, mid, NULL, NULL, &j, &rp), &e);
		queue_job_row_fini(&j);
	}
	REQUIRE_OK(queue_claim(db, "w", 30000, &j, &got, &e), &e);
	CHECK_EQ_INT(queue_succeed(db, j.seq, j.attempt, &art, "{\"layers\":3}", &e), 1);
	REQUIRE_OK(queue_get(db, a, j.id, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_SUCCEEDED);
	CHECK_NEAR(k.progress, 1.0, 0);
	CHECK_STR(k.metrics, "{\"layers\":3}");
	CHECK_EQ_INT(k.artifact_bytes, 4242);
	queue_job_row_fini(&k);
	REQUIRE_OK(db_tenant_get_id(db, a, &t, &e), &e);
	CHECK_EQ_INT(t.used_bytes, 1000 + 4242);
	/* Events: queued, running, succeeded. */
	REQUIRE_OK(queue_events(db, j.seq, 0, 100, &ev, &n, &e), &e);
	CHECK_EQ_INT(n, 3);
	if (n == 3) {
		CHECK_CONTAINS(ev[0].data, "\"state\":\"queued\"");
		CHECK_CONTAINS(ev[2].data, "\"state\":\"succeeded\"");
		CHECK_EQ_INT(ev[2].n, 3);
	}
	queue_events_free(ev, n);
	REQUIRE_OK(queue_events(db, j.seq, 2, 100, &ev, &n, &e), &e);
	CHECK_EQ_INT(n, 1); /* Last-Event-ID resume */
	queue_events_free(ev, n);
	/* Cancelling a finished job changes nothing. */
	REQUIRE_OK(queue_cancel(db, a, j.id, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_SUCCEEDED);
	queue_job_row_fini(&k);
	queue_job_row_fini(&j);
	/* A non-retryable failure fails at once. */
	REQUIRE_OK(queue_claim(db, "w", 30000, &j, &got, &e), &e);
	CHECK_EQ_INT(queue_fail(db, j.seq, j.attempt, &bad, &e), 1);
	REQUIRE_OK(queue_get(db, a, j.id, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_FAILED);
	CHECK_STR(k.error, "facet 3: NaN");
	queue_job_row_fini(&k);
	queue_job_row_fini(&j);
	/* Cancel a running job: its worker's writes now fail. */
	REQUIRE_OK(queue_claim(db, "w", 30000, &j, &got, &e), &e);
	REQUIRE_OK(queue_cancel(db, a, j.id, &k, &e), &e);
	CHECK_EQ_INT(k.state, JOB_CANCELLED);
	CHECK_EQ_INT(queue_heartbeat(db, j.seq, j.attempt, 30000, &e), 0);
	queue_job_row_fini(&k);
	queue_job_row_fini(&j);
	REQUIRE_OK(queue_counts(db, counts, &e), &e);
	CHECK_EQ_INT(counts[JOB_SUCCEEDED], 1);
	CHECK_EQ_INT(counts[JOB_FAILED], 1);
	CHECK_EQ_INT(counts[JOB_CANCELLED], 1);
	REQUIRE_OK(queue_durations(db, &d, &e), &e);
	CHECK_EQ_INT(d.count[0], 1);
	CHECK_EQ_INT(d.bucket[0][QUEUE_DURATION_BUCKETS - 1], 1);
	db_close(db);
}

static void test_list_paging(void)
{
	struct db *db = fresh();
	struct job_row j, *v;
	char mid[DB_ID_MAX];
	struct err e;
	int64_t a, cursor = 0;
	int rp, n, more, total = 0, pages = 0;

	REQUIRE(db);
	a = add_tenant(db, "a", 2, NULL);
	add_mesh(db, a, mid);
	for (int i = 0; i < 25; i++) {
		REQUIRE_OK(submit(db, a, mid, NULL, NULL, &j, &rp), &e);
		queue_job_row_fini(&j);
	}
	do {
		REQUIRE_OK(queue_list(db, a, -1, cursor, 10, &v, &n, &more, &e), &e);
		for (int i = 1; i < n; i++)
			CHECK(v[i].seq < v[i - 1].seq);
		total += n;
		pages++;
		if (n)
			cursor = v[n - 1].seq;
		queue_job_rows_free(v, n);
	} while (more);
	CHECK_EQ_INT(total, 25);
	CHECK_EQ_INT(pages, 3);
	REQUIRE_OK(queue_list(db, a, JOB_RUNNING, 0, 10, &v, &n, &more, &e), &e);
	CHECK_EQ_INT(n, 0);
	queue_job_rows_free(v, n);
	REQUIRE_OK(queue_list(db, a + 1, -1, 0, 10, &v, &n, &more, &e), &e);
	CHECK_EQ_INT(n, 0);
	queue_job_rows_free(v, n);
	db_close(db);
}

/* The claim must walk the jobs_queued index, never sort the queue. */
static void test_claim_plan(void)
{
	struct db *db = fresh();
	sqlite3 *sq;
	sqlite3_stmt *st;
	char plan[4096] = "", sqltext[2048];
	size_t len = 0;

	REQUIRE(db);
	db_close(db);
	REQUIRE(sqlite3_open(path, &sq) == SQLITE_OK);
	sqlite3_exec(sq, "ANALYZE", NULL, NULL, NULL);
	snprintf(sqltext, sizeof sqltext, "EXPLAIN QUERY PLAN %s", queue_claim_sql());
	REQUIRE(sqlite3_prepare_v2(sq, sqltext, -1, &st, NULL) == SQLITE_OK);
	while (sqlite3_step(st) == SQLITE_ROW)
		len += (size_t)snprintf(plan + len, sizeof plan - len, "%s\n",
					(const char *)sqlite3_column_text(st, 3));
	sqlite3_finalize(st);
	sqlite3_close(sq);
	CHECK_CONTAINS(plan, "SEARCH q USING INDEX jobs_tenant_state (tenant_id=? AND state=?)");
	CHECK_CONTAINS(plan, "SEARCH r USING COVERING INDEX jobs_tenant_state");
	CHECK_CONTAINS(plan, "SCAN t USING INDEX tenants_served");
	CHECK(!strstr(plan, "TEMP B-TREE"));
	CHECK(!strstr(plan, "SCAN q"));
	CHECK(!strstr(plan, "SCAN r"));
	if (harness_cur_failed)
		fprintf(stderr, "plan:\n%s", plan);
}

/* Output names: ASCII letters, digits, - and _ only, never "thumbnail". */
static void test_output_names(void)
{
	static const char *const cases[][3] = {
		{"femur.off", "j_x", "femur"},
		{"my part (v2).stl", "j_x", "my_part_v2_"},
		{"\xc3\xa9l\xc3\xa9phant.obj", "j_x", "_l_phant"},
		{"Thumbnail.stl", "j_x", "j_x"},
		{"ThumbThumbnailNail.stl", "j_x", "j_x"},
		{"gear_thumbnail-v1.stl", "j_x", "gear_-v1"},
		{".stl", "j_x", "_stl"},
		{"", "", "part"},
		{NULL, "j_abc", "j_abc"},
		{"\xc3\xa9.stl", "j_y", "j_y"},
	};
	char out[STORE_OUTPUT_NAME_MAX], big[300];

	for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
		store_output_name(cases[i][0], cases[i][1], out, sizeof out);
		CHECK_STR(out, cases[i][2]);
	}
	memset(big, 'a', sizeof big - 1);
	big[sizeof big - 1] = '\0';
	store_output_name(big, "j_x", out, sizeof out);
	CHECK_EQ_INT((int)strlen(out), STORE_OUTPUT_NAME_MAX - 1);
}

int main(void)
{
	pg_url = getenv("INFILLD_TEST_DB_URL");
	if (pg_url && !*pg_url)
		pg_url = NULL;
	if (pg_url)
		fprintf(stderr, "test_db: on %s\n", pg_url);
	snprintf(dir, sizeof dir, "/tmp/infilld-test-db-XXXXXX");
	if (!mkdtemp(dir))
		return 2;
	RUN(test_migrate);
	RUN(test_ids);
	RUN(test_tenants);
	RUN(test_meshes);
	RUN(test_mesh_quota);
	RUN(test_submit_idempotency);
	RUN(test_fair_claim);
	RUN(test_fencing_and_rescue);
	RUN(test_succeed_cancel_events);
	RUN(test_list_paging);
	if (!pg_url)
		RUN(test_claim_plan);
	RUN(test_output_names);
	{
		char cmd[300];
		snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
		if (system(cmd) != 0)
			fprintf(stderr, "cleanup failed\n");
	}
	return harness_report();
}
