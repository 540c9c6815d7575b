/* layers.c - the boundary surface of a stack of binary layer masks
 * (layers.h): pixel sides between inside and outside voxels, one sheet
 * table over the 256 configurations of the 8 voxels round a lattice
 * point, streamed plane by plane.  Design: docs/mesh.md "Layer stacks".
 */
#include "engine/mesh/layers.h"

#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

/* ---- The sheet table ----
 *
 * The 8 voxels round a lattice point p are its octants o (bit 0: +x side,
 * bit 1: +y, bit 2: +z).  The 12 voxel sides through p are named by face
 * f = 4 a + r: the side normal to axis a between the octant with bit a
 * clear and the one with it set, r holding the two other bits (lower axis
 * first).  A side is on the surface when one octant is inside and the
 * other not.  Round each of the 6 half-edges from p (axis a, sign s) lie 4
 * sides; 2 on the surface are joined, 4 (inside voxels diagonal across the
 * edge) are joined two by two by the inside voxel they bound, so voxels
 * that meet only along the edge stay apart (6-connected inside).  The
 * classes of joined sides are the sheets of the surface at p, one vertex
 * each.  A split vertex moves towards the side its sheet wraps (the fewer
 * octants of its faces: an inside corner it bounds, or an outside one), so
 * the copies separate. */
#define ML_FACES  12
#define ML_SHEETS 8

struct ml_table {
	uint8_t nsheet[256];
	int8_t sheet[256][ML_FACES];    /* -1: not on the surface */
	double dir[256][ML_SHEETS][3];  /* unit nudge, lattice frame; 0 with one sheet */
};

static void face_axes(int a, int *b, int *c)
{
	*b = a == 0 ? 1 : 0;
	*c = a == 2 ? 1 : 2;
}

/* Octants on the low and high side of face f. */
static void face_octants(int f, int *lo, int *hi)
{
	int a = f / 4, r = f % 4, b, c;

	face_axes(a, &b, &c);
	*lo = (r & 1) << b | (r >> 1 & 1) << c;
	*hi = *lo | 1 << a;
}

static int uf_find(int *p, int x)
{
	while (p[x] != x)
		x = p[x] = p[p[x]];
	return x;
}

static int bits(unsigned x)
{
	int n = 0;

	for (; x; x &= x - 1)
		n++;
	return n;
}

static void table_build(struct ml_table *t)
{
	memset(t, 0, sizeof *t);
	for (int cfg = 0; cfg < 256; cfg++) {
		int par[ML_FACES], on[ML_FACES], id[ML_FACES], n = 0;
		unsigned vin[ML_SHEETS] = {0}, vout[ML_SHEETS] = {0};

		for (int f = 0; f < ML_FACES; f++) {
			int lo, hi;
			face_octants(f, &lo, &hi);
			par[f] = f;
			on[f] = (cfg >> lo & 1) != (cfg >> hi & 1);
			t->sheet[cfg][f] = -1;
		}
		for (int a = 0; a < 3; a++)
			for (int s = 0; s < 2; s++) {
				int fs[4], k = 0;
				for (int f = 0; f < ML_FACES; f++) {
					int lo, hi;
					face_octants(f, &lo, &hi);
					if (f / 4 != a && (lo >> a & 1) == s && on[f])
						fs[k++] = f;
				}
				if (k == 2) {
					par[uf_find(par, fs[0])] = uf_find(par, fs[1]);
				} else if (k == 4) {
					for (int x = 0; x < 4; x++)
						for (int y = x + 1; y < 4; y++) {
							int l1, h1, l2, h2, v1, v2;
							face_octants(fs[x], &l1, &h1);
							face_octants(fs[y], &l2, &h2);
							v1 = cfg >> l1 & 1 ? l1 : h1;
							v2 = cfg >> l2 & 1 ? l2 : h2;
							if (v1 == v2)
								par[uf_find(par, fs[x])] =
									uf_find(par, fs[y]);
						}
				}
			}
		for (int f = 0; f < ML_FACES; f++)
			id[f] = -1;
		for (int f = 0; f < ML_FACES; f++) {
			int r, lo, hi;
			if (!on[f])
				continue;
			r = uf_find(par, f);
			if (id[r] < 0)
				id[r] = n++;
			t->sheet[cfg][f] = (int8_t)id[r];
			face_octants(f, &lo, &hi);
			if (cfg >> lo & 1) {
				vin[id[r]] |= 1u << lo;
				vout[id[r]] |= 1u << hi;
			} else {
				vin[id[r]] |= 1u << hi;
				vout[id[r]] |= 1u << lo;
			}
		}
		t->nsheet[cfg] = (uint8_t)n;
		for (int k = 0; n > 1 && k < n; k++) {
			unsigned set = bits(vin[k]) <= bits(vout[k])
					       ? vin[k]
					       : vout[k];
			double d[3] = {0, 0, 0}, len;
			for (int o = 0; o < 8; o++)
				if (set >> o & 1)
					for (int x = 0; x < 3; x++)
						d[x] += (o >> x & 1) ? 1 : -1;
			len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
			for (int x = 0; x < 3 && len > 0; x++)
				t->dir[cfg][k][x] = d[x] / len;
		}
	}
}

