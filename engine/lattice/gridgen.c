/* gridgen.c - streaming Freudenthal-grid lattices into binary files
 * (gridgen.h).  Pass 1 classifies the grid layer by layer (parallel inside
 * tests) and writes the inside nodes; pass 2 walks the layers again with
 * two rows of node indices and writes each node's 7 forward edges. */
#include "engine/lattice/gridgen.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/progress.h"
#include "engine/core/rng.h"

#include <math.h>
#include <string.h>

#define GRID_MAX_CELLS (1ull << 36)

/* the 7 forward neighbours of the Freudenthal triangulation */
static const int FWD[7][3] = {{1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, 0, 1},
			      {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};

struct grid {
	const struct lattice_domain *d;
	const struct lattice_grid_opts *o;
	struct vec3 lo, center;
	double h, hz, rim;
	int64_t n[3];
	uint8_t *bits;
};

double lattice_grid_spacing_for(double volume_mm3, double struts, double so_k)
{
	return cbrt(7.0 * volume_mm3 / (struts * so_k));
}

static struct vec3 node_pos(const struct grid *g, int64_t i, int64_t j, int64_t k)
{
	struct rng r;
	double jx = 0, jy = 0;

	if (g->o->jitter > 0) {
		rng_seed(&r, g->o->seed ^ ((uint64_t)i * 0x9E3779B97F4A7C15ull) ^
				     ((uint64_t)j * 0xC2B2AE3D27D4EB4Full) ^ ((uint64_t)k << 42));
		jx = (2 * rng_uniform(&r) - 1) * g->o->jitter * g->h;
		jy = (2 * rng_uniform(&r) - 1) * g->o->jitter * g->h;
	}
	return v3(g->lo.x + i * g->h + jx, g->lo.y + j * g->h + jy, g->lo.z + k * g->hz);
}

static int bit(const struct grid *g, int64_t i, int64_t j, int64_t k)
{
	uint64_t c;

	if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2])
		return 0;
	c = ((uint64_t)k * g->n[1] + j) * g->n[0] + i;
	return (g->bits[c >> 3] >> (c & 7)) & 1;
}

struct layer_ctx {
	struct grid *g;
	int64_t k;
	uint8_t *in; /* per cell of the layer */
};

static void classify(void *ctx, size_t c, int tid)
{
	struct layer_ctx *x = ctx;
	int64_t i = (int64_t)c % x->g->n[0], j = (int64_t)c / x->g->n[0];

	(void)tid;
	x->in[c] = (uint8_t)x->g->d->inside(x->g->d->ctx, node_pos(x->g, i, j, x->k));
}

static double radius_at(const struct grid *g, struct vec3 p)
{
	double t = fmin(1, v3_dist(p, g->center) / g->rim);
	return g->o->r_center_mm + t * (g->o->r_rim_mm - g->o->r_center_mm);
}

