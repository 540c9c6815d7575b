/* test_layers.c - surfaces of layer stacks (engine/mesh/layers.c) against
 * figures computed here without it.
 *
 * The checker reads the output as an STL reader would: corners rounded to
 * float32 and identified by their coordinates alone (so split vertices
 * must really be apart), then every undirected edge must lie in exactly
 * two triangles traversed once each way, every vertex link must be one
 * cycle, no triangle may repeat a corner.  It is first shown to reject
 * damaged meshes.  Expected figures come from the masks alone: volume =
 * inside voxels x voxel volume (to the nudges), and Euler characteristic
 * V - E + F = 2 (components - genus) for the shapes whose genus is known.
 */
#include "harness.h"

#include <stdint.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/layers.h"
#include "engine/mesh/mesh.h"

/* ---- The independent checker (coordinates, not indices) ---- */

struct chk {
	size_t bad_edges; /* undirected edges not in exactly two triangles */
	size_t same_dir;  /* edges in two triangles traversed the same way */
	size_t bad_links; /* vertices whose link is not one cycle */
	size_t repeated;  /* triangles with a repeated corner */
	long euler;       /* V - E + F */
	size_t components;
	double volume; /* signed */
};

struct corner {
	float p[3];
	uint32_t slot; /* 3 t + k */
};

static int corner_cmp(const void *a, const void *b)
{
	const struct corner *x = a, *y = b;
	for (int k = 0; k < 3; k++)
		if (x->p[k] != y->p[k])
			return x->p[k] < y->p[k] ? -1 : 1;
	return 0;
}

struct dedge {
	uint32_t a, b; /* directed a -> b */
	uint32_t t;
};

static int dedge_cmp(const void *p, const void *q)
{
	const struct dedge *x = p, *y = q;
	uint32_t xl = x->a < x->b ? x->a : x->b, xh = x->a ^ x->b ^ xl;
	uint32_t yl = y->a < y->b ? y->a : y->b, yh = y->a ^ y->b ^ yl;
	if (xl != yl)
		return xl < yl ? -1 : 1;
	if (xh != yh)
		return xh < yh ? -1 : 1;
	return 0;
}

static uint32_t uf(uint32_t *p, uint32_t i)
{
	while (p[i] != i)
		i = p[i] = p[p[i]];
	return i;
}

