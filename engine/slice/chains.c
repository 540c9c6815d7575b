/* chains.c - closing the open contour chains an open mesh leaves in a
 * plane (see chains.h).  Greedy joining, same hole first, then nearest
 * end over heads sorted by x with union-find "next alive" links so
 * consumed heads cost O(1) amortised to skip.  Rationale:
 * docs/slicing.md "Open meshes".
 */
#include "engine/slice/chains.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <stdlib.h>
#include <string.h>

struct head {
	int64_t x, y;
	size_t chain;
};

/* Heads this close to a tail (nm) continue it, whatever the holes say. */
#define SEAM_NM 1000.0

struct onhole {
	uint32_t hole;
	size_t chain;
};

struct heads {
	struct head *h; /* sorted by x, then y */
	size_t *slot;   /* chain -> index in h */
	size_t *right;  /* right[i] == i: alive (i == m: sentinel) */
	size_t *left;   /* shifted by one: left[i+1] is element i; left[0] sentinel */
	size_t m;
	struct onhole *byhole; /* chains with a head on a hole, by that hole */
	size_t nbyhole;
	unsigned char *dead; /* per chain: head consumed */
};

static int head_cmp(const void *a, const void *b)
{
	const struct head *p = a, *q = b;

	if (p->x != q->x)
		return p->x < q->x ? -1 : 1;
	if (p->y != q->y)
		return p->y < q->y ? -1 : 1;
	return p->chain < q->chain ? -1 : p->chain > q->chain;
}

/* First alive element at or right of i (m if none). */
static size_t find_right(size_t *r, size_t i)
{
	while (r[i] != i) {
		r[i] = r[r[i]];
		i = r[i];
	}
	return i;
}

/* Shifted index of the first alive element at or left of shifted j (0 if
 * none). */
static size_t find_left(size_t *l, size_t j)
{
	while (l[j] != j) {
		l[j] = l[l[j]];
		j = l[j];
	}
	return j;
}

static void head_remove(struct heads *hs, size_t chain)
{
	size_t i = hs->slot[chain];

	hs->right[i] = i + 1;
	hs->left[i + 1] = i;
	hs->dead[chain] = 1;
}

static int byhole_cmp(const void *a, const void *b)
{
	const struct onhole *p = a, *q = b;

	if (p->hole != q->hole)
		return p->hole < q->hole ? -1 : 1;
	return p->chain < q->chain ? -1 : p->chain > q->chain;
}

static double dist2(struct pt2 a, struct pt2 b)
{
	double dx = (double)(a.x - b.x), dy = (double)(a.y - b.y);
	return dx * dx + dy * dy;
}

/* Nearest alive chain whose head lies on hole `hole`, or SIZE_MAX. */
static size_t head_nearest_on_hole(const struct heads *hs, const struct paths *open,
				   uint32_t hole, struct pt2 q)
{
	size_t lo = 0, hi = hs->nbyhole, best_chain = SIZE_MAX;
	double best = INFINITY;

	if (hole == UINT32_MAX)
		return SIZE_MAX;
	while (lo < hi) {
		size_t mid = lo + (hi - lo) / 2;
		if (hs->byhole[mid].hole < hole)
			lo = mid + 1;
		else
			hi = mid;
	}
	for (; lo < hs->nbyhole && hs->byhole[lo].hole == hole; lo++) {
		size_t c = hs->byhole[lo].chain;
		double d;
		if (hs->dead[c])
			continue;
		d = dist2(open->v[c].pts[0], q);
		if (d < best) {
			best = d;
			best_chain = c;
		}
	}
	return best_chain;
}

/* Chain whose alive head is nearest to q (ties: lowest x, y, chain). */
static size_t head_nearest(struct heads *hs, struct pt2 q)
{
	size_t lo = 0, hi = hs->m, i, j, best_chain = SIZE_MAX;
	double best = INFINITY;

	while (lo < hi) { /* first index with x >= q.x */
		size_t mid = lo + (hi - lo) / 2;
		if (hs->h[mid].x < q.x)
			lo = mid + 1;
		else
			hi = mid;
	}
	for (i = find_right(hs->right, lo); i < hs->m; i = find_right(hs->right, i + 1)) {
		double dx = (double)(hs->h[i].x - q.x), dy = (double)(hs->h[i].y - q.y);
		if (dx * dx >= best)
			break;
		if (dx * dx + dy * dy < best) {
			best = dx * dx + dy * dy;
			best_chain = hs->h[i].chain;
		}
	}
	for (j = find_left(hs->left, lo); j > 0; j = find_left(hs->left, j - 1)) {
		const struct head *h = &hs->h[j - 1];
		double dx = (double)(q.x - h->x), dy = (double)(h->y - q.y);
		if (dx * dx > best)
			break;
		if (dx * dx + dy * dy < best ||
		    (dx * dx + dy * dy == best && h->chain < best_chain)) {
			best = dx * dx + dy * dy;
			best_chain = h->chain;
		}
	}
	return best_chain;
}

