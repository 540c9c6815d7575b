/* strutgrid.c - uniform grid over strut capsules for point field queries. */
#include "engine/lattice/strutgrid.h"
#include "engine/lattice/kernel.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

#define GRID_MAX_CELLS (8u << 20)
#define GRID_MAX_ENTRIES (1u << 31)

static void cell_of(const struct strut_grid *g, struct vec3 p, int *c)
{
	double q[3] = {p.x - g->lo.x, p.y - g->lo.y, p.z - g->lo.z};

	for (int a = 0; a < 3; a++) {
		double f = floor(q[a] / g->cell);
		c[a] = f < 0 ? 0 : f > g->n[a] - 1 ? g->n[a] - 1 : (int)f;
	}
}

static void strut_box(const struct strut_grid *g, size_t i, int *c0, int *c1)
{
	struct vec3 a = g->node[g->ab[2 * i]], b = g->node[g->ab[2 * i + 1]];
	struct vec3 lo = v3(fmin(a.x, b.x) - g->R, fmin(a.y, b.y) - g->R, fmin(a.z, b.z) - g->R);
	struct vec3 hi = v3(fmax(a.x, b.x) + g->R, fmax(a.y, b.y) + g->R, fmax(a.z, b.z) + g->R);

	cell_of(g, lo, c0);
	cell_of(g, hi, c1);
}

/* For every cell strut i's capsule box overlaps: without items, count it
 * in cnt[cell]; with items, store i at items[cnt[cell]++].  Returns the
 * number of cells. */
static size_t visit_cells(const struct strut_grid *g, size_t i, uint32_t *cnt, uint32_t *items)
{
	int c0[3], c1[3];

	strut_box(g, i, c0, c1);
	for (int k = c0[2]; k <= c1[2]; k++)
		for (int j = c0[1]; j <= c1[1]; j++)
			for (int q = c0[0]; q <= c1[0]; q++) {
				size_t c = ((size_t)k * g->n[1] + j) * g->n[0] + q;
				if (items)
					items[cnt[c]++] = (uint32_t)i;
				else
					cnt[c]++;
			}
	return (size_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
}

int strut_grid_init(struct strut_grid *g, const struct vec3 *node, const uint32_t *ab, size_t n,
		    double R, double cell_mm, struct err *e)
{
	struct box3 b = box3_empty();
	struct vec3 s;
	size_t ncells, total = 0;
	uint32_t *fill = NULL;

	memset(g, 0, sizeof *g);
	g->node = node;
	g->ab = ab;
	g->nstruts = n;
	g->R = R;
	for (size_t i = 0; i < 2 * n; i++)
		box3_add(&b, node[ab[i]]);
	if (n == 0)
		b.lo = b.hi = v3(0, 0, 0);
	b = box3_inflate(b, R + 1e-9);
	s = box3_size(b);
	g->lo = b.lo;
	g->cell = cell_mm > 0 ? cell_mm : 1;
	for (;;) {
		double nx = floor(s.x / g->cell) + 1, ny = floor(s.y / g->cell) + 1;
		double nz = floor(s.z / g->cell) + 1;
		if (nx * ny * nz <= GRID_MAX_CELLS) {
			g->n[0] = (int)nx;
			g->n[1] = (int)ny;
			g->n[2] = (int)nz;
			break;
		}
		g->cell *= 1.25;
	}
	ncells = (size_t)g->n[0] * g->n[1] * g->n[2];
	g->start = mem_calloc(ncells + 1, sizeof *g->start);
	fill = mem_alloc(ncells * sizeof *fill);
	if (!g->start || !fill)
		goto nomem;
	for (size_t i = 0; i < n; i++) {
		total += visit_cells(g, i, g->start + 1, NULL);
		if (total >= GRID_MAX_ENTRIES) {
			mem_free(fill);
			strut_grid_fini(g);
			return ERR_SET(e, ERR_LIMIT, "strut grid too large");
		}
	}
	for (size_t c = 0; c < ncells; c++)
		g->start[c + 1] += g->start[c];
	g->item = mem_alloc((total ? total : 1) * sizeof *g->item);
	if (!g->item)
		goto nomem;
	memcpy(fill, g->start, ncells * sizeof *fill);
	for (size_t i = 0; i < n; i++)
		visit_cells(g, i, fill, g->item);
	mem_free(fill);
	return 0;
nomem:
	mem_free(fill);
	strut_grid_fini(g);
	return ERR_SET(e, ERR_NOMEM, "out of memory for the strut grid");
}

void strut_grid_fini(struct strut_grid *g)
{
	mem_free(g->start);
	mem_free(g->item);
	g->start = g->item = NULL;
}

void strut_grid_cell(const struct strut_grid *g, struct vec3 p, const uint32_t **items,
		     size_t *count)
{
	int c[3];
	size_t k;

	cell_of(g, p, c);
	k = ((size_t)c[2] * g->n[1] + c[1]) * g->n[0] + c[0];
	*items = g->item + g->start[k];
	*count = g->start[k + 1] - g->start[k];
}

void strut_pairs_reset(struct strut_pairs *p)
{
	p->n = 0;
	p->npts = 0;
	if (p->first)
		p->first[0] = 0;
}

void strut_pairs_fini(struct strut_pairs *p)
{
	mem_free(p->strut);
	mem_free(p->val);
	mem_free(p->first);
	memset(p, 0, sizeof *p);
}

int strut_pairs_add_point(struct strut_pairs *pp, const struct strut_grid *g, struct vec3 p)
{
	const uint32_t *it;
	size_t cnt;

	if (mem_grow((void **)&pp->first, &pp->pcap, pp->npts + 2, sizeof *pp->first))
		return ERR_NOMEM;
	if (pp->npts == 0)
		pp->first[0] = 0;
	strut_grid_cell(g, p, &it, &cnt);
	for (size_t k = 0; k < cnt; k++) {
		uint32_t j = it[k];
		double v = lattice_kernel_integral(p, g->node[g->ab[2 * j]], g->node[g->ab[2 * j + 1]],
						   g->R);
		if (v <= 0)
			continue;
		if (pp->n == pp->cap) {
			size_t nc = pp->cap ? 2 * pp->cap : 256;
			uint32_t *ns = mem_realloc_array(pp->strut, nc, sizeof *ns);
			float *nv;
			if (!ns)
				return ERR_NOMEM;
			pp->strut = ns;
			nv = mem_realloc_array(pp->val, nc, sizeof *nv);
			if (!nv)
				return ERR_NOMEM;
			pp->val = nv;
			pp->cap = nc;
		}
		pp->strut[pp->n] = j;
		pp->val[pp->n] = (float)v;
		pp->n++;
	}
	pp->first[++pp->npts] = (uint32_t)pp->n;
	return 0;
}