/* ---- Streaming over the planes ---- */

struct ml_plane {
	uint8_t *cfg;   /* (nx + 1) (ny + 1) configurations */
	uint32_t *base; /* first vertex of each lattice point with cfg != 0, 255 */
};

struct ml_ctx {
	const struct mesh_layers_grid *g;
	const struct ml_table *t;
	struct mesh *m;
	size_t max_tri;
	int flip;       /* det m < 0: turn every face */
	double nudge;
	const uint8_t *ring[3]; /* layer k's mask at ring[k % 3] (P - 2 .. P held) */
	uint64_t *midkey;       /* midpoints of edges in four faces: open addressing, */
	uint32_t *midvid;       /* key = edge and voxel + 1 (0 empty), value = vertex */
	size_t nmid, midcap;
	struct err *e;
};

static inline int inside(const struct ml_ctx *c, const uint8_t *mask, int i, int j)
{
	return mask && i >= 0 && j >= 0 && i < c->g->nx && j < c->g->ny &&
	       mask[(size_t)j * (size_t)c->g->nx + (size_t)i];
}

/* Columns holding an inside pixel in rows j of masks a, b: [*x0, *x1];
 * 0 when none. */
static int row_span(const struct ml_ctx *c, const uint8_t *a, const uint8_t *b, int j, int *x0,
		    int *x1)
{
	int lo = c->g->nx, hi = -1;

	if (j < 0 || j >= c->g->ny)
		return 0;
	for (int k = 0; k < 2; k++) {
		const uint8_t *r = (k ? b : a);
		if (!r)
			continue;
		r += (size_t)j * (size_t)c->g->nx;
		for (int i = 0; i < c->g->nx; i++)
			if (r[i]) {
				lo = i < lo ? i : lo;
				break;
			}
		for (int i = c->g->nx - 1; i >= 0; i--)
			if (r[i]) {
				hi = i > hi ? i : hi;
				break;
			}
	}
	*x0 = lo;
	*x1 = hi;
	return lo <= hi;
}

/* Configurations and vertices of lattice plane P, between masks lo
 * (layer P - 1) and hi (layer P). */
static int build_plane(struct ml_ctx *c, int P, const uint8_t *lo, const uint8_t *hi,
		       struct ml_plane *pl)
{
	const struct mesh_layers_grid *g = c->g;
	size_t w = (size_t)g->nx + 1;

