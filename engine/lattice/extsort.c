/* extsort.c - external sort of struts by lower z (strut.h).
 *
 * Struts accumulate in a run buffer of budget_bytes; a full buffer is
 * radix-sorted (LSD, 4 x 8 bits on the order-preserving integer image of
 * the float key, stable) and appended to one unlinked temporary file.  At
 * the end the last run stays in memory and all runs are merged with a
 * binary heap; each spilled run is read through its own small buffer.
 * Memory: the run buffer (+ its sort scratch) and k read buffers; time
 * O(n) per run plus O(n log k) for the merge.
 */
#include "engine/lattice/binfmt.h"
#include "engine/lattice/strut.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

struct run {
	uint64_t off, n; /* byte offset in the spill file, records */
	uint64_t taken;
	struct latbin_cursor cur;
	struct lattice_strut head;
};

struct lattice_sorter {
	struct lattice_strut *buf, *tmp;
	size_t cap, n;
	int fd;
	char tmp_dir[256];
	struct run *runs;
	size_t nruns, runs_cap; /* spilled runs, then (at finish) the memory run */
	size_t spilled;
	int *heap;
	size_t nheap;
	int finished;
	uint64_t count;
	size_t mem_pos; /* single in-memory run: next record */
};

void lattice_strut_make(struct lattice_strut *s, struct vec3 p, struct vec3 q, double radius_mm)
{
	float pz = (float)p.z, qz = (float)q.z;

	if (qz < pz) {
		struct vec3 t = p;
		p = q;
		q = t;
	}
	s->a[0] = (float)p.x;
	s->a[1] = (float)p.y;
	s->a[2] = (float)p.z;
	s->b[0] = (float)q.x;
	s->b[1] = (float)q.y;
	s->b[2] = (float)q.z;
	s->radius_mm = (float)radius_mm;
}

