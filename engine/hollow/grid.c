/* grid.c - pixel-grid helpers of the top-down fill: row runs of masks,
 * 8-connected labelling and the nearest-seed label transform (exact
 * Euclidean distances between pixel centres).  See grid.h.
 */
#include "engine/hollow/grid.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"

int hl_grid_runs(const uint8_t *mask, int w, int x0, int y0, int x1, int y1,
		 struct hl_run **runs, size_t *n, size_t *cap, struct err *e)
{
	for (int y = y0; y < y1; y++) {
		const uint8_t *m = mask + (size_t)y * (size_t)w;
		int x = x0;
		while (x < x1) {
			int s;
			void *arr = *runs;
			while (x < x1 && !m[x])
				x++;
			if (x >= x1)
				break;
			s = x;
			while (x < x1 && m[x])
				x++;
			if (mem_grow(&arr, cap, *n + 1, sizeof **runs))
				return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill runs)");
			*runs = arr;
			(*runs)[*n].y = y;
			(*runs)[*n].x0 = s;
			(*runs)[*n].x1 = x - 1;
			(*runs)[*n].comp = 0;
			(*n)++;
		}
	}
	return 0;
}

void hl_grid_paint(uint8_t *mask, int w, const struct hl_run *runs, size_t n, uint8_t val)
{
	for (size_t i = 0; i < n; i++)
		memset(mask + (size_t)runs[i].y * (size_t)w + runs[i].x0, val,
		       (size_t)(runs[i].x1 - runs[i].x0 + 1));
}

/* Union-find over labels (path halving). */
static int32_t uf_root(int32_t *p, int32_t i)
{
	while (p[i] != i) {
		p[i] = p[p[i]];
		i = p[i];
	}
	return i;
}

int hl_grid_label(const uint8_t *mask, int w, int h, int32_t *lab, int32_t *count,
		  struct err *e)
{
	size_t np = (size_t)w * (size_t)h;
	int32_t *par = NULL, next = 1;
	size_t cap = 0;

	/* first pass: provisional labels from the W, NW, N, NE neighbours */
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			int32_t best = 0;
			static const int dx[4] = {-1, -1, 0, 1}, dy[4] = {0, -1, -1, -1};
			lab[i] = 0;
			if (!mask[i])
				continue;
			for (int q = 0; q < 4; q++) {
				int xx = x + dx[q], yy = y + dy[q];
				int32_t l;
				if (xx < 0 || xx >= w || yy < 0)
					continue;
				l = lab[(size_t)yy * (size_t)w + (size_t)xx];
				if (!l)
					continue;
				if (!best) {
					best = l;
				} else {
					int32_t a = uf_root(par, best), b = uf_root(par, l);
					if (a != b)
						par[a > b ? a : b] = a < b ? a : b;
				}
			}
			if (!best) {
				void *arr = par;
				if (next == INT32_MAX ||
				    mem_grow(&arr, &cap, (size_t)next + 1, sizeof *par)) {
					mem_free(par);
					return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill labels)");
				}
				par = arr;
				par[next] = next;
				best = next++;
			}
			lab[i] = best;
		}
	/* second pass: roots, renumbered 1..count */
	{
		int32_t c = 0;
		int32_t *ren = mem_calloc((size_t)next + 1, sizeof *ren);
		if (!ren) {
			mem_free(par);
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill labels)");
		}
		for (int32_t l = 1; l < next; l++) {
			int32_t r = uf_root(par, l);
			if (!ren[r])
				ren[r] = ++c;
		}
		for (size_t i = 0; i < np; i++)
			if (lab[i])
				lab[i] = ren[uf_root(par, lab[i])];
		*count = c;
		mem_free(ren);
	}
	mem_free(par);
	return 0;
}

int hl_grid_nearest(const int32_t *lab, int w, int h, double px_mm, double py_mm, float *d2,
		    int32_t *near, struct err *e)
{
	size_t np = (size_t)w * (size_t)h;
	uint8_t *seed = mem_alloc(np + 1);
	int32_t *idx = mem_alloc((np + 1) * sizeof *idx);
	struct edt_scratch es;
	int rc;

	edt_scratch_init(&es);
	if (!seed || !idx) {
		mem_free(seed);
		mem_free(idx);
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill distances)");
	}
	for (size_t i = 0; i < np; i++)
		seed[i] = lab[i] != 0;
	rc = edt_nearest_sq(seed, (size_t)w, w, h, px_mm, py_mm, d2, idx, &es, e);
	for (size_t i = 0; !rc && i < np; i++)
		near[i] = idx[i] < 0 ? 0 : lab[idx[i]];
	edt_scratch_fini(&es);
	mem_free(seed);
	mem_free(idx);
	return rc;
}
