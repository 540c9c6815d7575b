/* transient.c - transient structures between the hybrid engine's MFS and
 * TCS interiors (paper 003, section 6; contract in hybrid.h): the
 * transient layer with its floating regions bridged to the largest one
 * (6.1), and the extended-support region (6.2).  Method, the reading of
 * the paper's missing formula and the deviations: docs/hybrid.md,
 * "Transient structures".
 *
 * Images are w x h bytes, row stride w, pixel (x, y) at index y w + x; a
 * pixel's centre is at (x, y) in pixel units, distances are between
 * centres.  Connectivity is 8-connected throughout (geom/label.h).
 */
#include "engine/hybrid/structure.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"
#include "engine/geom/label.h"

/* Images are indexed by int32 (the EDT's feature transform). */
#define HY_MAX_PIXELS ((size_t)INT32_MAX)

static int check_image(int w, int h, struct err *e)
{
	if (w < 1 || h < 1 || (size_t)w * (size_t)h > HY_MAX_PIXELS)
		return ERR_FIELD(e, "size", "hybrid: image %d x %d out of range", w, h);
	return 0;
}

/* Scratch of the bridge painter: a disc stamp, pixel marks and lists. */
struct bridge {
	int w, h;
	uint8_t *us;         /* the layer being bridged (written) */
	const uint8_t *mask; /* where material may go */
	const uint8_t *lane; /* where a centre line may run: pixels of US, and mask
	                      pixels whose whole disc of radius r is on the mask */
	uint8_t *mark;       /* w h, 0 between uses: 1 = candidate, 2 = painted */
	int32_t (*disc)[2];  /* offsets (dx, dy) with dx^2 + dy^2 <= r^2 */
	size_t ndisc;
	int32_t *marked; /* pixels with mark != 0, to clear them */
	size_t nmarked, cap_marked;
	int32_t *stack; /* flood stack */
	size_t cap_stack;
	int32_t *path; /* centre line of the current bridge */
	size_t npath, cap_path;
};

static int push(int32_t **arr, size_t *n, size_t *cap, int32_t v)
{
	void *p = *arr;
	if (*n == *cap && mem_grow(&p, cap, *n + 1, sizeof **arr))
		return ERR_NOMEM;
	*arr = p;
	(*arr)[(*n)++] = v;
	return 0;
}

static int bridge_init(struct bridge *b, uint8_t *us, const uint8_t *mask, int w, int h,
                       double bridge_px)
{
	/* offsets beyond the image's extent never land on it */
	double r = fmin(bridge_px / 2, (double)(w > h ? w : h));
	int ri = (int)floor(r), rx = ri < w - 1 ? ri : w - 1, ry = ri < h - 1 ? ri : h - 1;

	memset(b, 0, sizeof *b);
	b->w = w;
	b->h = h;
	b->us = us;
	b->mask = mask;
	b->mark = mem_calloc((size_t)w * (size_t)h, 1);
	b->disc = mem_realloc_array(
	    NULL, ((size_t)2 * (size_t)rx + 1) * ((size_t)2 * (size_t)ry + 1), sizeof *b->disc);
	if (!b->mark || !b->disc)
		return ERR_NOMEM;
	for (int dy = -ry; dy <= ry; dy++)
		for (int dx = -rx; dx <= rx; dx++)
			if ((double)dx * dx + (double)dy * dy <= r * r * (1 + 1e-12)) {
				b->disc[b->ndisc][0] = dx;
				b->disc[b->ndisc][1] = dy;
				b->ndisc++;
			}
	return 0;
}

static void bridge_fini(struct bridge *b)
{
	mem_free(b->mark);
	mem_free(b->disc);
	mem_free(b->marked);
	mem_free(b->stack);
	mem_free(b->path);
}

/* Paint the bridge along b->path (8-connected pixels, all on the mask):
 * every pixel of the mask within r of a path pixel's centre that is
 * connected to the path inside that set.  So each path pixel is the
 * centre of a painted disc of diameter bridge_px wherever the mask
 * allows, and nothing painted floats. */