int lattice_grid_write(const struct lattice_domain *d, const struct lattice_grid_opts *o,
		       const char *path, struct lattice_grid_stats *st, struct err *e)
{
	struct grid g;
	struct lattice_writer *w = NULL;
	uint8_t *in = NULL;
	uint32_t *idx[2] = {NULL, NULL};
	uint64_t *base = NULL, count = 0;
	double rmax = fmax(o->r_center_mm, o->r_rim_mm), t0 = progress_now_s();
	struct vec3 sz = box3_size(d->box);
	size_t layer;
	int rc;

	memset(st, 0, sizeof *st);
	memset(&g, 0, sizeof g);
	if (!(o->spacing_mm > 0) || !(o->so_k >= 1) || !(o->jitter >= 0 && o->jitter < 0.25) ||
	    !(o->r_center_mm > 0) || !(o->r_rim_mm > 0) || box3_is_empty(d->box))
		return ERR_SET(e, ERR_PARAM, "bad grid lattice options");
	g.d = d;
	g.o = o;
	g.h = o->spacing_mm;
	g.hz = o->so_k * o->spacing_mm;
	g.n[0] = (int64_t)ceil(sz.x / g.h) + 1;
	g.n[1] = (int64_t)ceil(sz.y / g.h) + 1;
	g.n[2] = (int64_t)ceil(sz.z / g.hz) + 1;
	/* centre the grid on the box */
	g.lo = v3(d->box.lo.x - 0.5 * ((g.n[0] - 1) * g.h - sz.x),
		  d->box.lo.y - 0.5 * ((g.n[1] - 1) * g.h - sz.y),
		  d->box.lo.z - 0.5 * ((g.n[2] - 1) * g.hz - sz.z));
	g.center = box3_center(d->box);
	g.rim = fmax(1e-9, 0.5 * v3_len(sz));
	if ((double)g.n[0] * g.n[1] * g.n[2] > (double)GRID_MAX_CELLS || g.n[0] * g.n[1] > UINT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "grid of %lld x %lld x %lld cells is too large",
			       (long long)g.n[0], (long long)g.n[1], (long long)g.n[2]);
	layer = (size_t)(g.n[0] * g.n[1]);
	st->cells = layer * (size_t)g.n[2];
	g.bits = mem_calloc(st->cells / 8 + 1, 1);
	in = mem_alloc(layer);
	idx[0] = mem_alloc(layer * sizeof(uint32_t));
	idx[1] = mem_alloc(layer * sizeof(uint32_t));
	base = mem_alloc(((size_t)g.n[2] + 1) * sizeof *base);
	if (!g.bits || !in || !idx[0] || !idx[1] || !base) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for a %zu-cell grid", st->cells);
		goto out;
	}
	if ((rc = lattice_writer_open(path, o->support_mm > 0 ? o->support_mm : 1.5 * rmax, rmax,
				      &w, e)) != 0)
		goto out;

	/* pass 1: classify and write the nodes, layer by layer (z sorted) */
	for (int64_t k = 0; k < g.n[2]; k++) {
		struct layer_ctx x = {&g, k, in};

		parfor_run(layer, d->threads, 512, classify, &x);
		base[k] = count;
		for (size_t c = 0; c < layer; c++) {
			uint64_t cell = (uint64_t)k * layer + c;
			if (!in[c])
				continue;
			if (count >= LATTICE_MAX_NODES) {
				rc = ERR_SET(e, ERR_LIMIT, "more than %u nodes", LATTICE_MAX_NODES);
				goto out;
			}
			g.bits[cell >> 3] |= (uint8_t)(1u << (cell & 7));
			if ((rc = lattice_writer_node(w, node_pos(&g, (int64_t)(c % g.n[0]),
								   (int64_t)(c / g.n[0]), k),
						      e)) != 0)
				goto out;
			count++;
		}
	}
	base[g.n[2]] = count;
	st->nodes = count;
	st->seconds_classify = progress_now_s() - t0;

	/* pass 2: edges from each node to its forward neighbours */
	for (int64_t k = 0; k < g.n[2]; k++) {
		for (int s = 0; s < 2; s++) {
			int64_t kk = k + s;
			uint64_t n = kk < g.n[2] ? base[kk] : 0;
			for (size_t c = 0; c < layer; c++)
				idx[s][c] = kk < g.n[2] && bit(&g, (int64_t)(c % g.n[0]),
							      (int64_t)(c / g.n[0]), kk)
						    ? (uint32_t)n++
						    : UINT32_MAX;
		}
		for (size_t c = 0; c < layer; c++) {
			int64_t i = (int64_t)(c % g.n[0]), j = (int64_t)(c / g.n[0]);
			struct vec3 p;

			if (idx[0][c] == UINT32_MAX)
				continue;
			p = node_pos(&g, i, j, k);
			for (int f = 0; f < 7; f++) {
				int64_t ii = i + FWD[f][0], jj = j + FWD[f][1];
				uint32_t b;
				if (ii >= g.n[0] || jj >= g.n[1] || (FWD[f][2] && k + 1 >= g.n[2]))
					continue;
				b = idx[FWD[f][2]][(size_t)(jj * g.n[0] + ii)];
				if (b == UINT32_MAX)
					continue;
				if ((rc = lattice_writer_edge(
					     w, idx[0][c], b,
					     radius_at(&g, v3_lerp(p, node_pos(&g, ii, jj, k + FWD[f][2]),
								   0.5)),
					     e)) != 0)
					goto out;
				st->struts++;
			}
		}
	}
	rc = lattice_writer_close(w, e);
	w = NULL;
	st->seconds_write = progress_now_s() - t0 - st->seconds_classify;
out:
	lattice_writer_abort(w);
	mem_free(g.bits);
	mem_free(in);
	mem_free(idx[0]);
	mem_free(idx[1]);
	mem_free(base);
	return rc;
}
