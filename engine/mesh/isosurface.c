/* isosurface.c - marching tetrahedra on a regular grid (isosurface.h).
 *
 * The grid is padded by one layer of outside samples; every cube is split
 * into the 6 Kuhn (Freudenthal) tetrahedra around its main diagonal, the
 * surface is the level set of the piecewise-linear interpolant, built one
 * slab of cubes at a time with vertex indices kept for two sample planes.
 * Method, proofs of closure and figures: docs/mesh.md, "Isosurfaces".
 */
#include "engine/mesh/isosurface.h"

#include <assert.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

/* Crossing points stay this fraction of an edge away from its samples, so
 * no vertex lands on a sample and no triangle degenerates (docs/mesh.md). */
#define ISO_T_MIN 1e-3

/* ---- The case table ----
 *
 * Corner c of a cube is at (c & 1, c >> 1 & 1, c >> 2 & 1) from its low
 * corner.  The Kuhn split's edges join corners u, v with u a proper bit
 * subset of v: 12 cube edges, 6 face diagonals (from each face's low
 * corner), the main diagonal, 19 in all.  Edge e is stored with its low
 * corner u and direction d = v ^ u; every grid edge is the edge of some
 * grid point p along one of the 7 directions d = 1..7, so (p, d) names
 * it across cubes.  For each of the 256 corner masks (bit c set = corner c
 * inside) the table lists the triangles of the cube as triples of cube
 * edges, oriented CCW seen from outside. */
#define CUBE_EDGES    19
#define MAX_CUBE_TRIS 12 /* 6 tetrahedra, at most 2 triangles each */

struct iso_table {
	uint8_t u[CUBE_EDGES], d[CUBE_EDGES];
	uint8_t ntri[256];
	uint8_t tri[256][MAX_CUBE_TRIS][3];
};

static void corner_pos(int c, int p[3])
{
	p[0] = c & 1;
	p[1] = c >> 1 & 1;
	p[2] = c >> 2 & 1;
}

/* Append the triangle on cube edges (ea, eb, ec) to case `mask`, turned so
 * that its normal points from corner `in` (inside) towards corner `out`.
 * The test uses the edge midpoints: every crossing with t in (0, 1) gives
 * a non-degenerate triangle (docs/mesh.md), so the sign found at t = 1/2
 * holds for all t. */
static void table_add(struct iso_table *tb, const int eid[8][8], int mask, int a0, int a1, int b0,
                      int b1, int c0, int c1, int in, int out)
{
	int e[3] = {eid[a0][a1], eid[b0][b1], eid[c0][c1]};
	int m[3][3], pi[3], po[3], n[3], r, k = tb->ntri[mask];
	long dot;

	for (int i = 0; i < 3; i++) {
		int pu[3], pv[3];
		corner_pos(tb->u[e[i]], pu);
		corner_pos(tb->u[e[i]] | tb->d[e[i]], pv);
		for (int j = 0; j < 3; j++)
			m[i][j] = pu[j] + pv[j]; /* twice the midpoint */
	}
	{
		int a[3], b[3];
		for (int j = 0; j < 3; j++) {
			a[j] = m[1][j] - m[0][j];
			b[j] = m[2][j] - m[0][j];
		}
		n[0] = a[1] * b[2] - a[2] * b[1];
		n[1] = a[2] * b[0] - a[0] * b[2];
		n[2] = a[0] * b[1] - a[1] * b[0];
	}
	corner_pos(in, pi);
	corner_pos(out, po);
	dot = 0;
	for (int j = 0; j < 3; j++)
		dot += (long)n[j] * (po[j] - pi[j]);
	assert(dot != 0);
	if (dot < 0) {
		r = e[1];
		e[1] = e[2];
		e[2] = r;
	}
	assert(k < MAX_CUBE_TRIS);
	for (int i = 0; i < 3; i++)
		tb->tri[mask][k][i] = (uint8_t)e[i];
	tb->ntri[mask] = (uint8_t)(k + 1);
}