static int bridge_paint(struct bridge *b)
{
	size_t sp = 0;
	int rc = 0;

	b->nmarked = 0;
	for (size_t k = 0; k < b->npath; k++) {
		int px = b->path[k] % b->w, py = b->path[k] / b->w;
		for (size_t d = 0; d < b->ndisc; d++) {
			int x = px + b->disc[d][0], y = py + b->disc[d][1];
			int32_t i;
			if (x < 0 || y < 0 || x >= b->w || y >= b->h)
				continue;
			i = y * b->w + x;
			if (b->mark[i] || !b->mask[i])
				continue;
			b->mark[i] = 1;
			if ((rc = push(&b->marked, &b->nmarked, &b->cap_marked, i)) != 0)
				goto out;
		}
	}
	for (size_t k = 0; k < b->npath; k++) {
		int32_t i = b->path[k];
		if (b->mark[i] == 2)
			continue;
		b->mark[i] = 2;
		b->us[i] = 1;
		if ((rc = push(&b->stack, &sp, &b->cap_stack, i)) != 0)
			goto out;
		while (sp) {
			int32_t q = b->stack[--sp];
			int qx = q % b->w, qy = q / b->w;
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					int x = qx + dx, y = qy + dy;
					int32_t j;
					if (x < 0 || y < 0 || x >= b->w || y >= b->h)
						continue;
					j = y * b->w + x;
					if (b->mark[j] != 1)
						continue;
					b->mark[j] = 2;
					b->us[j] = 1;
					if ((rc = push(&b->stack, &sp, &b->cap_stack, j)) != 0)
						goto out;
				}
		}
	}
out:
	for (size_t k = 0; k < b->nmarked; k++)
		b->mark[b->marked[k]] = 0;
	return rc;
}

/* The digital straight segment from pixel p to pixel q (Bresenham,
 * 8-connected) into b->path; *ok = 1 when every pixel of it is on a lane. */
static int straight_path(struct bridge *b, int32_t p, int32_t q, int *ok)
{
	int x0 = p % b->w, y0 = p / b->w, x1 = q % b->w, y1 = q / b->w;
	int dx = abs(x1 - x0), dy = -abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
	int err = dx + dy;

	b->npath = 0;
	*ok = 1;
	for (;;) {
		int32_t i = y0 * b->w + x0;
		if (!b->lane[i])
			*ok = 0;
		if (push(&b->path, &b->npath, &b->cap_path, i))
			return ERR_NOMEM;
		if (x0 == x1 && y0 == y1)
			return 0;
		int e2 = 2 * err; /* both tests against the same error */
		if (e2 >= dy) {
			err += dy;
			x0 += sx;
		}
		if (e2 <= dx) {
			err += dx;
			y0 += sy;
		}
	}
}

/* Components l of US with pending[l] set are joined along shortest
 * 8-connected paths (in steps) from the largest component `big`: one
 * breadth-first search from all of its pixels through the lanes, then,
 * for those it did not reach, one through every mask pixel (the bridge
 * then runs nearer the mask's edge than r, narrower there).  A component
 * that no mask path reaches stays as it is; pending[l] is cleared for
 * those joined.  O(w h) per search plus the painting. */