static void check_soup(const struct mesh *m, struct chk *r)
{
	size_t nt = m->nt, nc = 3 * nt, nv = 0, ne = 0;
	struct corner *c = calloc(nc ? nc : 1, sizeof *c);
	uint32_t *id = calloc(nc ? nc : 1, sizeof *id);
	struct dedge *d = calloc(nc ? nc : 1, sizeof *d);
	uint32_t *par, *link;

	memset(r, 0, sizeof *r);
	for (size_t i = 0; i < nc; i++) {
		struct vec3 v = m->v[m->tri[i]];
		c[i].p[0] = (float)v.x;
		c[i].p[1] = (float)v.y;
		c[i].p[2] = (float)v.z;
		c[i].slot = (uint32_t)i;
	}
	qsort(c, nc, sizeof *c, corner_cmp);
	for (size_t i = 0; i < nc; i++) {
		if (i > 0 && corner_cmp(&c[i - 1], &c[i]) != 0)
			nv++;
		id[c[i].slot] = (uint32_t)nv;
	}
	nv = nc ? nv + 1 : 0;
	for (size_t t = 0; t < nt; t++) {
		uint32_t a = id[3 * t], b = id[3 * t + 1], e = id[3 * t + 2];
		double v = 0;
		const float *p = c[0].p;
		(void)p;
		if (a == b || b == e || a == e)
			r->repeated++;
		for (int k = 0; k < 3; k++) {
			d[3 * t + k].a = id[3 * t + k];
			d[3 * t + k].b = id[3 * t + (k + 1) % 3];
			d[3 * t + k].t = (uint32_t)t;
		}
		{
			struct vec3 x = m->v[m->tri[3 * t]], y = m->v[m->tri[3 * t + 1]],
				    z = m->v[m->tri[3 * t + 2]];
			v = (x.x * (y.y * z.z - y.z * z.y) - x.y * (y.x * z.z - y.z * z.x) +
			     x.z * (y.x * z.y - y.y * z.x)) /
			    6;
		}
		r->volume += v;
	}
	qsort(d, nc, sizeof *d, dedge_cmp);
	par = calloc(nv ? nv : 1, sizeof *par);
	for (size_t i = 0; i < nv; i++)
		par[i] = (uint32_t)i;
	for (size_t i = 0; i < nc;) {
		size_t j = i;
		while (j < nc && dedge_cmp(&d[i], &d[j]) == 0)
			j++;
		ne++;
		if (j - i != 2)
			r->bad_edges++;
		else if (d[i].a == d[i + 1].a)
			r->same_dir++;
		par[uf(par, d[i].a)] = uf(par, d[i].b);
		i = j;
	}
	for (size_t i = 0; i < nv; i++)
		if (uf(par, (uint32_t)i) == i)
			r->components++;
	/* vertex links: for each vertex, the triangles round it must form
	 * one cycle through the opposite edges (a -> b for each triangle) */
	link = calloc(nv ? nv : 1, sizeof *link);
	{
		/* count triangles per vertex, then walk the link */
		size_t *start = calloc(nv + 1, sizeof *start);
		uint32_t *nexta = calloc(nc ? nc : 1, sizeof *nexta), *nextb = calloc(nc ? nc : 1,
										      sizeof *nextb);
		size_t *fill = calloc(nv + 1, sizeof *fill);
		for (size_t i = 0; i < nc; i++)
			start[id[i] + 1]++;
		for (size_t i = 0; i < nv; i++)
			start[i + 1] += start[i];
		for (size_t t = 0; t < nt; t++)
			for (int k = 0; k < 3; k++) {
				uint32_t v = id[3 * t + k];
				size_t q = start[v] + fill[v]++;
				nexta[q] = id[3 * t + (k + 1) % 3];
				nextb[q] = id[3 * t + (k + 2) % 3];
			}
		for (size_t v = 0; v < nv; v++) {
			size_t n = start[v + 1] - start[v], steps = 0;
			uint32_t cur = nexta[start[v]], first = cur;
			do {
				size_t q, hits = 0, at = 0;
				for (q = start[v]; q < start[v + 1]; q++)
					if (nexta[q] == cur)
						hits++, at = q;
				if (hits != 1)
					break;
				cur = nextb[at];
				steps++;
			} while (cur != first && steps <= n);
			if (steps != n || cur != first)
				r->bad_links++;
		}
		free(start);
		free(nexta);
		free(nextb);
		free(fill);
	}
	r->euler = (long)nv - (long)ne + (long)nt;
	free(link);
	free(par);
	free(c);
	free(id);
	free(d);
}

static int manifold(const struct chk *r)
{
	return !r->bad_edges && !r->same_dir && !r->bad_links && !r->repeated;
}

/* ---- Stacks ---- */

struct stack {
	int nx, ny, nz;
	uint8_t *v; /* nz * ny * nx */
};

static int stack_layer(void *ctx, int k, uint8_t *mask, struct err *e)
{
	const struct stack *s = ctx;
	(void)e;
	memcpy(mask, s->v + (size_t)k * s->nx * s->ny, (size_t)s->nx * s->ny);
	return 0;
}

static void stack_init(struct stack *s, int nx, int ny, int nz)
{
	s->nx = nx;
	s->ny = ny;
	s->nz = nz;
	s->v = calloc((size_t)nx * ny * nz, 1);
}

static void set(struct stack *s, int i, int j, int k)
{
	s->v[((size_t)k * s->ny + j) * s->nx + i] = 1;
}

static size_t count(const struct stack *s)
{
	size_t n = 0;
	for (size_t i = 0; i < (size_t)s->nx * s->ny * s->nz; i++)
		n += s->v[i] != 0;
	return n;
}

/* Surface of s in a frame of pitch 0.05 x 0.04 mm, layers 0.05 mm (or a
 * mirrored, transposed one), checked; returns the mesh (caller frees). */
static struct mesh *surface(struct stack *s, int mirror, struct chk *r)
{
	struct mesh_layers_grid g;
	struct mesh_layers_src src = {stack_layer, s};
	struct mesh *m = NULL;
	struct err e;
	int rc;