	memset(pl->cfg, 0, w * ((size_t)g->ny + 1));
	for (int J = 0; J <= g->ny; J++) {
		int a0, a1, b0, b1, x0, x1, ha = row_span(c, lo, hi, J - 1, &a0, &a1),
					    hb = row_span(c, lo, hi, J, &b0, &b1);
		if (!ha && !hb)
			continue;
		x0 = !ha ? b0 : !hb ? a0 : a0 < b0 ? a0 : b0;
		x1 = !ha ? b1 : !hb ? a1 : a1 > b1 ? a1 : b1;
		for (int I = x0; I <= x1 + 1; I++) {
			unsigned cfg = 0;
			for (int o = 0; o < 8; o++)
				if (inside(c, o & 4 ? hi : lo, I - 1 + (o & 1), J - 1 + (o >> 1 & 1)))
					cfg |= 1u << o;
			if (cfg == 0 || cfg == 255)
				continue;
			pl->cfg[(size_t)J * w + (size_t)I] = (uint8_t)cfg;
			if (c->m->nv + c->t->nsheet[cfg] >= (size_t)UINT32_MAX)
				return ERR_SET(c->e, ERR_LIMIT, "layer surface: too many vertices");
			pl->base[(size_t)J * w + (size_t)I] = (uint32_t)c->m->nv;
			for (int s = 0; s < c->t->nsheet[cfg]; s++) {
				const double *d = c->t->dir[cfg][s];
				double dx = g->m[0][0] * d[0] + g->m[0][1] * d[1];
				double dy = g->m[1][0] * d[0] + g->m[1][1] * d[1];
				double dz = g->layer_mm * d[2];
				double len = sqrt(dx * dx + dy * dy + dz * dz);
				double k = len > 0 ? c->nudge / len : 0;
				struct vec3 p = v3(g->o[0] + g->m[0][0] * I + g->m[0][1] * J + k * dx,
						   g->o[1] + g->m[1][0] * I + g->m[1][1] * J + k * dy,
						   g->z0_mm + g->layer_mm * P + k * dz);
				if (mesh_add_vertex(c->m, p))
					return ERR_SET(c->e, ERR_NOMEM,
						       "layer surface: out of memory (vertices)");
			}
		}
	}
	return 0;
}

/* Vertex of face f's sheet at lattice point (I, J) of plane pl. */
static uint32_t vid(const struct ml_ctx *c, const struct ml_plane *pl, int I, int J, int f)
{
	size_t q = (size_t)J * ((size_t)c->g->nx + 1) + (size_t)I;
	int s = c->t->sheet[pl->cfg[q]][f];

	return pl->base[q] + (uint32_t)(s < 0 ? 0 : s);
}

/* Is voxel (i, j) of layer k inside?  Layers k outside [0, nz) are not;
 * the caller holds layers P - 2 .. P in c->ring. */
static int vox(const struct ml_ctx *c, int i, int j, int k)
{
	if (k < 0 || k >= c->g->nz)
		return 0;
	return inside(c, c->ring[k % 3], i, j);
}

/* The lattice edge from (I, J, P) along axis a (0 x, 1 y, 2 z), seen from
 * face f whose inside voxel is (vi, vj, vk): UINT32_MAX when the edge lies
 * in two faces; when it lies in four (inside voxels diagonal across it),
 * the vertex at its midpoint for f's pair (the two faces of f's inside
 * voxel), made on first use and moved towards that voxel. */