static int geodesic_bridges(struct bridge *b, const int32_t *lab, int32_t big, int32_t count,
                            uint8_t *pending, struct err *e)
{
	size_t n = (size_t)b->w * (size_t)b->h;
	int32_t *parent = mem_alloc(n * sizeof *parent), *queue = mem_alloc(n * sizeof *queue);
	int32_t *contact = mem_alloc(((size_t)count + 1) * sizeof *contact);
	int rc = 0;

	if (!parent || !queue || !contact)
		goto nomem;
	for (int pass = 0; pass < 2; pass++) {
		const uint8_t *allowed = pass == 0 ? b->lane : b->mask;
		size_t head = 0, tail = 0;
		int left = 0;
		for (int32_t l = 0; l <= count; l++) {
			contact[l] = -1;
			left |= pending[l];
		}
		if (!left)
			break;
		for (size_t i = 0; i < n; i++) {
			parent[i] = -1;
			if (lab[i] == big) {
				parent[i] = (int32_t)i;
				queue[tail++] = (int32_t)i;
			}
		}
		while (head < tail) {
			int32_t q = queue[head++];
			int qx = q % b->w, qy = q / b->w;
			if (lab[q] && pending[lab[q]] && contact[lab[q]] < 0)
				contact[lab[q]] = q;
			for (int dy = -1; dy <= 1; dy++)
				for (int dx = -1; dx <= 1; dx++) {
					int x = qx + dx, y = qy + dy;
					int32_t j;
					if (x < 0 || y < 0 || x >= b->w || y >= b->h)
						continue;
					j = y * b->w + x;
					if (parent[j] >= 0 || !allowed[j])
						continue;
					parent[j] = q;
					queue[tail++] = j; /* each pixel once: tail <= n */
				}
		}
		for (int32_t l = 1; l <= count; l++) {
			int32_t i = contact[l];
			if (!pending[l] || i < 0)
				continue;
			b->npath = 0;
			for (;;) {
				if (push(&b->path, &b->npath, &b->cap_path, i))
					goto nomem;
				if (parent[i] == i)
					break;
				i = parent[i];
			}
			if (bridge_paint(b))
				goto nomem;
			pending[l] = 0;
		}
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hybrid: out of memory (transient bridges)");
out:
	mem_free(parent);
	mem_free(queue);
	mem_free(contact);
	return rc;
}

/* lane[i] (see struct bridge) from the distance of every pixel to the
 * nearest pixel off the mask; the image's edge counts as off the mask. */
static int lanes(const uint8_t *mask, const int32_t *lab, int w, int h, double r, uint8_t *lane,
                 uint8_t *scratch, float *d2, struct edt_scratch *es, struct err *e)
{
	size_t n = (size_t)w * (size_t)h;
	int rc;

	for (size_t i = 0; i < n; i++)
		scratch[i] = !mask[i];
	if ((rc = edt_sq(scratch, (size_t)w, w, h, 1.0, 1.0, d2, es, e)) != 0)
		return rc;
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			double edge =
			    fmin(fmin(x + 1.0, y + 1.0), fmin((double)(w - x), (double)(h - y)));
			lane[i] = lab[i] != 0 || (mask[i] && d2[i] > r * r && edge > r);
		}
	return 0;
}