	memset(&g, 0, sizeof g);
	g.nx = s->nx;
	g.ny = s->ny;
	g.nz = s->nz;
	g.o[0] = 31.3;
	g.o[1] = -12.7;
	if (mirror) { /* x from J, y from -I (as a portrait display's map) */
		g.m[0][1] = 0.05;
		g.m[1][0] = -0.04;
	} else {
		g.m[0][0] = 0.05;
		g.m[1][1] = 0.04;
	}
	g.z0_mm = 0;
	g.layer_mm = 0.05;
	memset(&e, 0, sizeof e);
	rc = mesh_layers_surface(&g, &src, 100000000, &m, &e);
	if (rc) {
		fprintf(stderr, "mesh_layers_surface: %d %s\n", rc, e.msg);
		return NULL;
	}
	check_soup(m, r);
	return m;
}

static const double VOXEL = 0.05 * 0.04 * 0.05;

/* Checked surface: manifold, volume = count x voxel within the nudges. */
static void expect(struct stack *s, long euler, size_t comps)
{
	for (int mirror = 0; mirror < 2; mirror++) {
		struct chk r;
		struct mesh *m = surface(s, mirror, &r);
		if (!m) {
			CHECK(m != NULL);
			return;
		}
		CHECK_EQ_INT(r.bad_edges, 0);
		CHECK_EQ_INT(r.same_dir, 0);
		CHECK_EQ_INT(r.bad_links, 0);
		CHECK_EQ_INT(r.repeated, 0);
		CHECK_NEAR(r.volume, (double)count(s) * VOXEL, 1e-3 * VOXEL * (double)m->nv + 1e-12);
		CHECK(r.volume > 0);
		if (euler != -999)
			CHECK_EQ_INT(r.euler, euler);
		if (comps)
			CHECK_EQ_INT(r.components, comps);
		mesh_free(m);
	}
}

