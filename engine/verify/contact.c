/* contact.c - the reference part's own islands (contact.h).
 *
 * Where the solid part itself starts in the air (an overhanging chin's
 * lowest layer) it needs supports whatever fills it: an island of the
 * checked stack touching one of the part's own islands is the part's, any
 * other is one the engine added.  Per layer: the reference's 8-connected
 * solid components over the bounding box of its solid, flooded with an
 * explicit list, O(box pixels).
 */
#include "engine/verify/contact.h"

#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/raster.h"

void verify_contact_init(struct verify_contact *c)
{
	memset(c, 0, sizeof *c);
	c->bx1 = c->by1 = -1;
}

void verify_contact_fini(struct verify_contact *c)
{
	mem_free(c->prev);
	mem_free(c->cur);
	mem_free(c->fc);
	mem_free(c->list);
	verify_contact_init(c);
}

/* Flood the component of pixel i0 (solid in cur, not yet in fc's seen
 * bit 2) into c->list; 1 when some pixel has solid below. */
static int flood(struct verify_contact *c, size_t i0, size_t *len)
{
	size_t n = 0, head = 0;
	int supported = 0, w = c->w, h = c->h;

	c->list[n++] = (uint32_t)i0;
	c->fc[i0] = 2; /* seen */
	while (head < n) {
		size_t q = c->list[head++];
		int qx = (int)(q % (size_t)w), qy = (int)(q / (size_t)w);
		supported |= c->layers > 0 && c->prev[q];
		for (int dy = -1; dy <= 1; dy++)
			for (int dx = -1; dx <= 1; dx++) {
				int nx = qx + dx, ny = qy + dy;
				size_t j;
				if (nx < 0 || ny < 0 || nx >= w || ny >= h)
					continue;
				j = (size_t)ny * (size_t)w + (size_t)nx;
				if (!c->cur[j] || c->fc[j])
					continue;
				c->fc[j] = 2;
				c->list[n++] = (uint32_t)j; /* each pixel once: n <= w h */
			}
	}
	*len = n;
	return supported || c->layers == 0; /* layer 0 stands on the plate */
}

int verify_contact_layer(struct verify_contact *c, const struct raster *ref, int threshold)
{
	size_t n = (size_t)ref->w * (size_t)ref->h;
	int x0 = ref->w, y0 = ref->h, x1 = -1, y1 = -1;

	if (c->layers == 0) {
		c->w = ref->w;
		c->h = ref->h;
		c->prev = mem_calloc(n, 1);
		c->cur = mem_alloc(n);
		c->fc = mem_calloc(n, 1);
		c->list = mem_alloc(n * sizeof *c->list);
		if (!c->prev || !c->cur || !c->fc || !c->list)
			return ERR_NOMEM;
	} else if (ref->w != c->w || ref->h != c->h) {
		return -1;
	}
	/* clear the last layer's marks over its box, threshold this layer */
	for (int y = c->by0; y <= c->by1; y++)
		memset(c->fc + (size_t)y * (size_t)c->w + c->bx0, 0, (size_t)(c->bx1 - c->bx0 + 1));
	for (int y = 0; y < ref->h; y++) {
		const uint8_t *row = ref->px + (size_t)y * ref->stride;
		uint8_t *cu = c->cur + (size_t)y * (size_t)c->w;
		for (int x = 0; x < ref->w; x++) {
			cu[x] = row[x] >= threshold;
			if (cu[x]) {
				x0 = x < x0 ? x : x0;
				x1 = x > x1 ? x : x1;
				y0 = y < y0 ? y : y0;
				y1 = y > y1 ? y : y1;
			}
		}
	}
	/* fc: 2 while flooding (seen), then 1 on the pixels of islands */
	for (int y = y0; y <= y1; y++)
		for (int x = x0; x <= x1; x++) {
			size_t i = (size_t)y * (size_t)c->w + (size_t)x, len;
			if (!c->cur[i] || c->fc[i])
				continue;
			if (!flood(c, i, &len))
				for (size_t k = 0; k < len; k++)
					c->fc[c->list[k]] = 1;
		}
	c->bx0 = x0;
	c->by0 = y0;
	c->bx1 = x1;
	c->by1 = y1;
	{
		uint8_t *t = c->prev;
		c->prev = c->cur;
		c->cur = t;
	}
	c->layers++;
	return 0;
}

int verify_contact_near(const struct verify_contact *c, int x, int y, int tol_px)
{
	for (int yy = y - tol_px; yy <= y + tol_px; yy++) {
		if (yy < 0 || yy >= c->h)
			continue;
		for (int xx = x - tol_px; xx <= x + tol_px; xx++)
			if (xx >= 0 && xx < c->w && c->fc[(size_t)yy * (size_t)c->w + (size_t)xx] == 1)
				return 1;
	}
	return 0;
}
