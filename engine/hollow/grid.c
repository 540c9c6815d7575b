/* grid.c - pixel-grid helpers of the top-down fill: row runs of masks,
 * 8-connected labelling and the nearest-seed label transform (exact
 * Euclidean distances between pixel centres).  See grid.h.
 */
#include "engine/hollow/grid.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

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
	float *g = mem_alloc((np + 1) * sizeof *g);
	int32_t *ax = mem_alloc((np + 1) * sizeof *ax);
	int *v = mem_alloc(((size_t)h + 1) * sizeof *v);
	double *z = mem_alloc(((size_t)h + 2) * sizeof *z);
	double py2 = py_mm * py_mm;

	if (!g || !ax || !v || !z) {
		mem_free(g);
		mem_free(ax);
		mem_free(v);
		mem_free(z);
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill distances)");
	}
	/* rows: nearest seed column by a left and a right scan */
	for (int y = 0; y < h; y++) {
		const int32_t *l = lab + (size_t)y * (size_t)w;
		float *gr = g + (size_t)y * (size_t)w;
		int32_t *ar = ax + (size_t)y * (size_t)w;
		int last = -1;
		for (int x = 0; x < w; x++) {
			if (l[x])
				last = x;
			ar[x] = last;
		}
		last = -1;
		for (int x = w - 1; x >= 0; x--) {
			if (l[x])
				last = x;
			if (last >= 0 && (ar[x] < 0 || last - x < x - ar[x]))
				ar[x] = last;
			gr[x] = ar[x] < 0 ? INFINITY
					  : (float)((x - ar[x]) * (x - ar[x]) * px_mm * px_mm);
		}
	}
	/* columns: lower envelope of the parabolas g(q) + py^2 (y - q)^2 */
	for (int x = 0; x < w; x++) {
		int k = -1;
		for (int q = 0; q < h; q++) {
			double fq = g[(size_t)q * (size_t)w + (size_t)x], s = 0;
			if (!isfinite(fq))
				continue;
			while (k >= 0) {
				int r = v[k];
				double fr = g[(size_t)r * (size_t)w + (size_t)x];
				s = ((fq + py2 * q * q) - (fr + py2 * r * r)) / (2 * py2 * (q - r));
				if (s > z[k])
					break;
				k--;
			}
			if (k < 0) {
				k = 0;
				v[0] = q;
				z[0] = -INFINITY;
			} else {
				k++;
				v[k] = q;
				z[k] = s;
			}
			z[k + 1] = INFINITY;
		}
		for (int y = 0, j = 0; y < h; y++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			if (k < 0) {
				d2[i] = INFINITY;
				near[i] = 0;
				continue;
			}
			while (j < k && z[j + 1] < y)
				j++;
			{
				int q = v[j];
				size_t iq = (size_t)q * (size_t)w + (size_t)x;
				d2[i] = (float)(g[iq] + py2 * (y - q) * (y - q));
				near[i] = lab[(size_t)q * (size_t)w + (size_t)ax[iq]];
			}
		}
	}
	mem_free(g);
	mem_free(ax);
	mem_free(v);
	mem_free(z);
	return 0;
}
