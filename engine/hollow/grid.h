/* grid.h - pixel-grid helpers of the top-down fill (topdown.c): row runs
 * of binary masks and the nearest-seed label transform (exact Euclidean,
 * labels of the feature transform of geom/edt.h).  Components are
 * labelled by engine/geom/label.h.
 */
#ifndef INFILLD_HOLLOW_GRID_H
#define INFILLD_HOLLOW_GRID_H

#include <stddef.h>
#include <stdint.h>

struct err;

/* One run of set pixels: row y, columns x0..x1 inclusive (grid pixels). */
struct hl_run {
	int32_t y, x0, x1;
	uint32_t comp; /* component id (topdown.c), 0 elsewhere */
};

/* The set pixels of mask (w x h, row stride w, nonzero = set) restricted
 * to columns [x0, x1) and rows [y0, y1), as runs in row-major order,
 * appended to *runs (*n, *cap: mem_grow array).  0 or ERR_NOMEM. */
int hl_grid_runs(const uint8_t *mask, int w, int x0, int y0, int x1, int y1,
		 struct hl_run **runs, size_t *n, size_t *cap, struct err *e);

/* Set mask[y * w + x] = val for every pixel of runs[0..n). */
void hl_grid_paint(uint8_t *mask, int w, const struct hl_run *runs, size_t n, uint8_t val);

/* Nearest-seed transform on a w x h window (row stride w): for every
 * pixel, d2 = squared distance (mm^2, pitches px_mm along x, py_mm along
 * y) between pixel centres to the nearest pixel with lab != 0, and
 * near = that pixel's lab (0 and INFINITY without seeds).  O(w h).
 * Scratch is allocated per call (edt_nearest_sq does the work).  0 or
 * ERR_NOMEM. */
int hl_grid_nearest(const int32_t *lab, int w, int h, double px_mm, double py_mm, float *d2,
		    int32_t *near, struct err *e);

#endif
