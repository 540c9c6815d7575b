/* solve.c - optimising the voids of one round, in parallel.
 *
 * Lightweight (eq. 11) is a sum over voids, so each void is its own
 * problem (the paper: "different groups can thus be optimized in
 * parallel").  Ipopt's linear solver MUMPS is not thread-safe, so the
 * parallelism is process-level: up to `threads` forked workers, each
 * solving one void and sending its offsets back through a pipe; a worker
 * that crashes costs only its void.  Stability (eq. 12-14) couples all
 * voids through the centre of mass and is solved as one problem here.
 * A void whose optimised offsets fail the constraint check falls back to
 * its support-free starting point (start.c) when that passes.
 */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/hollow/opt/opt_int.h"

/* What a worker sends back before its nv offsets. */
struct wire_head {
	int rc, status, iterations, capped, outer;
	double seconds, volume_mm3, ceil_eps_mm2;
	size_t nv;
	char msg[200];
};

static int write_all(int fd, const void *p, size_t n)
{
	const char *c = p;

	while (n) {
		ssize_t w = write(fd, c, n);
		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0)
			return -1;
		c += w;
		n -= (size_t)w;
	}
	return 0;
}

/* Worker process: solve void v, write the result, never return. */
static void worker(int fd, struct hl_void *v, const struct hl_nlp_opts *o)
{
	struct hl_nlp_opts oo = *o;
	struct wire_head h;
	struct err e;

	oo.cancelled = NULL; /* the parent kills us instead */
	err_clear(&e);
	memset(&h, 0, sizeof h);
	h.rc = hl_nlp_solve(v, 1, &oo, &e);
	h.status = v->status;
	h.iterations = v->iterations;
	h.capped = v->capped;
	h.outer = v->outer;
	h.seconds = v->seconds;
	h.volume_mm3 = v->volume_mm3;
	h.ceil_eps_mm2 = v->ceil_eps_mm2;
	h.nv = h.rc == 0 && v->l ? v->nv : 0;
	snprintf(h.msg, sizeof h.msg, "%s", e.msg);
	if (write_all(fd, &h, sizeof h) == 0 && h.nv)
		write_all(fd, v->l, h.nv * sizeof *v->l);
	_exit(0);
}

struct slot {
	pid_t pid;
	int fd;
	size_t void_idx;
	unsigned char *buf; /* head + offsets */
	size_t want, got;
};

static void slot_reap(struct slot *s, int kill_it)
{
	if (s->pid > 0) {
		if (kill_it)
			kill(s->pid, SIGKILL);
		while (waitpid(s->pid, NULL, 0) < 0 && errno == EINTR)
			;
	}
	if (s->fd >= 0)
		close(s->fd);
	mem_free(s->buf);
	memset(s, 0, sizeof *s);
	s->fd = -1;
}

/* Take a finished worker's bytes into its void. */
static void slot_deliver(struct slot *s, struct hl_void *v)
{
	struct wire_head h;

	v->status = -2000; /* crashed or truncated */
	if (s->got < sizeof h)
		return;
	memcpy(&h, s->buf, sizeof h);
	if (h.rc != 0 || h.nv != v->nv || s->got < sizeof h + h.nv * sizeof(double)) {
		v->status = h.rc ? h.rc : -2001;
		return;
	}
	mem_free(v->l);
	v->l = mem_alloc((v->nv + 1) * sizeof *v->l);
	if (!v->l) {
		v->status = ERR_NOMEM;
		return;
	}
	memcpy(v->l, s->buf + sizeof h, v->nv * sizeof *v->l);
	v->status = h.status;
	v->iterations = h.iterations;
	v->capped = h.capped;
	v->outer = h.outer;
	v->seconds = h.seconds;
	v->volume_mm3 = h.volume_mm3;
	v->ceil_eps_mm2 = h.ceil_eps_mm2;
}

/* No solve may start: the time budget is spent (Ipopt's own limit stops
 * a running solve) or the work budget left no iterations. */
static int budget_out(const struct hl_nlp_opts *o)
{
	return o->iter_cap < 0 || (o->deadline_s > 0 && progress_now_s() >= o->deadline_s);
}

