/* fins.h - fins and slivers in one layer (verify.c's fin count;
 * docs/verify.md "Fins").
 *
 * Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_FINS_H
#define INFILLD_VERIFY_FINS_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Scratch reused across layers; verify_fins_fini() frees. */
struct verify_fins {
	uint32_t *end; /* per window pixel: a fin's void component, 0 if none */
	size_t cap;
};

void verify_fins_init(struct verify_fins *s);
void verify_fins_fini(struct verify_fins *s);

/* One layer's window of w x h pixels (row stride w): solid[i] 1 on solid,
 * lab[i] the void component id (> 0) elsewhere, out_id the outside's id
 * (pixels beyond the window read as outside), enc[id - first] != 0 when
 * component id is enclosed in the layer.
 * A fin pixel is a solid pixel in a run of at most max_px pixels along a
 * row, a column or a diagonal whose two ends are enclosed void: solid too
 * thin to print between cavities.  fcnt[id - first] += 1 for each, id one
 * end's component.  A sliver pixel is a fin pixel none of whose solid
 * 4-neighbours is solid outside the fins: it stands free between voids,
 * where a fin pixel beside thicker solid (a one-pixel bump on a wall's
 * edge, a convex tip) is attached along its side and prints with it;
 * scnt[id - first] += 1 for each.  A fin wall ending on thick walls
 * counts its two end pixels as fins only.  0 or ERR_NOMEM. */
int verify_fins(const uint8_t *solid, const uint32_t *lab, int w, int h, uint32_t out_id,
		const uint8_t *enc, uint32_t first, int max_px, double *fcnt, double *scnt,
		struct verify_fins *s, struct err *e);

#endif
