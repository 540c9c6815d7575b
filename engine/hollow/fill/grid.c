/* grid.c - pixel-grid helpers of the top-down fill: row runs of masks and
 * the nearest-seed label transform (exact Euclidean distances between
 * pixel centres).  See fill_int.h; labelling is engine/geom/label.c.
 */
#include "engine/hollow/fill/fill_int.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/edt.h"

int hl_grid_runs(const uint8_t *mask, int w, int x0, int y0, int x1, int y1,
		 struct hl_span **runs, size_t *n, size_t *cap, struct err *e)
{
	for (int y = y0; y < y1; y++) {
		const uint8_t *m = mask + (size_t)y * (size_t)w;
		int x = x0;
		while (x < x1) {
			int s;
			void *arr = *runs;
			while (x < x1 && !m[x])
				x++;
			if (x >= x1)
				break;
			s = x;
			while (x < x1 && m[x])
				x++;
			if (mem_grow(&arr, cap, *n + 1, sizeof **runs))
				return ERR_SET(e, ERR_NOMEM, "hollow: out of memory (fill runs)");
			*runs = arr;
			(*runs)[*n].y = y;
			(*runs)[*n].x0 = s;
			(*runs)[*n].x1 = x - 1;
			(*runs)[*n].comp = 0;
			(*n)++;
		}
	}
	return 0;
}

void hl_grid_row_starts(const struct hl_span *r, size_t n, int h, size_t *rs)
{
	size_t i = 0;

	for (int y = 0; y <= h; y++) {
		while (i < n && r[i].y < y)
			i++;
		rs[y] = i;
	}
}

void hl_grid_paint(uint8_t *mask, int w, const struct hl_span *runs, size_t n, uint8_t val)
{
	for (size_t i = 0; i < n; i++)
		memset(mask + (size_t)runs[i].y * (size_t)w + runs[i].x0, val,
		       (size_t)(runs[i].x1 - runs[i].x0 + 1));
}

int hl_grid_nearest(const int32_t *lab, int w, int h, double px_mm, double py_mm, float *d2,
		    int32_t *near, uint8_t *seed, int32_t *idx, struct edt_scratch *es,
		    struct err *e)
{
	size_t np = (size_t)w * (size_t)h;
	int rc;

	for (size_t i = 0; i < np; i++)
		seed[i] = lab[i] != 0;
	rc = edt_nearest_sq(seed, (size_t)w, w, h, px_mm, py_mm, d2, idx, es, e);
	for (size_t i = 0; !rc && i < np; i++)
		near[i] = idx[i] < 0 ? 0 : lab[idx[i]];
	return rc;
}