static void test_checker_rejects(void)
{
	struct stack s;
	struct chk r;
	struct mesh *m;

	stack_init(&s, 3, 3, 3);
	set(&s, 1, 1, 1);
	m = surface(&s, 0, &r);
	REQUIRE(m);
	CHECK(manifold(&r));
	CHECK_EQ_INT(r.euler, 2);
	/* a removed triangle: border edges */
	m->nt--;
	check_soup(m, &r);
	CHECK(!manifold(&r));
	CHECK(r.bad_edges > 0);
	m->nt++;
	/* a turned triangle: edges traversed the same way */
	{
		uint32_t t = m->tri[0];
		m->tri[0] = m->tri[1];
		m->tri[1] = t;
		check_soup(m, &r);
		CHECK(r.same_dir > 0);
		m->tri[1] = m->tri[0];
		m->tri[0] = t;
	}
	/* two cubes glued at an edge with shared coordinates: edges in 4 faces */
	mesh_free(m);
	{
		struct mesh *a = mesh_new();
		static const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
					    {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
		for (int c = 0; c < 2; c++) {
			for (int k = 0; k < 8; k++)
				mesh_add_vertex(a, v3(c + (k & 1), c + (k >> 1 & 1), (k >> 2 & 1)));
			for (int f = 0; f < 6; f++) {
				uint32_t o = (uint32_t)(8 * c);
				mesh_add_triangle(a, o + q[f][0], o + q[f][1], o + q[f][2]);
				mesh_add_triangle(a, o + q[f][0], o + q[f][2], o + q[f][3]);
			}
		}
		check_soup(a, &r);
		CHECK(r.bad_edges > 0);
		mesh_free(a);
	}
	free(s.v);
}

static void test_shapes(void)
{
	struct stack s;

	/* one voxel, a box */
	stack_init(&s, 4, 4, 4);
	set(&s, 1, 1, 1);
	expect(&s, 2, 1);
	for (int i = 0; i < 4; i++)
		for (int j = 0; j < 3; j++)
			for (int k = 0; k < 4; k++)
				set(&s, i, j, k);
	expect(&s, 2, 1);
	free(s.v);

	/* in-plane diagonal: two voxels meeting along a vertical edge */
	stack_init(&s, 4, 4, 3);
	set(&s, 1, 1, 1);
	set(&s, 2, 2, 1);
	expect(&s, 4, 2);
	/* plus a third making an L over the edge: still apart */
	set(&s, 1, 1, 2);
	expect(&s, 4, 2);
	free(s.v);

	/* across layers: along a horizontal edge, and at a corner only */
	stack_init(&s, 4, 4, 4);
	set(&s, 1, 1, 1);
	set(&s, 2, 1, 2);
	expect(&s, 4, 2);
	free(s.v);
	stack_init(&s, 4, 4, 4);
	set(&s, 1, 1, 1);
	set(&s, 2, 2, 2);
	expect(&s, 4, 2);
	free(s.v);

	/* checkerboard 2 x 2 x 2: 4 voxels meeting at one corner and edges */
	stack_init(&s, 4, 4, 4);
	for (int i = 1; i < 3; i++)
		for (int j = 1; j < 3; j++)
			for (int k = 1; k < 3; k++)
				if ((i + j + k) % 2 == 0)
					set(&s, i, j, k);
	expect(&s, 8, 4);
	free(s.v);

	/* a ring (hole through it: genus 1), then an island in its hole */
	stack_init(&s, 7, 7, 3);
	for (int i = 1; i < 6; i++)
		for (int j = 1; j < 6; j++)
			if (i == 1 || j == 1 || i == 5 || j == 5)
				set(&s, i, j, 1);
	expect(&s, 0, 1);
	set(&s, 3, 3, 1);
	expect(&s, 2, 2);
	/* a closed cavity: the ring capped above and below (sphere with a
	 * sphere inside: two surfaces), the island inside it */
	free(s.v);
	stack_init(&s, 7, 7, 7);
	for (int i = 1; i < 6; i++)
		for (int j = 1; j < 6; j++)
			for (int k = 1; k < 6; k++)
				if (i == 1 || j == 1 || i == 5 || j == 5 || k == 1 || k == 5)
					set(&s, i, j, k);
	set(&s, 3, 3, 3);
	expect(&s, 6, 3);
	free(s.v);

	/* the hex ring: 6 voxels of a 2 x 2 x 2 block, two opposite corners
	 * empty (outside sheets meeting at the centre) */
	stack_init(&s, 4, 4, 4);
	for (int o = 0; o < 8; o++)
		if (o != 0 && o != 7)
			set(&s, 1 + (o & 1), 1 + (o >> 1 & 1), 1 + (o >> 2 & 1));
	expect(&s, -999, 1);
	free(s.v);
}

/* Random stacks at several densities: manifold and exact volume. */
static void test_random(void)
{
	uint64_t seed = 0x9e3779b97f4a7c15ull;
	size_t failed = 0, runs = 0;

	for (int d = 3; d <= 7; d += 2)
		for (int rep = 0; rep < 40; rep++) {
			struct stack s;
			struct chk r;
			struct mesh *m;
			stack_init(&s, 10, 9, 8);
			for (int k = 0; k < s.nz; k++)
				for (int j = 0; j < s.ny; j++)
					for (int i = 0; i < s.nx; i++)
						if (harness_xorshift64(&seed) % 10 < (uint64_t)d)
							set(&s, i, j, k);
			m = surface(&s, rep & 1, &r);
			runs++;
			if (!m || !manifold(&r)) {
				failed++;
				if (failed <= 3 && m)
					fprintf(stderr,
						"random d=%d rep=%d: bad edges %zu same dir %zu "
						"links %zu\n",
						d, rep, r.bad_edges, r.same_dir, r.bad_links);
			}
			if (m)
				CHECK_NEAR(r.volume, (double)count(&s) * VOXEL,
					   1e-3 * VOXEL * (double)m->nv);
			mesh_free(m);
			free(s.v);
		}
	CHECK_EQ_INT(failed, 0);
	(void)runs;
}

static void test_errors(void)
{
	struct mesh_layers_grid g;
	struct stack s;
	struct mesh_layers_src src = {stack_layer, &s};
	struct mesh *m = NULL;
	struct err e;

	stack_init(&s, 2, 2, 2);
	memset(&g, 0, sizeof g);
	g.nx = g.ny = g.nz = 2;
	g.layer_mm = 0.05;
	memset(&e, 0, sizeof e);
	CHECK_EQ_INT(mesh_layers_surface(&g, &src, 100, &m, &e), ERR_PARAM); /* singular */
	g.m[0][0] = g.m[1][1] = 1;
	set(&s, 0, 0, 0);
	CHECK_EQ_INT(mesh_layers_surface(&g, &src, 4, &m, &e), ERR_LIMIT);
	CHECK(m == NULL);
	/* empty stack: empty mesh */
	memset(s.v, 0, 8);
	REQUIRE_OK(mesh_layers_surface(&g, &src, 100, &m, &e), &e);
	CHECK_EQ_INT(m->nt, 0);
	mesh_free(m);
	free(s.v);
}

int main(void)
{
	RUN(test_checker_rejects);
	RUN(test_shapes);
	RUN(test_random);
	RUN(test_errors);
	return harness_report();
}
