/* rhombic_engine.h - the `rhombic` engine: self-supporting adaptive
 * rhombic infill (paper 001; docs/rhombic.md). */
#ifndef INFILLD_RHOMBIC_ENGINE_H
#define INFILLD_RHOMBIC_ENGINE_H

#include "engine/engine.h"

extern const struct engine_ops rhombic_engine;

#endif