static int mid_vertex(struct ml_ctx *c, int I, int J, int P, int a, int vi, int vj, int vk,
		      uint32_t *out)
{
	/* the 4 voxels round the edge in cyclic order, as (di, dj, dk) offsets
	 * from (I, J, P) */
	static const int8_t off[3][4][3] = {
		{{0, -1, -1}, {0, 0, -1}, {0, 0, 0}, {0, -1, 0}},
		{{-1, 0, -1}, {0, 0, -1}, {0, 0, 0}, {-1, 0, 0}},
		{{-1, -1, 0}, {0, -1, 0}, {0, 0, 0}, {-1, 0, 0}},
	};
	const struct mesh_layers_grid *g = c->g;
	int in[4], who = -1;
	uint64_t key;
	size_t h;

	*out = UINT32_MAX;
	for (int q = 0; q < 4; q++) {
		int i = I + off[a][q][0], j = J + off[a][q][1], k = P + off[a][q][2];
		in[q] = vox(c, i, j, k);
		if (i == vi && j == vj && k == vk)
			who = q;
	}
	if (!(in[0] == in[2] && in[1] == in[3] && in[0] != in[1]) || who < 0)
		return 0;
	key = ((((uint64_t)I << 16 | (uint64_t)J) << 16 | (uint64_t)P) << 2 | (uint64_t)a) << 2 |
	      (uint64_t)who;
	key += 1; /* 0 marks an empty slot */
	if (2 * (c->nmid + 1) > c->midcap) {
		size_t ncap = c->midcap ? 2 * c->midcap : 1024;
		uint64_t *nk = mem_calloc(ncap, sizeof *nk);
		uint32_t *nv = mem_alloc(ncap * sizeof *nv);
		if (!nk || !nv) {
			mem_free(nk);
			mem_free(nv);
			return ERR_SET(c->e, ERR_NOMEM, "layer surface: out of memory (midpoints)");
		}
		for (size_t s = 0; s < c->midcap; s++) {
			if (!c->midkey[s])
				continue;
			h = (size_t)(c->midkey[s] * 0x9e3779b97f4a7c15ull >> 20) & (ncap - 1);
			while (nk[h])
				h = (h + 1) & (ncap - 1);
			nk[h] = c->midkey[s];
			nv[h] = c->midvid[s];
		}
		mem_free(c->midkey);
		mem_free(c->midvid);
		c->midkey = nk;
		c->midvid = nv;
		c->midcap = ncap;
	}
	h = (size_t)(key * 0x9e3779b97f4a7c15ull >> 20) & (c->midcap - 1);
	while (c->midkey[h] && c->midkey[h] != key)
		h = (h + 1) & (c->midcap - 1);
	if (!c->midkey[h]) {
		/* lattice midpoint, nudged towards the voxel's centre */
		double lx = I + (a == 0 ? 0.5 : 0), ly = J + (a == 1 ? 0.5 : 0), lz = P + (a == 2 ? 0.5 : 0);
		double d[3] = {vi + 0.5 - lx, vj + 0.5 - ly, vk + 0.5 - lz};
		double dx = g->m[0][0] * d[0] + g->m[0][1] * d[1];
		double dy = g->m[1][0] * d[0] + g->m[1][1] * d[1];
		double dz = g->layer_mm * d[2], len = sqrt(dx * dx + dy * dy + dz * dz);
		double k = len > 0 ? c->nudge / len : 0;
		if (c->m->nv + 1 >= (size_t)UINT32_MAX)
			return ERR_SET(c->e, ERR_LIMIT, "layer surface: too many vertices");
		if (mesh_add_vertex(c->m, v3(g->o[0] + g->m[0][0] * lx + g->m[0][1] * ly + k * dx,
					     g->o[1] + g->m[1][0] * lx + g->m[1][1] * ly + k * dy,
					     g->z0_mm + g->layer_mm * lz + k * dz)))
			return ERR_SET(c->e, ERR_NOMEM, "layer surface: out of memory (vertices)");
		c->midkey[h] = key;
		c->midvid[h] = (uint32_t)(c->m->nv - 1);
		c->nmid++;
	}
	*out = c->midvid[h];
	return 0;
}

/* One pixel side: corners v[0..3] (CCW seen from outside unless rev, or
 * the frame mirrors) with mid[s] the midpoint of side v[s] -> v[s + 1]
 * (UINT32_MAX: none).  Two triangles, or a fan round the centre when a
 * side has a midpoint. */
static int face(struct ml_ctx *c, const uint32_t v[4], const uint32_t mid[4], int rev)
{
	uint32_t L[8];
	int n = 0;

	for (int s = 0; s < 4; s++) {
		L[n++] = v[s];
		if (mid[s] != UINT32_MAX)
			L[n++] = mid[s];
	}
	if (rev ^ c->flip)
		for (int i = 0; i < n / 2; i++) {
			uint32_t t = L[i];
			L[i] = L[n - 1 - i];
			L[n - 1 - i] = t;
		}
	if (c->m->nt + (size_t)n > c->max_tri)
		return ERR_SET(c->e, ERR_LIMIT, "layer surface: more than %zu triangles",
			       c->max_tri);
	if (n == 4) {
		if (mesh_add_triangle(c->m, L[0], L[1], L[2]) ||
		    mesh_add_triangle(c->m, L[0], L[2], L[3]))
			return ERR_SET(c->e, ERR_NOMEM, "layer surface: out of memory (triangles)");
		return 0;
	}
	{
		struct vec3 p = v3(0, 0, 0);
		uint32_t ctr;
		for (int s = 0; s < 4; s++)
			p = v3(p.x + c->m->v[v[s]].x / 4, p.y + c->m->v[v[s]].y / 4,
			       p.z + c->m->v[v[s]].z / 4);
		if (c->m->nv + 1 >= (size_t)UINT32_MAX)
			return ERR_SET(c->e, ERR_LIMIT, "layer surface: too many vertices");
		ctr = (uint32_t)c->m->nv;
		if (mesh_add_vertex(c->m, p))
			return ERR_SET(c->e, ERR_NOMEM, "layer surface: out of memory (vertices)");
		for (int i = 0; i < n; i++)
			if (mesh_add_triangle(c->m, ctr, L[i], L[(i + 1) % n]))
				return ERR_SET(c->e, ERR_NOMEM,
					       "layer surface: out of memory (triangles)");
	}
	return 0;
}

