/* conn.c - the PostgreSQL connection (libpq): open, session settings,
 * reconnecting, transactions, the prepared-statement cache, LISTEN/NOTIFY
 * and the ops table of the backend (see db.h, db_ops.h, pg_internal.h).
 *
 * Every write runs between BEGIN and COMMIT (READ COMMITTED, the server's
 * default); what each op does about concurrent writers on other
 * connections is said where it matters (queue_worker.c: the claim).  The
 * URL may carry a password: no message here ever quotes it.
 */
#include "db/pg/pg_internal.h"
#include "engine/core/err.h"

#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* ---- parameters ---- */

void pgdb_p_init(struct pgdb_params *p)
{
	p->n = 0;
}

static int p_slot(struct pgdb_params *p)
{
	/* More than PGDB_MAX_PARAMS is a bug in a static statement of ours. */
	return p->n < PGDB_MAX_PARAMS ? p->n++ : PGDB_MAX_PARAMS - 1;
}

void pgdb_p_text(struct pgdb_params *p, const char *s)
{
	int k = p_slot(p);

	p->v[k] = s;
	p->len[k] = 0;
	p->fmt[k] = 0;
}

void pgdb_p_i64(struct pgdb_params *p, int64_t v)
{
	int k = p_slot(p);

	snprintf(p->num[k], sizeof p->num[k], "%" PRId64, v);
	p->v[k] = p->num[k];
	p->len[k] = 0;
	p->fmt[k] = 0;
}

void pgdb_p_f64(struct pgdb_params *p, double v)
{
	int k = p_slot(p);

	/* %.17g round-trips every double. */
	snprintf(p->num[k], sizeof p->num[k], "%.17g", v);
	p->v[k] = p->num[k];
	p->len[k] = 0;
	p->fmt[k] = 0;
}

void pgdb_p_bin(struct pgdb_params *p, const void *b, size_t len)
{
	int k = p_slot(p);

	p->v[k] = b ? (const char *)b : "";
	p->len[k] = (int)len;
	p->fmt[k] = 1;
}

/* ---- errors ---- */

/* libpq's multi-line message as one line (newlines and tabs to spaces,
 * trailing blanks cut). */
static void one_line(const char *in, char *out, size_t len)
{
	size_t k = 0;

	for (; in && *in && k + 1 < len; in++) {
		char c = *in == '\n' || *in == '\t' || *in == '\r' ? ' ' : *in;
		if (c == ' ' && (k == 0 || out[k - 1] == ' '))
			continue;
		out[k++] = c;
	}
	while (k > 0 && out[k - 1] == ' ')
		k--;
	out[k] = '\0';
}

int pgdb_fail(struct db *db, PGresult *r, struct err *e, const char *what)
{
	struct db_pg *d = (struct db_pg *)db;
	const char *msg = NULL, *state = NULL;
	char line[400];

	if (r) {
		msg = PQresultErrorField(r, PG_DIAG_MESSAGE_PRIMARY);
		state = PQresultErrorField(r, PG_DIAG_SQLSTATE);
		if (!msg || !*msg)
			msg = PQresultErrorMessage(r);
	}
	if ((!msg || !*msg) && d && d->c)
		msg = PQerrorMessage(d->c);
	if (d)
		snprintf(d->sqlstate, sizeof d->sqlstate, "%s", state ? state : "");
	one_line(msg && *msg ? msg : "no connection", line, sizeof line);
	return ERR_SET(e, ERR_IO, "%s: %s", what, line);
}

/* ---- session ---- */

static void notice_discard(void *arg, const char *message)
{
	(void)arg;
	(void)message; /* NOTICEs ("already exists, skipping") are not errors */
}

/* Settings of every session, after connecting and after each reconnect:
 * a lock or a statement that waits this long is a stuck peer (ERR_IO
 * rather than a hung worker), and a transaction left open by a stalled
 * process is ended by the server.  Prepared statements keep one generic
 * plan (force_generic_plan): statistics of a queue change faster than
 * ANALYZE follows, and custom plans made on them chose full-index walks
 * past finished jobs (bench_queue: 51 ms candidate lists at 100k jobs). */
