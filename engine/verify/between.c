/* between.c - in-layer walls between pairs of void components (see
 * between.h).
 *
 * Why touching regions suffice.  Let A, B be two labels' pixel sets with
 * closest pair (a, b), distance d, and m the midpoint of ab.  If a pixel
 * of a third set C lay closer to m than d / 2, then |a - c| < d and
 * |c - b| < d: C is closer to both than they are to each other.  The
 * caller's minimum is over pairs that end up in different 3D cavities,
 * and C is in a different cavity from at least one of A and B, so that
 * pair reads less than d anyway.  Otherwise m is on the boundary between
 * A's and B's regions, and the pixels astride it have a and b (or pairs
 * as close) as their nearest seeds: a point p on ab has no pixel of A
 * nearer than a (else that pixel would be closer than d to b).
 */
#include "engine/verify/between.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

void verify_between_init(struct verify_between *s)
{
	memset(s, 0, sizeof *s);
	edt_scratch_init(&s->es);
}

void verify_between_fini(struct verify_between *s)
{
	mem_free(s->near);
	mem_free(s->d2);
	mem_free(s->pairs);
	edt_scratch_fini(&s->es);
	memset(s, 0, sizeof *s);
}

static int cmp_pair(const void *x, const void *y)
{
	const struct verify_pair *p = x, *q = y;

	if (p->a != q->a)
		return p->a < q->a ? -1 : 1;
	if (p->b != q->b)
		return p->b < q->b ? -1 : 1;
	return (p->d_mm > q->d_mm) - (p->d_mm < q->d_mm);
}

static int add(struct verify_between *s, uint32_t a, uint32_t b, double d_mm)
{
	if (s->n == s->pcap) {
		void *arr = s->pairs;
		if (mem_grow(&arr, &s->pcap, s->n + 1, sizeof *s->pairs))
			return ERR_NOMEM;
		s->pairs = arr;
	}
	s->pairs[s->n].a = a < b ? a : b;
	s->pairs[s->n].b = a < b ? b : a;
	s->pairs[s->n].d_mm = d_mm;
	s->n++;
	return 0;
}

int verify_between_pairs(const uint8_t *seed, const uint32_t *lab, int w, int h, double px_mm,
                         double py_mm, struct verify_between *s, struct err *e)
{
	/* right, down, down-right, down-left: each 8-neighbour pair once */
	static const int dir[4][2] = {{1, 0}, {0, 1}, {1, 1}, {-1, 1}};
	size_t np = (size_t)w * (size_t)h, k = 0;

	s->n = 0;
	if (np > s->cap) {
		mem_free(s->near);
		mem_free(s->d2);
		s->near = mem_alloc(np * sizeof *s->near);
		s->d2 = mem_alloc(np * sizeof *s->d2);
		s->cap = s->near && s->d2 ? np : 0;
		if (!s->cap)
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory (walls between voids)");
	}
	if (edt_nearest_sq(seed, (size_t)w, w, h, px_mm, py_mm, s->d2, s->near, &s->es, e))
		return ERR_NOMEM;
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			int32_t ni = s->near[(size_t)y * (size_t)w + (size_t)x];
			if (ni < 0)
				continue;
			for (int q = 0; q < 4; q++) {
				int x2 = x + dir[q][0], y2 = y + dir[q][1];
				int32_t nj;
				double dx, dy;
				if (x2 < 0 || x2 >= w || y2 >= h)
					continue;
				nj = s->near[(size_t)y2 * (size_t)w + (size_t)x2];
				if (nj < 0 || lab[ni] == lab[nj])
					continue;
				dx = (double)(ni % w - nj % w) * px_mm;
				dy = (double)(ni / w - nj / w) * py_mm;
				if (add(s, lab[ni], lab[nj], sqrt(dx * dx + dy * dy)))
					return ERR_SET(
					    e, ERR_NOMEM,
					    "verify: out of memory (walls between voids)");
			}
		}
	if (!s->n)
		return 0;
	/* one entry per pair: its smallest distance (sorted first) */
	qsort(s->pairs, s->n, sizeof *s->pairs, cmp_pair);
	for (size_t i = 0; i < s->n; i++)
		if (!k || s->pairs[i].a != s->pairs[k - 1].a || s->pairs[i].b != s->pairs[k - 1].b)
			s->pairs[k++] = s->pairs[i];
	s->n = k;
	return 0;
}
