/* solid.h - the `solid` engine: the part itself, sliced (the baseline
 * every other engine is compared with), optionally hollowed uniformly. */
#ifndef INFILLD_SOLID_H
#define INFILLD_SOLID_H

#include "engine/engine.h"

extern const struct engine_ops solid_engine;

#endif
