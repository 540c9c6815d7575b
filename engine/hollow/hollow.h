/* hollow.h - the `hollow` engine: support-free hollowing (paper 004). */
#ifndef INFILLD_HOLLOW_H
#define INFILLD_HOLLOW_H

#include "engine/engine.h"

extern const struct engine_ops hollow_engine;

#endif