static void table_build(struct iso_table *tb)
{
	int eid[8][8], ne = 0;

	memset(tb, 0, sizeof *tb);
	for (int a = 0; a < 8; a++)
		for (int b = 0; b < 8; b++)
			eid[a][b] = -1;
	for (int u = 0; u < 8; u++)
		for (int v = 0; v < 8; v++)
			if (u != v && (u & v) == u) {
				tb->u[ne] = (uint8_t)u;
				tb->d[ne] = (uint8_t)(u ^ v);
				eid[u][v] = eid[v][u] = ne++;
			}
	assert(ne == CUBE_EDGES);
	for (int mask = 0; mask < 256; mask++) {
		static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
		                               {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
		for (int t = 0; t < 6; t++) {
			/* tetrahedron 0 -> e_a -> e_a + e_b -> 7 along the diagonal */
			int T[4] = {0, 1 << perm[t][0], (1 << perm[t][0]) | (1 << perm[t][1]), 7};
			int ins[4], outs[4], ni = 0, no = 0;
			for (int i = 0; i < 4; i++) {
				if (mask >> T[i] & 1)
					ins[ni++] = T[i];
				else
					outs[no++] = T[i];
			}
			if (ni == 1 || ni == 3) {
				/* one lone corner L: the triangle on its three edges */
				int L = ni == 1 ? ins[0] : outs[0];
				const int *o = ni == 1 ? outs : ins;
				table_add(tb, eid, mask, L, o[0], L, o[1], L, o[2], ins[0],
				          outs[0]);
			} else if (ni == 2) {
				/* quad ac, ad, bd, bc (a, b inside; c, d outside), split
				 * along ac-bd */
				int a = ins[0], b = ins[1], c = outs[0], d = outs[1];
				table_add(tb, eid, mask, a, c, a, d, b, d, a, c);
				table_add(tb, eid, mask, a, c, b, d, b, c, a, c);
			}
		}
	}
}

/* ---- Slab builder ---- */

struct iso_ctx {
	const float *field;
	int nx, ny, nz; /* samples of the caller's grid */
	int px, py, pz; /* padded: n + 2 */
	struct vec3 lo, step;
	float iso;
	size_t max_tri;
	struct mesh *m;
	struct err *e;
};

/* Sample at padded (I, J, K); *pad = 1 on the padding layer (outside). */
static float sample(const struct iso_ctx *c, int I, int J, int K, int *pad)
{
	if (I == 0 || J == 0 || K == 0 || I == c->px - 1 || J == c->py - 1 || K == c->pz - 1) {
		*pad = 1;
		return 0;
	}
	*pad = 0;
	return c->field[((size_t)(K - 1) * (size_t)c->ny + (size_t)(J - 1)) * (size_t)c->nx +
	                (size_t)(I - 1)];
}

/* New vertex on the edge from padded point (I, J, K) along direction d
 * (bits x, y, z).  The crossing parameter is linear interpolation of
 * the two samples, clamped to [ISO_T_MIN, 1 - ISO_T_MIN]; an edge to a
 * padding sample (whose value is not defined) or with non-finite samples
 * crosses at its midpoint. */
static int add_vertex(struct iso_ctx *c, int I, int J, int K, int d, uint32_t *id)
{
	int dx = d & 1, dy = d >> 1 & 1, dz = d >> 2 & 1, pa, pb;
	float fa = sample(c, I, J, K, &pa), fb = sample(c, I + dx, J + dy, K + dz, &pb);
	double t = 0.5;

	if (!pa && !pb) {
		t = ((double)c->iso - fa) / ((double)fb - fa);
		if (!isfinite(t))
			t = 0.5;
		t = t > ISO_T_MIN ? t : ISO_T_MIN;
		t = t < 1 - ISO_T_MIN ? t : 1 - ISO_T_MIN;
	}
	if (c->m->nv >= (size_t)UINT32_MAX) /* indices are uint32_t */
		return ERR_SET(c->e, ERR_LIMIT, "isosurface: more than %u vertices",
		               (unsigned)UINT32_MAX - 1);
	*id = (uint32_t)c->m->nv;
	if (mesh_add_vertex(c->m, v3(c->lo.x + ((I - 1) + t * dx) * c->step.x,
	                             c->lo.y + ((J - 1) + t * dy) * c->step.y,
	                             c->lo.z + ((K - 1) + t * dz) * c->step.z)))
		return ERR_SET(c->e, ERR_NOMEM, "isosurface: out of memory (vertices)");
	return 0;
}

/* One sample plane: inside flags and, per row, the span of inside
 * columns (x0 > x1 when the row has none).  The padding columns are
 * outside, so a row is never all inside and a crossing edge or mixed
 * cube always has an inside sample within a span: loops run over the
 * spans only, which makes empty space nearly free. */
struct iso_plane {
	uint8_t *in;     /* px * py, row-major */
	int *x0, *x1;    /* py entries */
	uint32_t *pv[3]; /* in-plane edge vertices, directions 1 = x, 2 = y, 3 = xy */
};

/* Columns I (padded) where an edge from row J, or a cube from row J,
 * can cross: within one of the spans of the rows given, widened by one
 * to the left; clipped to [0, px - 2]. */
static int span(const struct iso_ctx *c, const struct iso_plane *const *pl, const int *rows, int n,
                int *lo, int *hi)
{
	int a = INT_MAX, b = INT_MIN;

	for (int i = 0; i < n; i++) {
		int J = rows[i];
		if (J < 0 || J >= c->py || pl[i]->x0[J] > pl[i]->x1[J])
			continue;
		a = pl[i]->x0[J] < a ? pl[i]->x0[J] : a;
		b = pl[i]->x1[J] > b ? pl[i]->x1[J] : b;
	}
	if (a > b)
		return 0;
	*lo = a - 1 > 0 ? a - 1 : 0;
	*hi = b < c->px - 2 ? b : c->px - 2;
	return 1;
}

/* Inside flags of padded plane K, and the vertices of its in-plane edges
 * into pv[d - 1][J * px + I].  Entries of edges that do not cross keep
 * stale values: the case table never reads them. */
static int build_plane(struct iso_ctx *c, int K, struct iso_plane *p)
{
	size_t np = (size_t)c->px * (size_t)c->py, px = (size_t)c->px;

	memset(p->in, 0, np);
	for (int J = 0; J < c->py; J++) {
		p->x0[J] = INT_MAX;
		p->x1[J] = INT_MIN;
	}
	if (K == 0 || K == c->pz - 1)
		return 0; /* padding plane: all outside */
	for (int J = 1; J < c->py - 1; J++) {
		const float *row =
		    c->field + ((size_t)(K - 1) * (size_t)c->ny + (size_t)(J - 1)) * (size_t)c->nx;
		uint8_t *ir = p->in + (size_t)J * px;
		int x0 = INT_MAX, x1 = INT_MIN;
		for (int I = 1; I < c->px - 1; I++) {
			ir[I] = row[I - 1] >= c->iso;
			if (ir[I]) {
				x0 = I < x0 ? I : x0;
				x1 = I;
			}
		}
		p->x0[J] = x0;
		p->x1[J] = x1;
	}
	for (int J = 0; J < c->py; J++) {
		const struct iso_plane *pl[2] = {p, p};
		int rows[2] = {J, J + 1}, lo, hi;
		if (!span(c, pl, rows, 2, &lo, &hi))
			continue;
		for (int I = lo; I <= hi; I++) {
			size_t q = (size_t)J * px + (size_t)I;
			for (int d = 1; d <= 3; d++) {
				int I2 = I + (d & 1), J2 = J + (d >> 1), rc;
				if (I2 >= c->px || J2 >= c->py ||
				    p->in[q] == p->in[(size_t)J2 * px + (size_t)I2])
					continue;
				if ((rc = add_vertex(c, I, J, K, d, &p->pv[d - 1][q])) != 0)
					return rc;
			}
		}
	}
	return 0;
}

/* Vertices of the edges from plane K to plane K + 1 (directions 4 = z,
 * 5 = xz, 6 = yz, 7 = xyz) into sv[d - 4][J * px + I]. */
static int build_slab(struct iso_ctx *c, int K, const struct iso_plane *p0,
                      const struct iso_plane *p1, uint32_t *const sv[4])
{
	size_t px = (size_t)c->px;

	for (int J = 0; J < c->py; J++) {
		const struct iso_plane *pl[3] = {p0, p1, p1};
		int rows[3] = {J, J, J + 1}, lo, hi;
		if (!span(c, pl, rows, 3, &lo, &hi))
			continue;
		for (int I = lo; I <= hi; I++) {
			size_t q = (size_t)J * px + (size_t)I;
			for (int d = 4; d <= 7; d++) {
				int I2 = I + (d & 1), J2 = J + (d >> 1 & 1), rc;
				if (I2 >= c->px || J2 >= c->py ||
				    p0->in[q] == p1->in[(size_t)J2 * px + (size_t)I2])
					continue;
				if ((rc = add_vertex(c, I, J, K, d, &sv[d - 4][q])) != 0)
					return rc;
			}
		}
	}
	return 0;
}

/* Triangles of the cubes between planes K and K + 1. */
static int emit_slab(struct iso_ctx *c, const struct iso_table *tb, const struct iso_plane *p0,
                     const struct iso_plane *p1, uint32_t *const sv[4])
{
	/* corner c = x + 2 b with b = y + 2 z: spread puts bit b at 2 b */
	static const uint8_t spread[16] = {0x00, 0x01, 0x04, 0x05, 0x10, 0x11, 0x14, 0x15,
	                                   0x40, 0x41, 0x44, 0x45, 0x50, 0x51, 0x54, 0x55};
	const uint32_t *earr[CUBE_EDGES];
	size_t eoff[CUBE_EDGES], px = (size_t)c->px;

	for (int e = 0; e < CUBE_EDGES; e++) {
		int u = tb->u[e], d = tb->d[e];
		eoff[e] = (size_t)(u >> 1 & 1) * px + (size_t)(u & 1);
		earr[e] = d & 4 ? sv[d - 4] : (u & 4 ? p1 : p0)->pv[d - 1];
	}
	for (int J = 0; J + 1 < c->py; J++) {
		const struct iso_plane *pl[4] = {p0, p0, p1, p1};
		int rows[4] = {J, J + 1, J, J + 1}, lo, hi;
		const uint8_t *a0 = p0->in + (size_t)J * px, *a1 = a0 + px;
		const uint8_t *b0 = p1->in + (size_t)J * px, *b1 = b0 + px;
		unsigned colp;
		if (!span(c, pl, rows, 4, &lo, &hi))
			continue;
		colp = (unsigned)(a0[lo] | a1[lo] << 1 | b0[lo] << 2 | b1[lo] << 3);
		for (int I = lo; I <= hi; I++) {
			unsigned coln = (unsigned)(a0[I + 1] | a1[I + 1] << 1 | b0[I + 1] << 2 |
			                           b1[I + 1] << 3);
			unsigned mask = spread[colp] | (unsigned)spread[coln] << 1;
			size_t base = (size_t)J * px + (size_t)I;
			colp = coln;
			if (mask == 0 || mask == 255)
				continue;
			if (c->m->nt + tb->ntri[mask] > c->max_tri)
				return ERR_SET(c->e, ERR_LIMIT,
				               "isosurface: more than %zu triangles", c->max_tri);
			for (int k = 0; k < tb->ntri[mask]; k++) {
				const uint8_t *t = tb->tri[mask][k];
				uint32_t v0 = earr[t[0]][base + eoff[t[0]]];
				uint32_t v1 = earr[t[1]][base + eoff[t[1]]];
				uint32_t v2 = earr[t[2]][base + eoff[t[2]]];
				assert(v0 < c->m->nv && v1 < c->m->nv && v2 < c->m->nv);
				if (mesh_add_triangle(c->m, v0, v1, v2))
					return ERR_SET(c->e, ERR_NOMEM,
					               "isosurface: out of memory (triangles)");
			}
		}
	}
	return 0;
}

int mesh_isosurface(const float *field, int nx, int ny, int nz, struct vec3 lo_mm,
                    struct vec3 step_mm, float iso, size_t max_triangles, struct mesh **out,
                    struct err *e)
{
	struct iso_ctx c;
	struct iso_table *tb = NULL;
	struct iso_plane pl[2];
	uint8_t *flags = NULL;
	int *spans = NULL;
	uint32_t *buf = NULL, *sv[4];
	size_t np;
	int rc = 0;

	if (!field || !out)
		return ERR_FIELD(e, "field", "isosurface: no field or output");
	if (nx < 1 || ny < 1 || nz < 1 || nx > INT_MAX - 2 || ny > INT_MAX - 2 || nz > INT_MAX - 2)
		return ERR_FIELD(e, "size", "isosurface: grid %d x %d x %d", nx, ny, nz);
	if ((size_t)nx + 2 > SIZE_MAX / ((size_t)ny + 2) / 10 / sizeof(uint32_t) ||
	    (size_t)nx * (size_t)ny > SIZE_MAX / (size_t)nz)
		return ERR_FIELD(e, "size", "isosurface: grid %d x %d x %d too large", nx, ny, nz);
	if (!(step_mm.x > 0 && step_mm.y > 0 && step_mm.z > 0) || !isfinite(step_mm.x) ||
	    !isfinite(step_mm.y) || !isfinite(step_mm.z) || !isfinite(lo_mm.x) ||
	    !isfinite(lo_mm.y) || !isfinite(lo_mm.z))
		return ERR_FIELD(e, "step_mm", "isosurface: steps must be finite and > 0");
	if (isnan(iso))
		return ERR_FIELD(e, "iso", "isosurface: iso is NaN");

	memset(&c, 0, sizeof c);
	c.field = field;
	c.nx = nx;
	c.ny = ny;
	c.nz = nz;
	c.px = nx + 2;
	c.py = ny + 2;
	c.pz = nz + 2;
	c.lo = lo_mm;
	c.step = step_mm;
	c.iso = iso;
	c.max_tri = max_triangles;
	c.e = e;
	np = (size_t)c.px * (size_t)c.py;

	/* two planes of flags, 2 x 3 in-plane and 4 slab index arrays: 42
	 * bytes per padded sample of one plane, whatever nz */
	c.m = mesh_new();
	tb = mem_alloc(sizeof *tb);
	flags = mem_alloc(2 * np);
	spans = mem_alloc(4 * (size_t)c.py * sizeof *spans);
	buf = mem_alloc(10 * np * sizeof *buf);
	if (!c.m || !tb || !flags || !spans || !buf) {
		rc = ERR_SET(e, ERR_NOMEM, "isosurface: out of memory (%d x %d slab)", c.px, c.py);
		goto out;
	}
	table_build(tb);
	for (int i = 0; i < 2; i++) {
		pl[i].in = flags + (size_t)i * np;
		pl[i].x0 = spans + (size_t)(2 * i) * (size_t)c.py;
		pl[i].x1 = spans + (size_t)(2 * i + 1) * (size_t)c.py;
		for (int d = 0; d < 3; d++)
			pl[i].pv[d] = buf + (size_t)(3 * i + d) * np;
	}
	for (int d = 0; d < 4; d++)
		sv[d] = buf + (size_t)(6 + d) * np;

	if ((rc = build_plane(&c, 0, &pl[0])) != 0)
		goto out;
	for (int K = 0; K + 1 < c.pz; K++) {
		struct iso_plane *cur = &pl[K & 1], *nxt = &pl[(K & 1) ^ 1];
		if ((rc = build_plane(&c, K + 1, nxt)) != 0 ||
		    (rc = build_slab(&c, K, cur, nxt, sv)) != 0 ||
		    (rc = emit_slab(&c, tb, cur, nxt, sv)) != 0)
			goto out;
	}
	*out = c.m;
	c.m = NULL;
out:
	mesh_free(c.m);
	mem_free(tb);
	mem_free(flags);
	mem_free(spans);
	mem_free(buf);
	return rc;
}
