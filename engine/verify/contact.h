/* contact.h - the reference part's own islands, for the islands the
 * checked stack adds (verify.c's islands_added; docs/verify.md "Added
 * islands").
 *
 * Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_CONTACT_H
#define INFILLD_VERIFY_CONTACT_H

#include <stddef.h>
#include <stdint.h>

struct raster;

/* Per image pixel (w x h, row stride w): `prev` the reference's solid on
 * the layer fed last, over the box bx0..bx1, by0..by1 that bounds it
 * (empty when bx1 < 0; 0 elsewhere), and `fc` 1 on the pixels of its
 * islands there (solid components, 8-connected, with no solid on the
 * layer below; none on layer 0, which stands on the plate), 0 elsewhere;
 * `cur` (whose stale solid lies in cx0..cx1, cy0..cy1), `mask`, `lab`
 * and `sup` scratch.  Owned; verify_contact_fini() frees. */
struct verify_contact {
	int w, h, layers;
	int bx0, by0, bx1, by1;
	int cx0, cy0, cx1, cy1;
	uint8_t *prev, *cur, *fc;
	uint8_t *mask; /* the box's solid, packed (box width a row) */
	int32_t *lab;  /* its components (label.h) */
	uint8_t *sup;  /* per component: 1 when some pixel has solid below */
	size_t sup_cap;
};

void verify_contact_init(struct verify_contact *c);
void verify_contact_fini(struct verify_contact *c);

/* Feed the reference's next layer (borrowed for the call; gray >=
 * threshold is solid).  Its size must stay the same: -1 otherwise, or
 * ERR_NOMEM; 0 on success. */
int verify_contact_layer(struct verify_contact *c, const struct raster *ref, int threshold);

/* 1 when a pixel of an island of the reference's last layer lies
 * within tol_px pixels (Chebyshev: a square of side 2 tol_px + 1) of
 * image pixel (x, y).  O(tol_px^2). */
int verify_contact_near(const struct verify_contact *c, int x, int y, int tol_px);

#endif
