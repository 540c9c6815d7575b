/* optimize.c - design updates that refine the rhombic hierarchy: uniform
 * refinement (docs/rhombic.md section 5).
 */
#include "engine/rhombic/optimize.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

int rh_uniform(struct rh_tree *t, double part_vol, double target, int *steps, struct err *e)
{
	int32_t *leaves = NULL;
	size_t cap = 0;
	int rc = 0;

	*steps = 0;
	while (t->cavities > 0 && (part_vol - t->cavity_volume_mm3) / part_vol < target) {
		size_t n = 0;
		if (mem_grow((void **)&leaves, &cap, t->cavities, sizeof *leaves)) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
			break;
		}
		for (size_t i = 0; i < t->n; i++)
			if (t->c[i].state == RH_CAVITY && n < cap)
				leaves[n++] = (int32_t)i;
		for (size_t k = 0; k < n && !rc; k++)
			rc = rh_tree_refine(t, leaves[k], NULL, e);
		if (rc)
			break;
		(*steps)++;
	}
	mem_free(leaves);
	return rc;
}
