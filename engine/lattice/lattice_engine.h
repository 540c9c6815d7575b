/* lattice_engine.h - the `lattice` engine: graded self-supporting lattices as
 * convolution surfaces (paper 000), generated inside a mesh or read from a
 * lattice file, sliced in a streaming plane sweep.  docs/lattice.md. */
#ifndef INFILLD_LATTICE_ENGINE_H
#define INFILLD_LATTICE_ENGINE_H

#include "engine/engine.h"

extern const struct engine_ops lattice_engine;

#endif
