/* pointgrid.c - uniform bucket grid of points (pointgrid.h). */
#include "engine/geom/pointgrid.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

void pointgrid_dims(struct box3 b, size_t max_cells, double *cell_mm, int n[3])
{
	struct vec3 s = box3_size(b);

	for (;;) {
		double c = *cell_mm;
		double nx = ceil(s.x / c) + 1, ny = ceil(s.y / c) + 1, nz = ceil(s.z / c) + 1;
		if (nx * ny * nz <= (double)max_cells) {
			n[0] = (int)nx;
			n[1] = (int)ny;
			n[2] = (int)nz;
			return;
		}
		*cell_mm *= 1.25;
	}
}

void pointgrid_cell(struct vec3 lo, double cell_mm, const int n[3], struct vec3 p, int ijk[3])
{
	double q[3] = {p.x - lo.x, p.y - lo.y, p.z - lo.z};

	for (int a = 0; a < 3; a++) {
		double f = floor(q[a] / cell_mm);
		if (!(f >= 0)) /* also NaN */
			f = 0;
		if (f > n[a] - 1)
			f = n[a] - 1;
		ijk[a] = (int)f;
	}
}

int pointgrid_init(struct pointgrid *g, struct box3 box, double cell_mm, size_t max_cells,
		   struct err *e)
{
	size_t ng;

	memset(g, 0, sizeof *g);
	g->lo = box.lo;
	g->cell_mm = cell_mm;
	pointgrid_dims(box, max_cells, &g->cell_mm, g->n);
	ng = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2];
	g->head = mem_alloc(ng * sizeof *g->head);
	if (!g->head)
		return ERR_SET(e, ERR_NOMEM, "out of memory for a point grid of %zu cells", ng);
	memset(g->head, 0xff, ng * sizeof *g->head);
	return 0;
}

void pointgrid_fini(struct pointgrid *g)
{
	mem_free(g->head);
	mem_free(g->next);
	mem_free(g->pts);
	memset(g, 0, sizeof *g);
}

int pointgrid_insert(struct pointgrid *g, struct vec3 p, struct err *e)
{
	int ijk[3];
	size_t c;

	if (g->np >= INT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "more than %d points in a point grid", INT32_MAX);
	if (g->np == g->cap) {
		size_t nc = g->cap ? 2 * g->cap : 4096;
		struct vec3 *np = mem_realloc_array(g->pts, nc, sizeof *np);
		int32_t *nn;
		if (!np)
			return ERR_SET(e, ERR_NOMEM, "out of memory for %zu points", nc);
		g->pts = np;
		nn = mem_realloc_array(g->next, nc, sizeof *nn);
		if (!nn)
			return ERR_SET(e, ERR_NOMEM, "out of memory for %zu points", nc);
		g->next = nn;
		g->cap = nc;
	}
	pointgrid_cell(g->lo, g->cell_mm, g->n, p, ijk);
	c = ((size_t)ijk[2] * g->n[1] + ijk[1]) * g->n[0] + ijk[0];
	g->pts[g->np] = p;
	g->next[g->np] = g->head[c];
	g->head[c] = (int32_t)g->np;
	g->np++;
	return 0;
}

/* Cell ranges [c0, c1] per axis holding every point within d of p. */
static void cell_range(const struct pointgrid *g, struct vec3 p, double d_mm, int c0[3],
		       int c1[3])
{
	int ijk[3];
	double rr = ceil(d_mm / g->cell_mm);
	int r;

	pointgrid_cell(g->lo, g->cell_mm, g->n, p, ijk);
	/* a radius past the grid reads the whole grid */
	r = rr < 1 << 30 ? (int)rr : 1 << 30;
	if (!(r >= 0))
		r = 1 << 30;
	for (int a = 0; a < 3; a++) {
		c0[a] = ijk[a] - r < 0 ? 0 : ijk[a] - r;
		c1[a] = ijk[a] > g->n[a] - 1 - r ? g->n[a] - 1 : ijk[a] + r;
	}
}

int pointgrid_far_from_all(const struct pointgrid *g, struct vec3 p, double d_mm)
{
	double d2 = d_mm * d_mm;
	int c0[3], c1[3];

	cell_range(g, p, d_mm, c0, c1);
	for (int k = c0[2]; k <= c1[2]; k++)
		for (int j = c0[1]; j <= c1[1]; j++) {
			const int32_t *row = g->head + ((size_t)k * g->n[1] + j) * g->n[0];
			for (int i = c0[0]; i <= c1[0]; i++)
				for (int32_t q = row[i]; q >= 0; q = g->next[q])
					if (v3_len2(v3_sub(g->pts[q], p)) < d2)
						return 0;
		}
	return 1;
}

int pointgrid_visit(const struct pointgrid *g, struct vec3 p, double d_mm,
		    int (*fn)(void *ctx, int32_t q), void *ctx)
{
	int c0[3], c1[3], rc;

	cell_range(g, p, d_mm, c0, c1);
	for (int k = c0[2]; k <= c1[2]; k++)
		for (int j = c0[1]; j <= c1[1]; j++) {
			const int32_t *row = g->head + ((size_t)k * g->n[1] + j) * g->n[0];
			for (int i = c0[0]; i <= c1[0]; i++)
				for (int32_t q = row[i]; q >= 0; q = g->next[q])
					if ((rc = fn(ctx, q)) != 0)
						return rc;
		}
	return 0;
}
