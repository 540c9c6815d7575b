/* topdown.h - the top-down support-free fill (topdown.c): the largest
 * void a greedy top-down construction fits inside the offset stack,
 * layer by layer, used where the optimiser left space unhollowed.
 * Design: docs/hollow.md "Top-down fill".
 */
#ifndef INFILLD_HOLLOW_TOPDOWN_H
#define INFILLD_HOLLOW_TOPDOWN_H

#include <stddef.h>

#include "engine/geom/path.h"

struct mesh;
struct err;
struct hl_config;
struct progress;

struct hl_fill {
	struct paths *layer; /* n regions (nm, printer frame): the void of stack layer j,
				the slab [j, j + 1] * layer_mm */
	int n;
	double layer_mm;     /* stack layer height */
	size_t voids;        /* 3D components kept (connected through consecutive layers) */
	size_t voids_small;  /* components dropped: below min_void_mm3 */
	double volume_mm3;   /* of the kept components */
};

void hl_fill_fini(struct hl_fill *f);

/* Fill f with the top-down support-free void of the region that keeps
 * c->wall_mm from part's surface and, when solid != NULL (part minus the
 * optimised voids, one closed mesh), c->wall_next_mm from solid's surface.
 * Consecutive layers obey the overhang rule at c->alpha_rad - margin:
 * every non-void point of layer j + 1 lies within layer_mm tan(alpha) of
 * a non-void point of layer j (docs/hollow.md).  Components under
 * c->min_void_mm3 are dropped.  stack_count layers of c->stack_layer_mm.
 * prog (may be NULL) advances from f0 to f1 and can cancel.
 * Returns 0 (f replaced), ERR_NOMEM, ERR_LIMIT, ERR_CANCELLED or a slicer
 * error. */
int hl_fill_build(const struct mesh *part, const struct mesh *solid, const struct hl_config *c,
		  int stack_count, struct progress *prog, double f0, double f1, struct hl_fill *f,
		  struct err *e);

/* Layer source for slice/erode.h over a slicer: layer k is the slice at
 * (k + 1/2) layer_mm.  ctx is a struct hl_src_ctx (borrowed). */
struct slicer;
struct hl_src_ctx {
	struct slicer *s;
	double layer_mm;
};
int hl_src_layer(void *ctx, int k, struct paths *region, struct err *e);

/* The fill's region for a print layer whose mid-plane is at z_mm:
 * borrowed, NULL when there is none. */
const struct paths *hl_fill_at(const struct hl_fill *f, double z_mm);

#endif
