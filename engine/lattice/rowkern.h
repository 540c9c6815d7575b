/* rowkern.h - the innermost loop of lattice slicing (internal to lattice/).
 *
 * Accumulates one strut's contribution along a run of pixels of one image
 * row.  With u' = 0, 1, ..., n-1 the pixel offset from the run's first
 * pixel centre, the strut frame quantities are polynomials in u':
 * c(u') = R^2 - rho^2 = c0 + c1 u' + c2 u'^2 and h(u') = h0 + hs u', so a
 * pixel costs one sqrt and two quintics (kernel.c's G).  Sums are fixed
 * point (LATTICE_FIX_ONE = the isovalue) with saturating adds: the result
 * does not depend on the order struts are added, so in-core, out-of-core
 * and multi-threaded slicing give bit-identical images.
 */
#ifndef INFILLD_LATTICE_ROWKERN_H
#define INFILLD_LATTICE_ROWKERN_H

#include <stdint.h>

/* Fixed-point scale: field value F/C = acc / LATTICE_FIX_ONE. */
#define LATTICE_FIX_ONE 4194304.0f /* 2^22: range 1024 x C, resolution 2.4e-7 C */

struct rowkern_args {
	float c0, c1, c2; /* c(u') */
	float h0, hs;     /* h(u') along the strut from its start, mm */
	float l;          /* strut length, mm */
	float k;          /* LATTICE_FIX_ONE * w / (C R^4) */
};

/* acc[0..n-1] += k * (G(y1) - G(y0)), saturating.  Returns nothing;
 * pixels outside the support add 0. */
typedef void (*rowkern_fn)(const struct rowkern_args *a, uint32_t *acc, int n);

/* The fastest kernel this CPU runs (AVX2+FMA on x86-64 when available,
 * else portable C).  Both compute the same formula; results may differ in
 * the last bits (FMA), never between calls on one machine. */
rowkern_fn lattice_rowkern_pick(void);
/* The portable kernel (tests compare the two). */
void lattice_rowkern_scalar(const struct rowkern_args *a, uint32_t *acc, int n);

#endif