/* Order-preserving map of a finite float to uint32. */
static inline uint32_t zkey(const struct lattice_strut *s)
{
	uint32_t u;

	memcpy(&u, &s->a[2], 4);
	return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

static void radix_sort(struct lattice_strut *a, struct lattice_strut *tmp, size_t n)
{
	size_t cnt[256];

	for (int pass = 0; pass < 4; pass++) {
		int sh = 8 * pass;
		size_t sum = 0;

		memset(cnt, 0, sizeof cnt);
		for (size_t i = 0; i < n; i++)
			cnt[(zkey(&a[i]) >> sh) & 255]++;
		for (int k = 0; k < 256; k++) {
			size_t c = cnt[k];
			cnt[k] = sum;
			sum += c;
		}
		for (size_t i = 0; i < n; i++)
			tmp[cnt[(zkey(&a[i]) >> sh) & 255]++] = a[i];
		{
			struct lattice_strut *t = a;
			a = tmp;
			tmp = t;
		}
	}
	/* four passes: the data is back in the caller's array */
}

int lattice_sorter_new(size_t budget_bytes, const char *tmp_dir, struct lattice_sorter **out,
		       struct err *e)
{
	struct lattice_sorter *s = mem_calloc(1, sizeof *s);
	const char *dir = tmp_dir ? tmp_dir : getenv("TMPDIR");

	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->fd = -1;
	snprintf(s->tmp_dir, sizeof s->tmp_dir, "%s", dir && *dir ? dir : "/tmp");
	/* the run buffer and its radix scratch share the budget */
	s->cap = budget_bytes / (2 * sizeof(struct lattice_strut));
	if (s->cap < 64)
		s->cap = 64;
	*out = s;
	return 0;
}

void lattice_sorter_free(struct lattice_sorter *s)
{
	if (!s)
		return;
	for (size_t i = 0; i < s->nruns; i++)
		latbin_cursor_fini(&s->runs[i].cur);
	mem_free(s->runs);
	mem_free(s->heap);
	mem_free(s->buf);
	mem_free(s->tmp);
	if (s->fd >= 0)
		close(s->fd);
	mem_free(s);
}

static int ensure_buffers(struct lattice_sorter *s, struct err *e)
{
	if (s->buf)
		return 0;
	s->buf = mem_alloc(s->cap * sizeof *s->buf);
	s->tmp = mem_alloc(s->cap * sizeof *s->tmp);
	if (!s->buf || !s->tmp)
		return ERR_SET(e, ERR_NOMEM, "out of memory for a %zu-strut sort run", s->cap);
	return 0;
}

static int add_run(struct lattice_sorter *s, uint64_t off, uint64_t n, struct err *e)
{
	void *arr = s->runs;

	if (mem_grow(&arr, &s->runs_cap, s->nruns + 1, sizeof *s->runs)) {
		s->runs = arr;
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	}
	s->runs = arr;
	memset(&s->runs[s->nruns], 0, sizeof s->runs[0]);
	s->runs[s->nruns].off = off;
	s->runs[s->nruns].n = n;
	s->runs[s->nruns].cur.fd = -1;
	s->nruns++;
	return 0;
}

static int spill(struct lattice_sorter *s, struct err *e)
{
	uint64_t off, bytes = s->n * sizeof *s->buf, done = 0;
	int rc;

	if (s->fd < 0) {
		char path[300];

		snprintf(path, sizeof path, "%s/infilld-struts-XXXXXX", s->tmp_dir);
		s->fd = mkstemp(path);
		if (s->fd < 0)
			return ERR_SET(e, ERR_IO, "cannot create a spill file in %s: %s",
				       s->tmp_dir, strerror(errno));
		unlink(path);
	}
	off = s->nruns ? s->runs[s->nruns - 1].off + s->runs[s->nruns - 1].n * sizeof *s->buf : 0;
	radix_sort(s->buf, s->tmp, s->n);
	while (done < bytes) {
		ssize_t w = pwrite(s->fd, (const char *)s->buf + done, bytes - done,
				   (off_t)(off + done));
		if (w < 0 && errno == EINTR)
			continue;
		if (w < 0)
			return ERR_SET(e, ERR_IO, "writing the spill file: %s", strerror(errno));
		done += (uint64_t)w;
	}
	if ((rc = add_run(s, off, s->n, e)) != 0)
		return rc;
	s->spilled++;
	s->n = 0;
	return 0;
}

int lattice_sorter_add(struct lattice_sorter *s, const struct lattice_strut *st, struct err *e)
{
	int rc;

	if (s->finished)
		return ERR_SET(e, ERR_INTERNAL, "strut added after the sort finished");
	if (!isfinite(st->a[2]) || !isfinite(st->b[2]) || !isfinite(st->a[0]) ||
	    !isfinite(st->a[1]) || !isfinite(st->b[0]) || !isfinite(st->b[1]) ||
	    !(st->radius_mm > 0) || !isfinite(st->radius_mm) || st->b[2] < st->a[2])
		return ERR_SET(e, ERR_PARAM, "strut %llu is not finite or not oriented",
			       (unsigned long long)s->count);
	if ((rc = ensure_buffers(s, e)) != 0)
		return rc;
	if (s->n == s->cap && (rc = spill(s, e)) != 0)
		return rc;
	s->buf[s->n++] = *st;
	s->count++;
	return 0;
}

int lattice_sorter_add_lattice(struct lattice_sorter *s, const struct lattice *q, struct err *e)
{
	struct lattice_strut st;
	int rc;

	for (size_t i = 0; i < q->nedges; i++) {
		lattice_strut_make(&st, q->node[q->edge[i].a], q->node[q->edge[i].b],
				   q->edge[i].radius_mm);
		if ((rc = lattice_sorter_add(s, &st, e)) != 0)
			return rc;
	}
	return 0;
}

/* Heap of run indices ordered by their head's key (ties: run index, so
 * the merge is deterministic). */
static int run_less(const struct lattice_sorter *s, int a, int b)
{
	uint32_t ka = zkey(&s->runs[a].head), kb = zkey(&s->runs[b].head);
	return ka < kb || (ka == kb && a < b);
}

static void heap_down(struct lattice_sorter *s, size_t i)
{
	for (;;) {
		size_t l = 2 * i + 1, r = l + 1, m = i;
		int t;
		if (l < s->nheap && run_less(s, s->heap[l], s->heap[m]))
			m = l;
		if (r < s->nheap && run_less(s, s->heap[r], s->heap[m]))
			m = r;
		if (m == i)
			return;
		t = s->heap[i];
		s->heap[i] = s->heap[m];
		s->heap[m] = t;
		i = m;
	}
}

static int run_pull(struct lattice_sorter *s, struct run *r, struct err *e)
{
	const unsigned char *p;

	if (r->taken >= r->n)
		return 0;
	if (!(p = latbin_cursor_take(&r->cur, sizeof r->head, e)))
		return e ? e->code : ERR_IO;
	memcpy(&r->head, p, sizeof r->head);
	r->taken++;
	(void)s;
	return 1;
}

int lattice_sorter_finish(struct lattice_sorter *s, struct err *e)
{
	int rc;

	if (s->finished)
		return 0;
	s->finished = 1;
	if (s->n)
		radix_sort(s->buf, s->tmp, s->n);
	mem_free(s->tmp);
	s->tmp = NULL;
	if (s->spilled == 0)
		return 0; /* single in-memory run */
	/* Merge: spilled runs read through buffers sized to share 16 MiB, plus
	 * the last run from memory. */
	{
		size_t per = (16u << 20) / (s->nruns + 1);
		if (per < (64u << 10))
			per = 64u << 10;
		per -= per % sizeof(struct lattice_strut);
		for (size_t i = 0; i < s->nruns; i++)
			if (latbin_cursor_init(&s->runs[i].cur, s->fd, s->runs[i].off, per))
				return ERR_SET(e, ERR_NOMEM, "out of memory for merge buffers");
	}
	if (s->n) {
		if ((rc = add_run(s, 0, s->n, e)) != 0)
			return rc;
		latbin_cursor_init_mem(&s->runs[s->nruns - 1].cur, s->buf,
				       s->n * sizeof *s->buf, 0);
	}
	s->heap = mem_alloc(s->nruns * sizeof *s->heap);
	if (!s->heap)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	for (size_t i = 0; i < s->nruns; i++) {
		rc = run_pull(s, &s->runs[i], e);
		if (rc < 0)
			return rc;
		if (rc)
			s->heap[s->nheap++] = (int)i;
	}
	for (size_t i = s->nheap / 2; i-- > 0;)
		heap_down(s, i);
	return 0;
}

static int sorter_next(void *ctx, struct lattice_strut *out, struct err *e)
{
	struct lattice_sorter *s = ctx;
	int top, rc;

	if (!s->finished)
		return ERR_SET(e, ERR_INTERNAL, "sorter read before lattice_sorter_finish()");
	if (s->spilled == 0) {
		if (s->mem_pos >= s->n)
			return 0;
		*out = s->buf[s->mem_pos++];
		return 1;
	}
	if (s->nheap == 0)
		return 0;
	top = s->heap[0];
	*out = s->runs[top].head;
	rc = run_pull(s, &s->runs[top], e);
	if (rc < 0)
		return rc;
	if (rc == 0)
		s->heap[0] = s->heap[--s->nheap];
	heap_down(s, 0);
	return 1;
}

struct lattice_source lattice_sorter_source(struct lattice_sorter *s)
{
	struct lattice_source src = {sorter_next, s};
	return src;
}

size_t lattice_sorter_runs(const struct lattice_sorter *s)
{
	return s->spilled;
}

uint64_t lattice_sorter_count(const struct lattice_sorter *s)
{
	return s->count;
}
