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

	/* first pass: provisional labels from the W, NW, N, NE neighbours.
	 * N touches the other three (8-connected), so when N is labelled
	 * they already share its set; else NW touches W, and only NE can
	 * join another set (to NW's or W's) */
	for (int y = 0; y < h; y++) {
		const uint8_t *m = mask + (size_t)y * (size_t)w;
		int32_t *l = lab + (size_t)y * (size_t)w;
		const int32_t *u = y > 0 ? l - w : NULL; /* the row above */
		for (int x = 0; x < w; x++) {
			int32_t n = 0, nw = 0, ne = 0, wl = x > 0 ? l[x - 1] : 0, best;
			l[x] = 0;
			if (!m[x])
				continue;
			if (u) {
				n = u[x];
				nw = x > 0 ? u[x - 1] : 0;
				ne = x + 1 < w ? u[x + 1] : 0;
			}
			if (n) {
				best = n;
			} else if (nw || wl) {
				best = nw ? nw : wl;
				if (ne) {
					int32_t a = uf_root(par, best), b = uf_root(par, ne);
					if (a != b)
						par[a > b ? a : b] = a < b ? a : b;
				}
			} else if (ne) {
				best = ne;
			} else {
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
			l[x] = best;
		}
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
