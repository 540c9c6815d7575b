/* fins.c - fins and slivers in one layer (fins.h). */
#include "engine/verify/fins.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"

void verify_fins_init(struct verify_fins *s)
{
	s->end = NULL;
	s->cap = 0;
}

void verify_fins_fini(struct verify_fins *s)
{
	mem_free(s->end);
	verify_fins_init(s);
}

struct win {
	const uint8_t *solid;
	const uint32_t *lab;
	int w, h;
	uint32_t out_id;
};

/* Void label of window pixel (x, y): out_id beyond the window, 0 on solid. */
static uint32_t win_void(const struct win *c, int x, int y)
{
	size_t i;

	if (x < 0 || y < 0 || x >= c->w || y >= c->h)
		return c->out_id;
	i = (size_t)y * (size_t)c->w + (size_t)x;
	return c->solid[i] ? 0 : c->lab[i];
}

/* The enclosed component at one end of a run of at most max_px solid
 * pixels through (x, y) whose two ends are enclosed void; 0 if none.
 * Such a run has an end within (max_px + 1) / 2 pixels of (x, y) on one
 * side, so a pixel with solid that far in all 8 directions, inside the
 * window, is in none (the test most solid pixels take). */
static uint32_t fin_end(const struct win *c, const uint8_t *enc, uint32_t first, int max_px,
			int x, int y)
{
	static const int dir[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
	int r = (max_px + 1) / 2, deep = x >= r && y >= r && x < c->w - r && y < c->h - r;

	for (int q = 0; q < 4 && deep; q++)
		for (int t = 1; t <= r && deep; t++)
			deep = c->solid[(size_t)(y + t * dir[q][1]) * (size_t)c->w +
					(size_t)(x + t * dir[q][0])] &&
			       c->solid[(size_t)(y - t * dir[q][1]) * (size_t)c->w +
					(size_t)(x - t * dir[q][0])];
	if (deep)
		return 0;
	for (int q = 0; q < 4; q++) {
		int dx = dir[q][0], dy = dir[q][1], b = 1, f = 1;
		uint32_t la, lb;
		while (b <= max_px && !win_void(c, x - b * dx, y - b * dy))
			b++;
		while (f <= max_px && !win_void(c, x + f * dx, y + f * dy))
			f++;
		if (b + f - 1 > max_px)
			continue;
		la = win_void(c, x - b * dx, y - b * dy);
		lb = win_void(c, x + f * dx, y + f * dy);
		if (la != c->out_id && lb != c->out_id && enc[la - first] && enc[lb - first])
			return la;
	}
	return 0;
}

int verify_fins(const uint8_t *solid, const uint32_t *lab, int w, int h, uint32_t out_id,
		const uint8_t *enc, uint32_t first, int max_px, double *fcnt, double *scnt,
		struct verify_fins *s, struct err *e)
{
	struct win c = {solid, lab, w, h, out_id};
	size_t n = (size_t)w * (size_t)h;
	static const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};

	if (n > s->cap) {
		uint32_t *p = mem_alloc(n * sizeof *p);
		if (!p)
			return ERR_SET(e, ERR_NOMEM, "verify: out of memory for fins");
		mem_free(s->end);
		s->end = p;
		s->cap = n;
	}
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			s->end[i] = solid[i] ? fin_end(&c, enc, first, max_px, x, y) : 0;
			if (s->end[i])
				fcnt[s->end[i] - first] += 1;
		}
	for (int y = 0; y < h; y++)
		for (int x = 0; x < w; x++) {
			size_t i = (size_t)y * (size_t)w + (size_t)x;
			int attached = 0;
			if (!s->end[i])
				continue;
			for (int q = 0; q < 4 && !attached; q++) {
				int xx = x + nb[q][0], yy = y + nb[q][1];
				size_t j = (size_t)yy * (size_t)w + (size_t)xx;
				attached = xx >= 0 && yy >= 0 && xx < w && yy < h && solid[j] &&
					   !s->end[j];
			}
			if (!attached)
				scnt[s->end[i] - first] += 1;
		}
	return 0;
}