/* Horizontal sides in plane P (pl) between lo (layer P - 1) and hi. */
static int emit_caps(struct ml_ctx *c, int P, const struct ml_plane *pl, const uint8_t *lo,
		     const uint8_t *hi)
{
	for (int j = 0; j < c->g->ny; j++) {
		int x0, x1;
		if (!row_span(c, lo, hi, j, &x0, &x1))
			continue;
		for (int i = x0; i <= x1; i++) {
			int below = inside(c, lo, i, j), k, rc;
			uint32_t v[4], mid[4];
			if (below == inside(c, hi, i, j))
				continue;
			k = below ? P - 1 : P;
			/* corner (I, J): octant of pixel (i, j) is (i == I, j == J) */
			v[0] = vid(c, pl, i, j, 8 + 3);
			v[1] = vid(c, pl, i + 1, j, 8 + 2);
			v[2] = vid(c, pl, i + 1, j + 1, 8 + 0);
			v[3] = vid(c, pl, i, j + 1, 8 + 1);
			if ((rc = mid_vertex(c, i, j, P, 0, i, j, k, &mid[0])) != 0 ||
			    (rc = mid_vertex(c, i + 1, j, P, 1, i, j, k, &mid[1])) != 0 ||
			    (rc = mid_vertex(c, i, j + 1, P, 0, i, j, k, &mid[2])) != 0 ||
			    (rc = mid_vertex(c, i, j, P, 1, i, j, k, &mid[3])) != 0)
				return rc;
			/* mid[2], mid[3] run against the corner order: same edges */
			if ((rc = face(c, v, mid, !below)) != 0)
				return rc;
		}
	}
	return 0;
}

/* Vertical sides of layer k = P - 1 (mask ly) between planes p0 (k) and
 * p1 (k + 1). */
static int emit_walls(struct ml_ctx *c, int k, const struct ml_plane *p0,
		      const struct ml_plane *p1, const uint8_t *ly)
{
	for (int j = 0; j < c->g->ny; j++) {
		int x0, x1;
		if (!row_span(c, ly, NULL, j, &x0, &x1))
			continue;
		for (int i = x0; i <= x1; i++) {
			uint32_t v[4], mid[4];
			int rc;
			if (!inside(c, ly, i, j))
				continue;
			/* x sides: face 0 + (ybit | zbit << 1) */
			for (int s = 0; s < 2; s++) {
				int I = i + s; /* lattice line of the side */
				if (inside(c, ly, s ? i + 1 : i - 1, j))
					continue;
				v[0] = vid(c, p0, I, j, 0 + 3);
				v[1] = vid(c, p0, I, j + 1, 0 + 2);
				v[2] = vid(c, p1, I, j + 1, 0 + 0);
				v[3] = vid(c, p1, I, j, 0 + 1);
				if ((rc = mid_vertex(c, I, j, k, 1, i, j, k, &mid[0])) != 0 ||
				    (rc = mid_vertex(c, I, j + 1, k, 2, i, j, k, &mid[1])) != 0 ||
				    (rc = mid_vertex(c, I, j, k + 1, 1, i, j, k, &mid[2])) != 0 ||
				    (rc = mid_vertex(c, I, j, k, 2, i, j, k, &mid[3])) != 0 ||
				    (rc = face(c, v, mid, !s)) != 0)
					return rc;
			}
			/* y sides: face 4 + (xbit | zbit << 1) */
			for (int s = 0; s < 2; s++) {
				int J = j + s;
				if (inside(c, ly, i, s ? j + 1 : j - 1))
					continue;
				v[0] = vid(c, p0, i, J, 4 + 3);
				v[1] = vid(c, p1, i, J, 4 + 1);
				v[2] = vid(c, p1, i + 1, J, 4 + 0);
				v[3] = vid(c, p0, i + 1, J, 4 + 2);
				if ((rc = mid_vertex(c, i, J, k, 2, i, j, k, &mid[0])) != 0 ||
				    (rc = mid_vertex(c, i, J, k + 1, 0, i, j, k, &mid[1])) != 0 ||
				    (rc = mid_vertex(c, i + 1, J, k, 2, i, j, k, &mid[2])) != 0 ||
				    (rc = mid_vertex(c, i, J, k, 0, i, j, k, &mid[3])) != 0 ||
				    (rc = face(c, v, mid, !s)) != 0)
					return rc;
			}
		}
	}
	return 0;
}

