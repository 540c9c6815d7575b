/* label.c - connected components of binary pixel images (label.h).
 *
 * First pass: provisional labels from the W, NW, N, NE neighbours, unions
 * recorded in a parent array whose roots are always the smallest label of
 * their set; second pass: roots renumbered 1..count in increasing order,
 * which is raster order of each component's first pixel.
 */
#include "engine/geom/label.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* Union-find over labels (path halving). */
static int32_t uf_root(int32_t *p, int32_t i)
{
	while (p[i] != i) {
		p[i] = p[p[i]];
		i = p[i];
	}
	return i;
}

int label_components8(const uint8_t *mask, int w, int h, int32_t *lab, int32_t *count,
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
					return ERR_SET(e, ERR_NOMEM,
					               "label: out of memory (%d x %d image)", w,
					               h);
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
			return ERR_SET(e, ERR_NOMEM, "label: out of memory (%d x %d image)", w, h);
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

void label_sizes(const int32_t *lab, size_t n, int32_t count, size_t *size)
{
	for (int32_t l = 0; l <= count; l++)
		size[l] = 0;
	for (size_t i = 0; i < n; i++)
		size[lab[i]]++;
}
