/* dpband.h - the bands the strip dynamic programmes (strip.c, restrip.c)
 * search on long loops.  Pairs of up to HL_DP_FULL_CELLS grid cells
 * ((n + 1) (m + 1)) are searched as each file always did (every loop of
 * the bench models: up to about 400 x 400); larger pairs (a 156 mm gear's
 * loops: 4,734 x 4,734, whose full grid took 22 M cells and hundreds of MB
 * a pair) search bands |j - i m / n| <= half-width round the diagonal,
 * first HL_DP_NARROW_HW(max(n, m)) then HL_DP_WIDE_HW (strip.c's band), in
 * storage of the band's size, none of more than HL_DP_MAX_CELLS cells.
 * Not for use outside engine/hollow/opt/.
 */
#ifndef INFILLD_HOLLOW_OPT_DPBAND_H
#define INFILLD_HOLLOW_OPT_DPBAND_H

#include <stddef.h>

#define HL_DP_FULL_CELLS ((size_t)1 << 20)
#define HL_DP_MAX_CELLS ((size_t)1 << 22)
#define HL_DP_NARROW_HW(n) ((n) / 32 + 16)
#define HL_DP_WIDE_HW(n) ((n) / 8 + 6)

#endif
