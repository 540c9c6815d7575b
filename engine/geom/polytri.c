/* polytri.c - ear clipping (see polytri.h). */
#include "engine/geom/polytri.h"

#include <math.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

static double orient(const double *xy, uint32_t a, uint32_t b, uint32_t c)
{
	return (xy[2 * b] - xy[2 * a]) * (xy[2 * c + 1] - xy[2 * a + 1]) -
	       (xy[2 * b + 1] - xy[2 * a + 1]) * (xy[2 * c] - xy[2 * a]);
}

/* p inside or on triangle abc (counter-clockwise). */
static int in_tri(const double *xy, uint32_t a, uint32_t b, uint32_t c, uint32_t p)
{
	return orient(xy, a, b, p) >= 0 && orient(xy, b, c, p) >= 0 && orient(xy, c, a, p) >= 0;
}

static int same_pt(const double *xy, uint32_t a, uint32_t b)
{
	return xy[2 * a] == xy[2 * b] && xy[2 * a + 1] == xy[2 * b + 1];
}

/* Ear test: convex corner whose triangle holds no other remaining vertex
 * (vertices coinciding with a corner do not block it). */
static int is_ear(const double *xy, const uint32_t *prv, const uint32_t *nxt, uint32_t i)
{
	uint32_t a = prv[i], c = nxt[i];

	if (orient(xy, a, i, c) <= 0)
		return 0;
	for (uint32_t k = nxt[c]; k != a; k = nxt[k]) {
		if (same_pt(xy, k, a) || same_pt(xy, k, i) || same_pt(xy, k, c))
			continue;
		if (in_tri(xy, a, i, c, k))
			return 0;
	}
	return 1;
}

int polytri_ears(const double *xy, size_t n, uint32_t *tri, struct err *e)
{
	uint32_t *prv, *nxt;
	size_t left = n, nt = 0;
	uint32_t cur = 0;

	if (n < 3)
		return ERR_SET(e, ERR_PARAM, "polygon triangulation needs 3 vertices, got %zu", n);
	prv = mem_alloc(n * sizeof *prv);
	nxt = mem_alloc(n * sizeof *nxt);
	if (!prv || !nxt) {
		mem_free(prv);
		mem_free(nxt);
		return ERR_SET(e, ERR_NOMEM, "polygon triangulation: out of memory");
	}
	for (size_t i = 0; i < n; i++) {
		prv[i] = (uint32_t)((i + n - 1) % n);
		nxt[i] = (uint32_t)((i + 1) % n);
	}
	while (left > 3) {
		uint32_t i = cur, found = UINT32_MAX;
		for (size_t k = 0; k < left; k++, i = nxt[i])
			if (is_ear(xy, prv, nxt, i)) {
				found = i;
				break;
			}
		if (found == UINT32_MAX) {
			/* No proper ear (degenerate or self-intersecting rest):
			 * clip the most convex corner so the count stays n - 2. */
			double best = -INFINITY;
			i = cur;
			for (size_t k = 0; k < left; k++, i = nxt[i]) {
				double o = orient(xy, prv[i], i, nxt[i]);
				if (o > best) {
					best = o;
					found = i;
				}
			}
		}
		tri[3 * nt] = prv[found];
		tri[3 * nt + 1] = found;
		tri[3 * nt + 2] = nxt[found];
		nt++;
		nxt[prv[found]] = nxt[found];
		prv[nxt[found]] = prv[found];
		cur = prv[found];
		left--;
	}
	tri[3 * nt] = prv[cur];
	tri[3 * nt + 1] = cur;
	tri[3 * nt + 2] = nxt[cur];
	mem_free(prv);
	mem_free(nxt);
	return 0;
}