static int session_setup(struct db_pg *d, struct err *e)
{
	static const char sql[] = "SET lock_timeout = '10s';"
				  "SET statement_timeout = " PGDB_STATEMENT_TIMEOUT ";"
				  "SET idle_in_transaction_session_timeout = '60s';"
				  "SET plan_cache_mode = force_generic_plan;"
				  "SET client_min_messages = warning";
	PGresult *r;
	int rc = 0;

	d->ncache = 0; /* a new session has no prepared statements */
	r = PQexec(d->c, sql);
	if (PQresultStatus(r) != PGRES_COMMAND_OK)
		rc = pgdb_fail(&d->base, r, e, "setting up the PostgreSQL session");
	PQclear(r);
	if (!rc && d->listening) {
		r = PQexec(d->c, "LISTEN infilld_job");
		if (PQresultStatus(r) != PGRES_COMMAND_OK)
			rc = pgdb_fail(&d->base, r, e, "LISTEN");
		PQclear(r);
		/* Whatever was notified while the connection was down is lost. */
		d->lost_notify = 1;
	}
	return rc;
}

static int reconnect(struct db_pg *d, struct err *e)
{
	char line[400];

	PQreset(d->c);
	d->ncache = 0;
	d->in_tx = 0;
	if (PQstatus(d->c) != CONNECTION_OK) {
		one_line(PQerrorMessage(d->c), line, sizeof line);
		return ERR_SET(e, ERR_IO, "PostgreSQL connection lost, reconnecting failed: %s", line);
	}
	return session_setup(d, e);
}

int pgdb_ready(struct db *db, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;

	if (PQstatus(d->c) == CONNECTION_OK)
		return 0;
	if (d->in_tx)
		return ERR_SET(e, ERR_IO, "PostgreSQL connection lost inside a transaction");
	return reconnect(d, e);
}

int pgdb_reconnect(struct db *db, struct err *e)
{
	return reconnect((struct db_pg *)db, e);
}

int pgdb_in_tx(struct db *db)
{
	return ((struct db_pg *)db)->in_tx;
}

/* ---- statements ---- */

/* The prepared statement's name for sql, preparing it on first use; NULL
 * when the cache is full (then the caller runs it unprepared) or the
 * prepare failed (*fail = its result). */
static const char *prepared(struct db_pg *d, const char *sql, int nparams, PGresult **fail)
{
	PGresult *r;
	int k;

	*fail = NULL;
	for (int i = 0; i < d->ncache; i++)
		if (d->cache[i].sql == sql)
			return d->cache[i].name;
	if (d->ncache == PGDB_STMT_CACHE)
		return NULL;
	k = d->ncache;
	snprintf(d->cache[k].name, sizeof d->cache[k].name, "s%d", ++d->nprepared);
	r = PQprepare(d->c, d->cache[k].name, sql, nparams, NULL);
	if (PQresultStatus(r) != PGRES_COMMAND_OK) {
		*fail = r;
		return NULL;
	}
	PQclear(r);
	d->cache[k].sql = sql;
	d->ncache++;
	return d->cache[k].name;
}

static PGresult *query(struct db *db, const char *sql, int cache, const struct pgdb_params *p,
		       const char *what, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	int n = p ? p->n : 0;

	for (int attempt = 0;; attempt++) {
		PGresult *r = NULL;
		const char *name = NULL;
		ExecStatusType st;

		if (PQstatus(d->c) != CONNECTION_OK && !d->in_tx && attempt == 0) {
			if (reconnect(d, e))
				return NULL;
		}
		if (cache)
			name = prepared(d, sql, n, &r);
		if (!r)
			r = name ? PQexecPrepared(d->c, name, n, p ? p->v : NULL, p ? p->len : NULL,
						  p ? p->fmt : NULL, 0)
				 : PQexecParams(d->c, sql, n, NULL, p ? p->v : NULL,
						p ? p->len : NULL, p ? p->fmt : NULL, 0);
		st = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
		if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) {
			d->sqlstate[0] = '\0';
			return r;
		}
		/* Outside a transaction the statement is BEGIN or a read: safe
		 * to run again on a fresh connection. */
		if (attempt == 0 && !d->in_tx && PQstatus(d->c) != CONNECTION_OK) {
			PQclear(r);
			if (reconnect(d, e))
				return NULL;
			continue;
		}
		pgdb_fail(db, r, e, what);
		PQclear(r);
		return NULL;
	}
}

