/* graph.c - the in-memory lattice graph (lattice.h): nodes, struts, measures. */
#include "engine/lattice/lattice.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>

struct lattice *lattice_new(void)
{
	return mem_calloc(1, sizeof(struct lattice));
}

void lattice_free(struct lattice *q)
{
	if (!q)
		return;
	mem_free(q->node);
	mem_free(q->edge);
	mem_free(q);
}

void lattice_clear(struct lattice *q)
{
	q->nnodes = 0;
	q->nedges = 0;
}

int lattice_reserve(struct lattice *q, size_t nnodes, size_t nedges)
{
	void *p;

	if (nnodes > LATTICE_MAX_NODES || nedges > LATTICE_MAX_EDGES)
		return ERR_LIMIT;
	if (nnodes > q->node_cap) {
		p = mem_realloc_array(q->node, nnodes, sizeof *q->node);
		if (!p)
			return ERR_NOMEM;
		q->node = p;
		q->node_cap = nnodes;
	}
	if (nedges > q->edge_cap) {
		p = mem_realloc_array(q->edge, nedges, sizeof *q->edge);
		if (!p)
			return ERR_NOMEM;
		q->edge = p;
		q->edge_cap = nedges;
	}
	return 0;
}

int lattice_add_node(struct lattice *q, struct vec3 p)
{
	void *arr = q->node;
	int rc;

	if (q->nnodes >= LATTICE_MAX_NODES)
		return ERR_LIMIT;
	rc = mem_grow(&arr, &q->node_cap, q->nnodes + 1, sizeof *q->node);
	q->node = arr;
	if (rc)
		return rc;
	q->node[q->nnodes++] = p;
	return 0;
}

int lattice_add_edge(struct lattice *q, uint32_t a, uint32_t b, double radius_mm)
{
	void *arr = q->edge;
	int rc;

	if (a == b || a >= q->nnodes || b >= q->nnodes || !(radius_mm > 0) ||
	    !isfinite(radius_mm))
		return ERR_PARAM;
	if (q->nedges >= LATTICE_MAX_EDGES)
		return ERR_LIMIT;
	rc = mem_grow(&arr, &q->edge_cap, q->nedges + 1, sizeof *q->edge);
	q->edge = arr;
	if (rc)
		return rc;
	q->edge[q->nedges].a = a;
	q->edge[q->nedges].b = b;
	q->edge[q->nedges].radius_mm = (float)radius_mm;
	q->nedges++;
	return 0;
}

struct box3 lattice_bbox(const struct lattice *q)
{
	struct box3 b = box3_empty();

	for (size_t i = 0; i < q->nnodes; i++)
		box3_add(&b, q->node[i]);
	return b;
}

double lattice_max_radius(const struct lattice *q)
{
	double m = 0;

	for (size_t i = 0; i < q->nedges; i++)
		m = fmax(m, q->edge[i].radius_mm);
	return m;
}

double lattice_total_length(const struct lattice *q)
{
	double s = 0;

	for (size_t i = 0; i < q->nedges; i++)
		s += v3_dist(q->node[q->edge[i].a], q->node[q->edge[i].b]);
	return s;
}

double lattice_support(const struct lattice *q, double factor)
{
	return q->support_mm > 0 ? q->support_mm : factor * lattice_max_radius(q);
}
