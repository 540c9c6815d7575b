/* hybrid_engine.h - the `hybrid` engine: muscle-fibre and
 * tetrahedral-crystal interiors split by shape and stress (paper 003;
 * docs/hybrid.md). */
#ifndef INFILLD_HYBRID_ENGINE_H
#define INFILLD_HYBRID_ENGINE_H

#include "engine/engine.h"

extern const struct engine_ops hybrid_engine;

#endif