PGresult *pgdb_q(struct db *db, const char *sql, const struct pgdb_params *p, const char *what,
		 struct err *e)
{
	return query(db, sql, 1, p, what, e);
}

PGresult *pgdb_q_once(struct db *db, const char *sql, const struct pgdb_params *p,
		      const char *what, struct err *e)
{
	return query(db, sql, 0, p, what, e);
}

int pgdb_run(struct db *db, const char *sql, const struct pgdb_params *p, const char *what,
	     struct err *e)
{
	PGresult *r = pgdb_q(db, sql, p, what, e);

	if (!r)
		return ERR_IO;
	PQclear(r);
	return 0;
}

int64_t pgdb_changes(PGresult *r)
{
	const char *t = PQcmdTuples(r);

	return t && *t ? strtoll(t, NULL, 10) : 0;
}

int pgdb_exec(struct db *db, const char *sql, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	PGresult *r = PQexec(d->c, sql);
	ExecStatusType st = PQresultStatus(r);
	int rc = 0;

	if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK)
		rc = pgdb_fail(db, r, e, "sql failed");
	PQclear(r);
	return rc;
}

/* ---- columns ---- */

int64_t pgdb_i64(const PGresult *r, int i, int col)
{
	return strtoll(PQgetvalue(r, i, col), NULL, 10);
}

int pgdb_int(const PGresult *r, int i, int col)
{
	return (int)strtol(PQgetvalue(r, i, col), NULL, 10);
}

double pgdb_f64(const PGresult *r, int i, int col)
{
	return PQgetisnull(r, i, col) ? 0 : strtod(PQgetvalue(r, i, col), NULL);
}

const char *pgdb_text(const PGresult *r, int i, int col)
{
	return PQgetvalue(r, i, col); /* "" for NULL */
}

void pgdb_copy(const PGresult *r, int i, int col, char *buf, size_t len)
{
	const char *t = PQgetvalue(r, i, col);
	size_t n = (size_t)PQgetlength(r, i, col);

	if (n >= len)
		n = len - 1;
	memcpy(buf, t, n);
	buf[n] = '\0';
}

char *pgdb_dup(const PGresult *r, int i, int col)
{
	if (PQgetisnull(r, i, col))
		return NULL;
	return strdup(PQgetvalue(r, i, col));
}

static int hexval(char c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	return -1;
}

long pgdb_bytea(const PGresult *r, int i, int col, unsigned char *out, size_t cap)
{
	const char *t = PQgetvalue(r, i, col);
	size_t len = (size_t)PQgetlength(r, i, col), n;

	/* bytea_output = hex (the default since 9.0): "\x" + 2 digits a byte */
	if (PQgetisnull(r, i, col) || len < 2 || t[0] != '\\' || t[1] != 'x' || (len - 2) % 2)
		return -1;
	n = (len - 2) / 2;
	if (n > cap)
		return -1;
	for (size_t k = 0; k < n; k++) {
		int hi = hexval(t[2 + 2 * k]), lo = hexval(t[3 + 2 * k]);
		if (hi < 0 || lo < 0)
			return -1;
		out[k] = (unsigned char)(hi << 4 | lo);
	}
	return (long)n;
}

/* ---- connection ---- */

