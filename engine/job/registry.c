/* registry.c - the list of engines.  Each engine folder has a header
 * declaring its `const struct engine_ops <name>_engine`. */
#include "engine/engine.h"
#include "engine/hollow/hollow.h"
#include "engine/hybrid/hybrid_engine.h"
#include "engine/lattice/lattice_engine.h"
#include "engine/rhombic/rhombic_engine.h"
#include "engine/solid/solid.h"

#include <string.h>

static const struct engine_ops *const engines[] = {
	&solid_engine,
	&lattice_engine,
	&hollow_engine,
	&rhombic_engine,
	&hybrid_engine,
	NULL,
};

const struct engine_ops *const *engine_list(void)
{
	return engines;
}

const struct engine_ops *engine_find(const char *name)
{
	for (size_t i = 0; name && engines[i]; i++)
		if (strcmp(engines[i]->name, name) == 0)
			return engines[i];
	return NULL;
}