/* Append src's points to dst. */
static int path_append(struct path *dst, const struct path *src)
{
	void *arr = dst->pts;

	if (mem_grow(&arr, &dst->cap, dst->n + src->n, sizeof *dst->pts))
		return ERR_NOMEM;
	dst->pts = arr;
	memcpy(dst->pts + dst->n, src->pts, src->n * sizeof *src->pts);
	dst->n += src->n;
	return 0;
}

int slice_chains_close(struct paths *open, const uint32_t *key, struct paths *loops,
		       struct err *e)
{
	struct heads hs;
	unsigned char *used = NULL;
	size_t m = open->n;
	int rc = 0;

	memset(&hs, 0, sizeof hs);
	hs.m = m;
	if (m == 0)
		return 0;
	hs.h = mem_alloc(m * sizeof *hs.h);
	hs.slot = mem_alloc(m * sizeof *hs.slot);
	hs.right = mem_alloc((m + 1) * sizeof *hs.right);
	hs.left = mem_alloc((m + 1) * sizeof *hs.left);
	used = mem_calloc(m, 1);
	hs.dead = mem_calloc(m, 1);
	hs.byhole = mem_alloc(m * sizeof *hs.byhole);
	if (!hs.h || !hs.slot || !hs.right || !hs.left || !used || !hs.dead || !hs.byhole) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory closing %zu open contour chains", m);
		goto out;
	}
	for (size_t c = 0; c < m; c++) {
		hs.h[c].x = open->v[c].pts[0].x;
		hs.h[c].y = open->v[c].pts[0].y;
		hs.h[c].chain = c;
	}
	qsort(hs.h, m, sizeof *hs.h, head_cmp);
	for (size_t c = 0; key && c < m; c++) {
		if (key[2 * c] != UINT32_MAX) {
			hs.byhole[hs.nbyhole].hole = key[2 * c];
			hs.byhole[hs.nbyhole++].chain = c;
		}
	}
	qsort(hs.byhole, hs.nbyhole, sizeof *hs.byhole, byhole_cmp);
	for (size_t i = 0; i <= m; i++) {
		hs.right[i] = i;
		hs.left[i] = i;
		if (i < m)
			hs.slot[hs.h[i].chain] = i;
	}

	for (size_t c = 0; c < m; c++) {
		struct path g;
		struct path *dst;

		if (used[c])
			continue;
		used[c] = 1;
		g = open->v[c]; /* take ownership; c's head stays alive to close onto */
		path_init(&open->v[c]);
		open->v[c].pts = &g.pts[0]; /* its head point, for the hole search */
		open->v[c].n = 1;
		for (size_t tail = c;;) {
			struct pt2 t = g.pts[g.n - 1];
			size_t n = head_nearest(&hs, t);
			/* A head on the tail's very point is a seam the weld missed:
			 * the surface goes on there.  Otherwise cross the hole. */
			if (key && n != SIZE_MAX && dist2(open->v[n].pts[0], t) > SEAM_NM * SEAM_NM) {
				size_t h = head_nearest_on_hole(&hs, open, key[2 * tail + 1], t);
				if (h != SIZE_MAX)
					n = h;
			}
			if (n == c || n == SIZE_MAX) {
				head_remove(&hs, c);
				break;
			}
			if (path_append(&g, &open->v[n])) {
				path_init(&open->v[c]);
				path_fini(&g);
				rc = ERR_SET(e, ERR_NOMEM, "out of memory joining contour chains");
				goto out;
			}
			open->v[c].pts = &g.pts[0]; /* g may have moved */
			used[n] = 1;
			head_remove(&hs, n);
			path_fini(&open->v[n]);
			tail = n;
		}
		path_init(&open->v[c]);
		dst = paths_add(loops);
		if (!dst) {
			path_fini(&g);
			rc = ERR_SET(e, ERR_NOMEM, "out of memory joining contour chains");
			goto out;
		}
		*dst = g;
	}
out:
	paths_clear(open);
	mem_free(hs.h);
	mem_free(hs.slot);
	mem_free(hs.right);
	mem_free(hs.left);
	mem_free(used);
	mem_free(hs.dead);
	mem_free(hs.byhole);
	return rc;
}