int hy_transient_layer(const uint8_t *mfs, const uint8_t *tcs, const uint8_t *mask, int w, int h,
                       double bridge_px, uint8_t *us, struct err *e)
{
	size_t n, *size = NULL;
	int32_t *lab = NULL, *near = NULL, *best = NULL, count = 0, big = 0;
	uint8_t *seed = NULL, *pending = NULL, *lane = NULL;
	float *d2 = NULL;
	struct edt_scratch es;
	struct bridge b;
	int rc;

	if ((rc = check_image(w, h, e)) != 0)
		return rc;
	if (!mfs || !tcs || !mask || !us)
		return ERR_FIELD(e, "image", "hybrid: transient layer needs mfs, tcs, mask and us");
	if (!(bridge_px > 0) || !isfinite(bridge_px))
		return ERR_FIELD(e, "bridge_px", "hybrid: bridge width %g px must be > 0",
		                 bridge_px);
	n = (size_t)w * (size_t)h;
	edt_scratch_init(&es);
	memset(&b, 0, sizeof b);

	/* US = (S_MFS | S_TCS), clipped to the part's section */
	for (size_t i = 0; i < n; i++)
		us[i] = (mfs[i] || tcs[i]) && mask[i];
	lab = mem_alloc(n * sizeof *lab);
	if (!lab)
		goto nomem;
	if ((rc = label_components8(us, w, h, lab, &count, e)) != 0)
		goto out;
	if (count <= 1)
		goto out; /* one region (or none): nothing to connect */

	/* R_1^1: the largest region (the first in raster order on ties) */
	size = mem_alloc(((size_t)count + 1) * sizeof *size);
	if (!size)
		goto nomem;
	label_sizes(lab, n, count, size);
	big = 1;
	for (int32_t l = 2; l <= count; l++)
		if (size[l] > size[big])
			big = l;

	/* each other region's pixel nearest to R_1^1 (first in raster order
	 * on ties) and the R_1^1 pixel nearest to it */
	seed = mem_alloc(n);
	d2 = mem_alloc(n * sizeof *d2);
	near = mem_alloc(n * sizeof *near);
	best = mem_alloc(((size_t)count + 1) * sizeof *best);
	pending = mem_calloc((size_t)count + 1, 1);
	if (!seed || !d2 || !near || !best || !pending)
		goto nomem;
	for (size_t i = 0; i < n; i++)
		seed[i] = lab[i] == big;
	if ((rc = edt_nearest_sq(seed, (size_t)w, w, h, 1.0, 1.0, d2, near, &es, e)) != 0)
		goto out;
	for (int32_t l = 0; l <= count; l++)
		best[l] = -1;
	for (size_t i = 0; i < n; i++) {
		int32_t l = lab[i];
		if (l && l != big && (best[l] < 0 || d2[i] < d2[best[l]]))
			best[l] = (int32_t)i;
	}

	/* straight bridges where their centre line runs on lanes, the others
	 * around obstacles (seed and d2 are free again: scratch for lanes) */
	lane = mem_alloc(n);
	if (!lane)
		goto nomem;
	if ((rc = lanes(mask, lab, w, h, bridge_px / 2, lane, seed, d2, &es, e)) != 0)
		goto out;
	if (bridge_init(&b, us, mask, w, h, bridge_px))
		goto nomem;
	b.lane = lane;
	{
		int any_pending = 0;
		for (int32_t l = 1; l <= count; l++) {
			int ok;
			if (l == big)
				continue;
			if (straight_path(&b, best[l], near[best[l]], &ok))
				goto nomem;
			if (!ok) {
				pending[l] = 1;
				any_pending = 1;
				continue;
			}
			if (bridge_paint(&b))
				goto nomem;
		}
		if (any_pending)
			rc = geodesic_bridges(&b, lab, big, count, pending, e);
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hybrid: out of memory (transient layer %d x %d)", w, h);
out:
	bridge_fini(&b);
	edt_scratch_fini(&es);
	mem_free(lab);
	mem_free(size);
	mem_free(seed);
	mem_free(d2);
	mem_free(near);
	mem_free(best);
	mem_free(pending);
	mem_free(lane);
	return rc;
}

int hy_support_region(const uint8_t *tcs_proj, const uint8_t *us, int w, int h, size_t min_px,
                      uint8_t *out, struct err *e)
{
	size_t n, *size = NULL;
	int32_t *lab = NULL, count = 0;
	int rc;

	if ((rc = check_image(w, h, e)) != 0)
		return rc;
	if (!tcs_proj || !us || !out)
		return ERR_FIELD(e, "image", "hybrid: support region needs tcs_proj, us and out");
	n = (size_t)w * (size_t)h;
	/* element by element first, so out may alias either input */
	for (size_t i = 0; i < n; i++)
		out[i] = tcs_proj[i] && us[i];
	lab = mem_alloc(n * sizeof *lab);
	if (!lab) {
		rc = ERR_SET(e, ERR_NOMEM, "hybrid: out of memory (support region %d x %d)", w, h);
		goto out;
	}
	if ((rc = label_components8(out, w, h, lab, &count, e)) != 0)
		goto out;
	size = mem_alloc(((size_t)count + 1) * sizeof *size);
	if (!size) {
		rc = ERR_SET(e, ERR_NOMEM, "hybrid: out of memory (support region %d x %d)", w, h);
		goto out;
	}
	label_sizes(lab, n, count, size);
	for (size_t i = 0; i < n; i++)
		if (lab[i] && size[lab[i]] < min_px)
			out[i] = 0;
out:
	mem_free(lab);
	mem_free(size);
	return rc;
}
