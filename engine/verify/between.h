/* between.h - in-layer walls between pairs of void components (verify.c's
 * walls between cavities; docs/verify.md "Walls between cavities").
 *
 * Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_BETWEEN_H
#define INFILLD_VERIFY_BETWEEN_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/edt.h"

struct err;

/* One pair of seed labels a < b and the centre distance (mm) between the
 * nearest pair of their pixels found (see verify_between_pairs). */
struct verify_pair {
	uint32_t a, b;
	double d_mm;
};

/* Scratch reused across layers; verify_between_fini() frees. */
struct verify_between {
	int32_t *near;
	float *d2;
	size_t cap;
	struct verify_pair *pairs;
	size_t n, pcap;
	struct edt_scratch es;
};

void verify_between_init(struct verify_between *s);
void verify_between_fini(struct verify_between *s);

/* Pairs of labels among the seeds of a w x h window (row stride w):
 * seed[i] != 0 marks a seed pixel, lab[i] its label (> 0).  For every two
 * labels whose nearest-seed regions (the exact Euclidean feature
 * transform, pitches px_mm along x and py_mm along y) touch, s->pairs
 * gets one entry, sorted by (a, b), with the smallest centre distance
 * between the nearest seeds of two touching pixels (8-neighbours) of the
 * two regions.  That distance is a real pair's, so it never reads below
 * the sets' true distance; it is the true distance when the closest pair
 * lies on a row or a column, and within a pixel or so of it otherwise
 * (tests/unit/verify/test_verify_between.c).  Two labels with a third
 * between them everywhere get no entry: their distance exceeds the
 * distance of one of them to the third (docs/verify.md).  0 or
 * ERR_NOMEM. */
int verify_between_pairs(const uint8_t *seed, const uint32_t *lab, int w, int h, double px_mm,
                         double py_mm, struct verify_between *s, struct err *e);

#endif
