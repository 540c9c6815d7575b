/* contact.c - the reference part's own islands (contact.h).
 *
 * Where the solid part itself starts in the air (an overhanging chin's
 * lowest layer) it needs supports whatever fills it: an island of the
 * checked stack touching one of the part's own islands is the part's, any
 * other is one the engine added.  Per layer: the reference's solid over
 * the bounding box of its solid, its 8-connected components labelled
 * there (engine/geom/label.h), those with no pixel over the layer below's
 * solid marked; O(box pixels), with empty rows skipped a word at a time.
 */
#include "engine/verify/contact.h"

#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/label.h"
#include "engine/geom/raster.h"

void verify_contact_init(struct verify_contact *c)
{
	memset(c, 0, sizeof *c);
	c->bx1 = c->by1 = c->cx1 = c->cy1 = -1;
}

void verify_contact_fini(struct verify_contact *c)
{
	mem_free(c->prev);
	mem_free(c->cur);
	mem_free(c->fc);
	mem_free(c->mask);
	mem_free(c->lab);
	mem_free(c->sup);
	verify_contact_init(c);
}

/* Clear rows y0..y1, columns x0..x1 of the w-wide image a (nothing when
 * x1 < 0). */
static void clear_box(uint8_t *a, int w, int x0, int y0, int x1, int y1)
{
	for (int y = y0; x1 >= 0 && y <= y1; y++)
		memset(a + (size_t)y * (size_t)w + x0, 0, (size_t)(x1 - x0 + 1));
}

int verify_contact_layer(struct verify_contact *c, const struct raster *ref, int threshold)
{
	size_t n = (size_t)ref->w * (size_t)ref->h;
	int x0 = ref->w, y0 = ref->h, x1 = -1, y1 = -1, bw, bh;
	int32_t count = 0;
	struct err e;

	if (c->layers == 0) {
		c->w = ref->w;
		c->h = ref->h;
		c->prev = mem_calloc(n, 1);
		c->cur = mem_calloc(n, 1);
		c->fc = mem_calloc(n, 1);
		c->mask = mem_alloc(n);
		c->lab = mem_alloc(n * sizeof *c->lab);
		if (!c->prev || !c->cur || !c->fc || !c->mask || !c->lab)
			return ERR_NOMEM;
	} else if (ref->w != c->w || ref->h != c->h) {
		return -1;
	}
	/* clear the last layer's marks and cur's stale solid over their boxes */
	clear_box(c->fc, c->w, c->bx0, c->by0, c->bx1, c->by1);
	clear_box(c->cur, c->w, c->cx0, c->cy0, c->cx1, c->cy1);
	for (int y = 0; y < ref->h; y++) {
		const uint8_t *row = ref->px + (size_t)y * ref->stride;
		uint8_t *cu = c->cur + (size_t)y * (size_t)c->w;
		int a, b;
		if (!raster_row_span(row, ref->w, threshold, &a, &b))
			continue;
		for (int x = a; x <= b; x++)
			cu[x] = row[x] >= threshold;
		x0 = a < x0 ? a : x0;
		x1 = b > x1 ? b : x1;
		y0 = y < y0 ? y : y0;
		y1 = y;
	}
	if (x1 < 0)
		goto done;
	bw = x1 - x0 + 1;
	bh = y1 - y0 + 1;
	for (int y = 0; y < bh; y++)
		memcpy(c->mask + (size_t)y * (size_t)bw,
		       c->cur + (size_t)(y + y0) * (size_t)c->w + x0, (size_t)bw);
	err_clear(&e);
	if (label_components8(c->mask, bw, bh, c->lab, &count, &e))
		return ERR_NOMEM;
	if (mem_grow((void **)&c->sup, &c->sup_cap, (size_t)count + 1, 1))
		return ERR_NOMEM;
	/* layer 0 stands on the plate: every component is held */
	memset(c->sup, c->layers == 0, (size_t)count + 1);
	for (int y = 0; c->layers > 0 && y < bh; y++) {
		const int32_t *l = c->lab + (size_t)y * (size_t)bw;
		const uint8_t *pr = c->prev + (size_t)(y + y0) * (size_t)c->w + x0;
		for (int x = 0; x < bw; x++)
			if (l[x] && pr[x])
				c->sup[l[x]] = 1;
	}
	for (int y = 0; y < bh; y++) {
		const int32_t *l = c->lab + (size_t)y * (size_t)bw;
		uint8_t *f = c->fc + (size_t)(y + y0) * (size_t)c->w + x0;
		for (int x = 0; x < bw; x++)
			f[x] = l[x] && !c->sup[l[x]];
	}
done:
	/* cur becomes prev; prev's solid, stale, lies in its box */
	c->cx0 = c->bx0;
	c->cy0 = c->by0;
	c->cx1 = c->bx1;
	c->cy1 = c->by1;
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
