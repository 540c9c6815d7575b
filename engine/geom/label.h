/* label.h - connected components of binary pixel images.
 *
 * Two-pass labelling with union-find (path halving), O(w h).  8-connected:
 * pixels meeting at a corner belong together, as resin cured in one layer
 * does.  Used by the verifier (void components), the hollow engine's
 * top-down fill and the hybrid engine's transient layers (paper 003,
 * section 6).
 */
#ifndef INFILLD_GEOM_LABEL_H
#define INFILLD_GEOM_LABEL_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* Label the 8-connected components of mask (nonzero = set; w x h, row
 * stride w) 1..count into lab (w h entries, caller's; 0 off the mask);
 * components are numbered in raster order of their first pixel (row by
 * row from y = 0, x ascending).  *count set.  Scratch: one int32 per
 * provisional label, freed before return.  0 or ERR_NOMEM. */
int label_components8(const uint8_t *mask, int w, int h, int32_t *lab, int32_t *count,
                      struct err *e);

/* size[l] = pixels of label l for l in 0..count (size: count + 1 entries,
 * caller's; size[0] = pixels off the mask). */
void label_sizes(const int32_t *lab, size_t n, int32_t count, size_t *size);

#endif