static int solve_forked(struct hl_void *v, size_t n, const size_t *order,
			const struct hl_nlp_opts *o, int threads, struct progress *prog, double f0,
			double f1, struct err *e)
{
	struct slot *sl = mem_calloc((size_t)threads, sizeof *sl);
	size_t next = 0, done = 0;
	int rc = 0;

	if (!sl)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	for (int i = 0; i < threads; i++)
		sl[i].fd = -1;
	while (done < n) {
		struct pollfd pf[64];
		int np = 0, map[64];
		/* launch (none past the deadline: the rest keep their start) */
		for (int i = 0; i < threads && next < n; i++) {
			int p[2];
			struct hl_void *V = &v[order[next]];
			if (sl[i].pid > 0)
				continue;
			if (budget_out(o)) {
				for (; next < n; next++, done++)
					v[order[next]].status = HL_STATUS_UNSOLVED;
				break;
			}
			if (pipe(p) < 0) {
				rc = ERR_SET(e, ERR_IO, "hollow: pipe: %s", strerror(errno));
				goto out;
			}
			sl[i].pid = fork();
			if (sl[i].pid == 0) {
				close(p[0]);
				worker(p[1], V, o);
			}
			close(p[1]);
			if (sl[i].pid < 0) {
				close(p[0]);
				sl[i].pid = 0;
				/* no process to spare: solve this one here */
				rc = hl_nlp_solve(V, 1, o, e);
				if (rc)
					goto out;
				next++;
				done++;
				continue;
			}
			sl[i].fd = p[0];
			sl[i].void_idx = order[next++];
			sl[i].want = sizeof(struct wire_head) + V->nv * sizeof(double);
			sl[i].buf = mem_alloc(sl[i].want);
			sl[i].got = 0;
			if (!sl[i].buf) {
				rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
				goto out;
			}
		}
		for (int i = 0; i < threads && np < 64; i++)
			if (sl[i].pid > 0) {
				pf[np].fd = sl[i].fd;
				pf[np].events = POLLIN;
				map[np++] = i;
			}
		if (np == 0)
			continue;
		if (poll(pf, (nfds_t)np, 200) < 0 && errno != EINTR) {
			rc = ERR_SET(e, ERR_IO, "hollow: poll: %s", strerror(errno));
			goto out;
		}
		for (int q = 0; q < np; q++) {
			struct slot *s = &sl[map[q]];
			ssize_t r;
			if (!(pf[q].revents & (POLLIN | POLLHUP | POLLERR)))
				continue;
			r = read(s->fd, s->buf + s->got, s->want - s->got);
			if (r < 0 && errno == EINTR)
				continue;
			if (r > 0)
				s->got += (size_t)r;
			if (r <= 0 || s->got == s->want) {
				slot_deliver(s, &v[s->void_idx]);
				slot_reap(s, 0);
				done++;
			}
		}
		if (prog) {
			rc = progress_update(prog, f0 + (f1 - f0) * (double)done / (double)n, e);
			if (rc)
				goto out;
		}
	}
out:
	for (int i = 0; i < threads; i++)
		if (sl[i].pid > 0 || sl[i].fd >= 0)
			slot_reap(&sl[i], 1);
	mem_free(sl);
	return rc;
}

static int cmp_size_desc(const void *a, const void *b)
{
	const size_t *x = a, *y = b;
	/* entries are (nv << 20 | index) packed: larger nv first */
	return (*x < *y) - (*x > *y);
}

int hl_solve_round(struct hl_void *v, size_t n, const struct hl_nlp_opts *o, int threads,
		   struct progress *prog, double f0, double f1, struct err *e)
{
	size_t *order = NULL;
	int rc = 0;

	if (n == 0)
		return 0;
	if (o->objective == HL_OBJ_STABILITY) {
		if (budget_out(o))
			for (size_t i = 0; i < n; i++)
				v[i].status = HL_STATUS_UNSOLVED;
		else
			rc = hl_nlp_solve(v, n, o, e);
	} else {
		order = mem_alloc(n * sizeof *order);
		if (!order)
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		for (size_t i = 0; i < n; i++)
			order[i] = (v[i].nv << 20) | i;
		qsort(order, n, sizeof *order, cmp_size_desc);
		for (size_t i = 0; i < n; i++)
			order[i] &= (1u << 20) - 1;
		if (threads > 64)
			threads = 64;
		if (threads > 1 && n > 1 && n < (1u << 20)) {
			rc = solve_forked(v, n, order, o, threads, prog, f0, f1, e);
		} else {
			for (size_t i = 0; i < n && !rc; i++) {
				if (budget_out(o)) {
					v[order[i]].status = HL_STATUS_UNSOLVED;
					continue;
				}
				rc = hl_nlp_solve(&v[order[i]], 1, o, e);
				if (!rc && prog)
					rc = progress_update(prog, f0 + (f1 - f0) * (double)(i + 1) / (double)n,
							     e);
			}
		}
	}
	if (rc)
		goto out;
	/* fallback: the support-free start when the optimum fails its check */
	for (size_t i = 0; i < n; i++) {
		struct hl_check c;
		double *l;
		if (v[i].status == 0)
			continue;
		l = mem_alloc((v[i].nv + 1) * sizeof *l);
		if (!l) {
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			goto out;
		}
		rc = hl_void_support_start(&v[i], hl_reach_slope(o->alpha_rad), l, e);
		if (rc) {
			mem_free(l);
			goto out;
		}
		hl_void_check(&v[i], l, o->alpha_rad, o->gate_tau, &c);
		if (c.worst_face <= 1e-4 && c.worst_edge_mm <= 1e-3) {
			mem_free(v[i].l);
			v[i].l = l;
			v[i].status = HL_STATUS_FALLBACK;
			v[i].volume_mm3 = hl_void_volume(&v[i], l);
		} else {
			mem_free(l);
		}
	}
out:
	mem_free(order);
	return rc;
}