int pgdb_open(const char *url, struct db **out, struct err *e)
{
	/* The URL's own settings win over connect_timeout (it comes first);
	 * client_encoding comes after it: every text here is UTF-8. */
	static const char *const kw[] = {"connect_timeout", "dbname", "fallback_application_name",
					 "client_encoding", NULL};
	const char *val[] = {"10", url, "infilld", "UTF8", NULL};
	struct db_pg *d = calloc(1, sizeof *d);
	char line[400];
	int rc;

	if (!d)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the database");
	d->base.ops = &db_pg_ops;
	d->c = PQconnectdbParams(kw, val, 1);
	if (!d->c) {
		free(d);
		return ERR_SET(e, ERR_NOMEM, "out of memory connecting to PostgreSQL");
	}
	if (PQstatus(d->c) != CONNECTION_OK) {
		one_line(PQerrorMessage(d->c), line, sizeof line);
		rc = ERR_SET(e, ERR_IO, "cannot connect to PostgreSQL: %s", line);
		goto out;
	}
	PQsetNoticeProcessor(d->c, notice_discard, NULL);
	if ((rc = session_setup(d, e)))
		goto out;
	rc = pgdb_migrate(&d->base, e);
out:
	if (rc) {
		pgdb_close(&d->base);
		return rc;
	}
	*out = &d->base;
	return 0;
}

void pgdb_close(struct db *db)
{
	struct db_pg *d = (struct db_pg *)db;

	if (!d)
		return;
	PQfinish(d->c);
	free(d);
}

int pgdb_begin(struct db *db, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	int rc;

	if (d->in_tx)
		return ERR_SET(e, ERR_INTERNAL, "BEGIN inside a transaction");
	if ((rc = pgdb_run(db, "BEGIN", NULL, "BEGIN", e)))
		return rc;
	d->in_tx = 1;
	return 0;
}

int pgdb_commit(struct db *db, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	PGresult *r = pgdb_q(db, "COMMIT", NULL, "COMMIT", e);
	int rc = 0;

	/* COMMIT of a failed transaction "succeeds" as ROLLBACK. */
	if (!r)
		rc = ERR_IO;
	else if (strcmp(PQcmdStatus(r), "COMMIT") != 0)
		rc = ERR_SET(e, ERR_IO, "COMMIT: the transaction was rolled back");
	PQclear(r);
	d->in_tx = 0;
	if (rc)
		pgdb_rollback(db);
	return rc;
}

void pgdb_rollback(struct db *db)
{
	struct db_pg *d = (struct db_pg *)db;
	PGTransactionStatusType ts = PQtransactionStatus(d->c);

	d->in_tx = 0;
	if (ts == PQTRANS_INTRANS || ts == PQTRANS_INERROR)
		PQclear(PQexec(d->c, "ROLLBACK"));
}

int pgdb_check_writable(struct db *db, struct err *e)
{
	/* A write that changes nothing: a read-only server (a standby, or
	 * default_transaction_read_only) refuses it. */
	static const char sql[] = "UPDATE schema_version SET version = version WHERE version < 0";
	int rc = pgdb_begin(db, e);

	if (rc)
		return rc;
	if ((rc = pgdb_run(db, sql, NULL, "checking the database is writable", e))) {
		pgdb_rollback(db);
		return rc;
	}
	return pgdb_commit(db, e);
}

/* ---- notifications ---- */

int pgdb_listen(struct db *db, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	int rc = pgdb_run(db, "LISTEN infilld_job", NULL, "LISTEN", e);

	if (!rc)
		d->listening = 1;
	return rc;
}

/* Move the notifications libpq has read into seqs; *over = 1 when they
 * did not fit. */
static void drain(struct db_pg *d, int64_t *seqs, int cap, int *cnt, int *over)
{
	PGnotify *nt;

	while ((nt = PQnotifies(d->c))) {
		char *end;
		long long v = strtoll(nt->extra, &end, 10);
		if (end == nt->extra || *end)
			*over = 1; /* not ours: re-read everything */
		else if (*cnt < cap)
			seqs[(*cnt)++] = v;
		else
			*over = 1;
		PQfreemem(nt);
	}
}

