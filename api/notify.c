/* notify.c - waking parked SSE streams when their job changes.
 *
 * One thread per API server (the notifier) holds its own database
 * connection and listens for job changes (db_listen/db_wait: PostgreSQL's
 * LISTEN/NOTIFY, sent by whichever machine's worker wrote the event).  A
 * stream with nothing new parks its connection (api_park_stream) under
 * wait_mu; the notifier resumes the streams of the jobs it is told about,
 * all of them when the backend cannot say which (SQLite: every 200 ms, the
 * poll), and any parked for API_KEEPALIVE_S so it can send a keep-alive.
 * No thread waits per stream.
 *
 * Lost wake-ups: a notification can arrive after a stream read the
 * events and before it parked.  Each notification gets a generation
 * number; a stream notes the generation before reading (api_notify_gen)
 * and parks only if nothing for its job (or "everything") came after it,
 * looked up in a ring of the last API_NOTIFY_RING notifications (older
 * than the ring: it does not park).
 */
#include "api/api_internal.h"
#include "api/log.h"
#include "engine/core/err.h"
#include "engine/core/progress.h"

#include <stdlib.h>
#include <time.h>

#define NOTIFY_WAIT_MS 200
#define NOTIFY_BATCH 64

uint64_t api_notify_gen(struct api_server *s)
{
	uint64_t g;

	pthread_mutex_lock(&s->wait_mu);
	g = s->notify_gen;
	pthread_mutex_unlock(&s->wait_mu);
	return g;
}

/* Under wait_mu: did anything for job_seq arrive after generation seen? */
static int changed_since(const struct api_server *s, int64_t job_seq, uint64_t seen)
{
	if (s->notify_all_gen > seen || s->notify_gen - seen >= API_NOTIFY_RING)
		return 1;
	for (uint64_t g = seen + 1; g <= s->notify_gen; g++)
		if (s->notify_ring[g % API_NOTIFY_RING] == job_seq)
			return 1;
	return 0;
}

void api_park_stream(struct api_server *s, struct MHD_Connection *conn, int64_t job_seq,
		     uint64_t seen_gen)
{
	struct api_waiter *w = malloc(sizeof *w);

	/* Registered before suspending, under the lock the notifier takes to
	 * resume, so a wake-up can never be lost. */
	pthread_mutex_lock(&s->wait_mu);
	MHD_suspend_connection(conn);
	if (w && !changed_since(s, job_seq, seen_gen)) {
		w->conn = conn;
		w->job_seq = job_seq;
		w->parked_s = progress_now_s();
		w->next = s->waiting;
		s->waiting = w;
		w = NULL;
	} else {
		MHD_resume_connection(conn); /* changed meanwhile (or no memory): read again */
	}
	pthread_mutex_unlock(&s->wait_mu);
	free(w);
}

/* Under wait_mu: record n notified seqs (n < 0: every job) and resume
 * the streams they concern, and those due a keep-alive. */
static void wake(struct api_server *s, const int64_t *seqs, int n)
{
	struct api_waiter **pp = &s->waiting;
	double now = progress_now_s();

	if (n < 0)
		s->notify_all_gen = ++s->notify_gen;
	for (int i = 0; i < n; i++)
		s->notify_ring[++s->notify_gen % API_NOTIFY_RING] = seqs[i];
	while (*pp) {
		struct api_waiter *w = *pp;
		int hit = n < 0 || now - w->parked_s >= API_KEEPALIVE_S;
		for (int i = 0; !hit && i < n; i++)
			hit = seqs[i] == w->job_seq;
		if (!hit) {
			pp = &w->next;
			continue;
		}
		*pp = w->next;
		MHD_resume_connection(w->conn);
		free(w);
	}
}

static void *notifier_main(void *arg)
{
	struct api_server *s = arg;
	int64_t seqs[NOTIFY_BATCH];
	int listening = 0;
	double last_fail_s = -1e9;

	while (!atomic_load(&s->stopping)) {
		struct err e;
		int n = 0;

		err_clear(&e);
		if (!listening && db_listen(s->notify_db, &e) == 0)
			listening = 1;
		if (!listening || db_wait(s->notify_db, NOTIFY_WAIT_MS, seqs, NOTIFY_BATCH, &n, &e)) {
			/* Database unreachable: notifications may be lost, so wake
			 * everything (each stream reads for itself) and listen anew. */
			if (progress_now_s() - last_fail_s > 60) {
				log_msg(LOG_WARN, "http", "job notifications: %s", e.msg);
				last_fail_s = progress_now_s();
			}
			listening = 0;
			n = -1;
			struct timespec ts = {0, NOTIFY_WAIT_MS * 1000000L};
			nanosleep(&ts, NULL);
		}
		pthread_mutex_lock(&s->wait_mu);
		wake(s, seqs, n);
		pthread_mutex_unlock(&s->wait_mu);
	}
	return NULL;
}

int api_notify_start(struct api_server *s, struct err *e)
{
	int rc = db_open(s->cfg.db_url, &s->notify_db, e);

	if (rc)
		return rc;
	if (pthread_create(&s->notifier, NULL, notifier_main, s) != 0) {
		db_close(s->notify_db);
		s->notify_db = NULL;
		return ERR_SET(e, ERR_IO, "cannot start the notifier thread");
	}
	return 0;
}

void api_notify_stop(struct api_server *s)
{
	if (!s->notify_db)
		return;
	atomic_store(&s->stopping, 1);
	pthread_join(s->notifier, NULL);
	/* Resume whatever is still parked so MHD can close it. */
	pthread_mutex_lock(&s->wait_mu);
	while (s->waiting) {
		struct api_waiter *w = s->waiting;
		s->waiting = w->next;
		MHD_resume_connection(w->conn);
		free(w);
	}
	pthread_mutex_unlock(&s->wait_mu);
	db_close(s->notify_db);
	s->notify_db = NULL;
}