int mesh_layers_surface(const struct mesh_layers_grid *g, const struct mesh_layers_src *src,
			size_t max_triangles, struct mesh **out, struct err *e)
{
	struct ml_ctx c;
	struct ml_table *t = NULL;
	struct ml_plane pl[2];
	uint8_t *mask[3] = {NULL, NULL, NULL};
	size_t np, nm;
	double det;
	int rc = 0;

	if (!g || !src || !src->layer || !out)
		return ERR_FIELD(e, "grid", "layer surface: no grid, source or output");
	if (g->nx < 1 || g->ny < 1 || g->nz < 1 || g->nx > 65535 || g->ny > 65535 ||
	    g->nz > 65535)
		return ERR_FIELD(e, "grid", "layer surface: stack %d x %d x %d", g->nx, g->ny,
				 g->nz);
	det = g->m[0][0] * g->m[1][1] - g->m[0][1] * g->m[1][0];
	if (!isfinite(det) || det == 0 || !(g->layer_mm > 0) || !isfinite(g->layer_mm) ||
	    !isfinite(g->o[0]) || !isfinite(g->o[1]) || !isfinite(g->z0_mm) ||
	    !(g->nudge_mm >= 0))
		return ERR_FIELD(e, "grid", "layer surface: singular or non-finite frame");
	memset(&c, 0, sizeof c);
	c.g = g;
	c.max_tri = max_triangles;
	c.flip = det < 0;
	c.nudge = g->nudge_mm > 0 ? g->nudge_mm : MESH_LAYERS_NUDGE_MM;
	c.e = e;
	nm = (size_t)g->nx * (size_t)g->ny;
	np = ((size_t)g->nx + 1) * ((size_t)g->ny + 1);
	memset(pl, 0, sizeof pl);
	c.m = mesh_new();
	t = mem_alloc(sizeof *t);
	for (int k = 0; k < 3; k++) {
		mask[k] = mem_alloc(nm);
		c.ring[k] = mask[k];
		if (k == 2)
			break;
		pl[k].cfg = mem_alloc(np);
		pl[k].base = mem_alloc(np * sizeof *pl[k].base);
		if (!mask[k] || !pl[k].cfg || !pl[k].base)
			rc = -1;
	}
	if (!mask[2])
		rc = -1;
	if (rc || !c.m || !t) {
		rc = ERR_SET(e, ERR_NOMEM, "layer surface: out of memory (%d x %d planes)", g->nx,
			     g->ny);
		goto out;
	}
	table_build(t);
	c.t = t;
	/* plane P lies between layer P - 1 and layer P (mask[k % 3] holds
	 * layer k); layers -1 and nz are empty */
	for (int P = 0; P <= g->nz; P++) {
		const uint8_t *lo = P > 0 ? mask[(P - 1) % 3] : NULL;
		const uint8_t *hi = P < g->nz ? mask[P % 3] : NULL;
		struct ml_plane *cur = &pl[P & 1], *prev = &pl[(P + 1) & 1];
		if (P < g->nz && (rc = src->layer(src->ctx, P, mask[P % 3], e)) != 0)
			goto out;
		if ((rc = build_plane(&c, P, lo, hi, cur)) != 0 ||
		    (rc = emit_caps(&c, P, cur, lo, hi)) != 0)
			goto out;
		if (P > 0 && (rc = emit_walls(&c, P - 1, prev, cur, lo)) != 0)
			goto out;
	}
	*out = c.m;
	c.m = NULL;
out:
	mesh_free(c.m);
	mem_free(t);
	for (int k = 0; k < 3; k++)
		mem_free(mask[k]);
	for (int k = 0; k < 2; k++) {
		mem_free(pl[k].cfg);
		mem_free(pl[k].base);
	}
	mem_free(c.midkey);
	mem_free(c.midvid);
	return rc;
}