static int64_t mono_ms(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int pgdb_wait(struct db *db, int timeout_ms, int64_t *seqs, int cap, int *n, struct err *e)
{
	struct db_pg *d = (struct db_pg *)db;
	int64_t deadline = mono_ms() + (timeout_ms > 0 ? timeout_ms : 0);
	int cnt = 0, over = 0, rc;

	if (!d->listening)
		return ERR_SET(e, ERR_INTERNAL, "db_wait() before db_listen()");
	if ((rc = pgdb_ready(db, e)))
		return rc;
	for (;;) {
		struct pollfd pf = {PQsocket(d->c), POLLIN, 0};
		int64_t left;

		if (!PQconsumeInput(d->c)) {
			/* Broken: reconnect (LISTEN again); what was sent meanwhile
			 * is lost, so the caller re-reads every job it watches. */
			if ((rc = reconnect(d, e)))
				return rc;
			d->lost_notify = 0;
			*n = -1;
			return 0;
		}
		if (d->lost_notify) {
			d->lost_notify = 0;
			over = 1;
		}
		drain(d, seqs, cap, &cnt, &over);
		left = deadline - mono_ms();
		if (cnt || over || left <= 0)
			break;
		if (pf.fd < 0)
			return ERR_SET(e, ERR_IO, "waiting for notifications: no connection");
		if (poll(&pf, 1, (int)left) < 0 && errno != EINTR)
			return ERR_SET(e, ERR_IO, "waiting for notifications: %s", strerror(errno));
	}
	*n = over ? -1 : cnt;
	return 0;
}

static int pgdb_analyze(struct db *db, struct err *e)
{
	return pgdb_exec(db, "ANALYZE", e);
}

const struct db_ops db_pg_ops = {
	.name = "postgresql",
	.open = pgdb_open,
	.close = pgdb_close,
	.schema_version = pgdb_schema_version,
	.schema_latest = pgdb_schema_latest,
	.begin = pgdb_begin,
	.commit = pgdb_commit,
	.rollback = pgdb_rollback,
	.check_writable = pgdb_check_writable,
	.listen = pgdb_listen,
	.wait = pgdb_wait,
	.tenant_add = pgdb_tenant_add,
	.tenant_list = pgdb_tenant_list,
	.tenant_get = pgdb_tenant_get,
	.tenant_get_id = pgdb_tenant_get_id,
	.tenant_rotate = pgdb_tenant_rotate,
	.tenant_remove = pgdb_tenant_remove,
	.tenant_add_usage = pgdb_tenant_add_usage,
	.tenant_charge = pgdb_tenant_charge,
	.tenant_auth = pgdb_tenant_auth,
	.admin_key_rotate = pgdb_admin_key_rotate,
	.admin_auth = pgdb_admin_auth,
	.mesh_add = pgdb_mesh_add,
	.mesh_get = pgdb_mesh_get,
	.mesh_list = pgdb_mesh_list,
	.mesh_delete = pgdb_mesh_delete,
	.artifact_list = pgdb_artifact_list,
	.artifact_quarantine = pgdb_artifact_quarantine,
	.submit_one = pgdb_submit_one,
	.savepoint = pgdb_savepoint,
	.get = pgdb_get,
	.get_seq = pgdb_get_seq,
	.list = pgdb_list,
	.cancel = pgdb_cancel,
	.claim = pgdb_claim,
	.heartbeat = pgdb_heartbeat,
	.progress = pgdb_progress,
	.succeed = pgdb_succeed,
	.fail = pgdb_fail_job,
	.rescue = pgdb_rescue,
	.events = pgdb_events,
	.counts = pgdb_counts,
	.durations = pgdb_durations,
	.expire_artifacts = pgdb_expire_artifacts,
	.artifact_referenced = pgdb_artifact_referenced,
	.copy_out = pgdb_copy_out,
	.copy_in = pgdb_copy_in,
	.copy_done = pgdb_copy_done,
	.analyze = pgdb_analyze,
};
