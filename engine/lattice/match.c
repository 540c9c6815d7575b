/* match.c - density matching (paper 000 section 5.3) and its measurement.
 *
 * Radii start at r0 = 2 r_min; R = factor * 1.4 r0 while matching (radii
 * stay within [r_min, 1.4 r0], see RCAP_RATIO).  Steps (docs/lattice.md 4.4):
 *  1. each tet's target: the largest target of the voxel centres inside
 *     it, else the field at its centroid;
 *  2. a tet whose Monte-Carlo density with all radii at 1.4 r0 stays below
 *     its target is split 1:8 (edge midpoints shared, so neighbours see the
 *     split edges as two struts), recursively, while edges stay >= 4 r0;
 *  3. per tet, binary search of a common factor on its own struts' radii
 *     (others at r0); a strut takes the mean factor of its tets;
 *  4. per voxel, binary search of a common ratio for the struts crossing
 *     it; a strut keeps the smallest ratio any of its voxels asks for
 *     (repeated `passes` times, then once more after R is refitted to
 *     factor * the largest radius).
 * Densities are Monte-Carlo fractions of sample points where F > C;
 * samples are fixed per tet/voxel (common random numbers), so every
 * binary search is over a monotone function.
 */
#include "engine/lattice/gen.h"
#include "engine/lattice/kernel.h"
#include "engine/lattice/strutgrid.h"
#include "engine/lattice/voxgrid.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/progress.h"
#include "engine/core/rng.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TET_SAMPLES 64
/* Largest radius while matching, relative to r0.  The field of a strut
 * much thinner than R hardly falls with its radius (the weight tends to
 * 15 C / (16 R) as r -> 0) and blends into blobs at the nodes, so radii
 * stay within [r_min, 1.4 r0] and R = factor * 1.4 r0 (~2 r0 with the
 * default 1.5): densities then follow the radii (docs/lattice.md 4.4). */
#define RCAP_RATIO 1.4
#define BISECT_STEPS 18
#define MAX_THREADS 64

/* ---- the evolving tet mesh and its struts ---- */

struct emap { /* open addressing: edge key (a << 32 | b, a < b) -> midpoint */
	uint64_t *key;
	uint32_t *val;
	size_t cap, n;
};

static uint64_t ekey(uint32_t a, uint32_t b)
{
	return a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
}

static size_t ehash(uint64_t k, size_t cap)
{
	k ^= k >> 33;
	k *= 0xff51afd7ed558ccdull;
	k ^= k >> 33;
	return (size_t)k & (cap - 1);
}

static int emap_get(const struct emap *m, uint64_t k, uint32_t *v)
{
	if (!m->cap)
		return 0;
	for (size_t i = ehash(k, m->cap);; i = (i + 1) & (m->cap - 1)) {
		if (m->key[i] == 0)
			return 0;
		if (m->key[i] == k) {
			*v = m->val[i];
			return 1;
		}
	}
}

static int emap_put(struct emap *m, uint64_t k, uint32_t v)
{
	if (2 * (m->n + 1) > m->cap) {
		struct emap nm;
		nm.cap = m->cap ? 2 * m->cap : 1024;
		nm.n = 0;
		nm.key = mem_calloc(nm.cap, sizeof *nm.key);
		nm.val = mem_alloc(nm.cap * sizeof *nm.val);
		if (!nm.key || !nm.val) {
			mem_free(nm.key);
			mem_free(nm.val);
			return ERR_NOMEM;
		}
		for (size_t i = 0; i < m->cap; i++)
			if (m->key[i])
				emap_put(&nm, m->key[i], m->val[i]);
		mem_free(m->key);
		mem_free(m->val);
		*m = nm;
	}
	for (size_t i = ehash(k, m->cap);; i = (i + 1) & (m->cap - 1))
		if (m->key[i] == 0 || m->key[i] == k) {
			m->n += m->key[i] == 0;
			m->key[i] = k;
			m->val[i] = v;
			return 0;
		}
}

struct mtet {
	uint32_t v[4];   /* positively oriented */
	float target;    /* desired solid fraction */
	uint8_t level;   /* 1:8 subdivisions above it */
};

struct mstate {
	const struct lattice_match_opts *o;
	const struct lattice_domain *d;
	const struct voxels *vox;
	struct vec3 *p;
	size_t np, pcap;
	struct mtet *tet;
	size_t nt, tcap;
	struct emap mid;
	/* struts */
	uint32_t *ab;        /* 2 per strut */
	uint64_t *skey;      /* sorted keys, parallel to ab */
	size_t ns;
	double *r;
	struct strut_grid grid;
	double R, r0, rcap;
	struct strut_pairs pairs[MAX_THREADS];
	/* matched voxel -> struts crossing it (CSR), valid for this strut set */
	uint32_t *vs_start, *vs_item;
	int vs_valid;
};

static const int EV[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return x < y ? -1 : x > y;
}

/* Emit the struts along tet edge (a, b), expanded through midpoints. */
static int expand_edge(const struct mstate *m, uint32_t a, uint32_t b, uint64_t **out,
		       size_t *n, size_t *cap, int depth)
{
	uint32_t c;

	if (depth < 16 && emap_get(&m->mid, ekey(a, b), &c))
		return expand_edge(m, a, c, out, n, cap, depth + 1) ||
		       expand_edge(m, c, b, out, n, cap, depth + 1);
	if (mem_grow((void **)out, cap, *n + 1, sizeof **out))
		return ERR_NOMEM;
	(*out)[(*n)++] = ekey(a, b);
	return 0;
}

/* Rebuild the strut list from the tets (unique expanded edges); struts
 * that existed keep their radius, new ones start at r0.  Rebuilds the
 * point-query grid. */
static int rebuild_struts(struct mstate *m, struct err *e)
{
	uint64_t *k = NULL;
	size_t n = 0, cap = 0, u = 0;
	double *nr;
	uint32_t *nab;

	for (size_t t = 0; t < m->nt; t++)
		for (int j = 0; j < 6; j++)
			if (expand_edge(m, m->tet[t].v[EV[j][0]], m->tet[t].v[EV[j][1]], &k, &n, &cap,
					0)) {
				mem_free(k);
				return ERR_SET(e, ERR_NOMEM, "out of memory for struts");
			}
	qsort(k, n, sizeof *k, cmp_u64);
	for (size_t i = 0; i < n; i++)
		if (i == 0 || k[i] != k[i - 1])
			k[u++] = k[i];
	nr = mem_alloc((u ? u : 1) * sizeof *nr);
	nab = mem_alloc((u ? u : 1) * 2 * sizeof *nab);
	if (!nr || !nab) {
		mem_free(k);
		mem_free(nr);
		mem_free(nab);
		return ERR_SET(e, ERR_NOMEM, "out of memory for struts");
	}
	for (size_t i = 0; i < u; i++) {
		uint64_t *hit = m->skey ? bsearch(&k[i], m->skey, m->ns, sizeof *k, cmp_u64) : NULL;
		nr[i] = hit ? m->r[hit - m->skey] : m->r0;
		nab[2 * i] = (uint32_t)(k[i] >> 32);
		nab[2 * i + 1] = (uint32_t)k[i];
	}
	mem_free(m->skey);
	mem_free(m->r);
	mem_free(m->ab);
	m->skey = k;
	m->r = nr;
	m->ab = nab;
	m->ns = u;
	m->vs_valid = 0;
	strut_grid_fini(&m->grid);
	{
		double len = 0;
		for (size_t i = 0; i < u; i++)
			len += v3_dist(m->p[nab[2 * i]], m->p[nab[2 * i + 1]]);
		/* cells of a quarter strut length: short lists, few cells per strut */
		return strut_grid_init(&m->grid, m->p, m->ab, m->ns, m->R,
				       fmax(0.6 * m->R, u ? 0.25 * len / u : m->R), e);
	}
}

/* Strut indices of tet t (its expanded edges), at most cap. */
static size_t tet_struts(const struct mstate *m, size_t t, uint32_t *idx, size_t cap)
{
	uint64_t *k = NULL;
	size_t n = 0, kc = 0, out = 0;

	for (int j = 0; j < 6; j++)
		if (expand_edge(m, m->tet[t].v[EV[j][0]], m->tet[t].v[EV[j][1]], &k, &n, &kc, 0))
			break;
	for (size_t i = 0; i < n && out < cap; i++) {
		uint64_t *hit = bsearch(&k[i], m->skey, m->ns, sizeof *k, cmp_u64);
		if (hit)
			idx[out++] = (uint32_t)(hit - m->skey);
	}
	mem_free(k);
	return out;
}

static struct vec3 bary(const struct mstate *m, size_t t, const double *w)
{
	const uint32_t *q = m->tet[t].v;
	return v3_add(v3_add(v3_scale(m->p[q[0]], w[0]), v3_scale(m->p[q[1]], w[1])),
		      v3_add(v3_scale(m->p[q[2]], w[2]), v3_scale(m->p[q[3]], w[3])));
}

/* Uniform point in tet t (folding the unit cube into the simplex). */
static struct vec3 tet_sample(const struct mstate *m, size_t t, struct rng *r)
{
	double a = rng_uniform(r), b = rng_uniform(r), c = rng_uniform(r), w[4];

	if (a + b > 1) {
		a = 1 - a;
		b = 1 - b;
	}
	if (b + c > 1) {
		double tmp = c;
		c = 1 - a - b;
		b = 1 - tmp;
	} else if (a + b + c > 1) {
		double tmp = c;
		c = a + b + c - 1;
		a = 1 - b - tmp;
	}
	w[0] = 1 - a - b - c;
	w[1] = a;
	w[2] = b;
	w[3] = c;
	return bary(m, t, w);
}

static uint64_t tet_seed(const struct mstate *m, size_t t)
{
	const uint32_t *q = m->tet[t].v;
	return m->o->seed ^ ((uint64_t)q[0] * 0x9E3779B97F4A7C15ull) ^ ((uint64_t)q[1] << 21) ^
	       ((uint64_t)q[2] << 42) ^ q[3];
}

static double clamp_r(const struct mstate *m, double r)
{
	return r > m->rcap ? m->rcap : r < m->o->r_min_mm ? m->o->r_min_mm : r;
}

/* Fraction of the point set's samples inside the solid (F > C) when every
 * radius is multiplied by `global` and, for struts with sel[j] set, also
 * by `scale` (clamped to [r_min, rcap]). */
static double pairs_density(const struct mstate *m, const struct strut_pairs *pp,
			    const uint8_t *sel, double scale, double global)
{
	size_t hit = 0;

	for (size_t s = 0; s < pp->npts; s++) {
		double f = 0;
		for (uint32_t k = pp->first[s]; k < pp->first[s + 1] && f <= 1; k++) {
			uint32_t j = pp->strut[k];
			double r = m->r[j] * global * (sel && sel[j] ? scale : 1);
			f += lattice_weight_for_radius(clamp_r(m, r), 1.0, m->R) * pp->val[k];
		}
		hit += f > 1;
	}
	return pp->npts ? (double)hit / pp->npts : 0;
}

/* Monotone bisection: largest f in [lo, hi] with density(f) <= target. */
static double bisect_scale(const struct mstate *m, const struct strut_pairs *pp,
			   const uint8_t *sel, double target, double lo, double hi)
{
	if (pairs_density(m, pp, sel, hi, 1) <= target)
		return hi;
	if (pairs_density(m, pp, sel, lo, 1) >= target)
		return lo;
	for (int it = 0; it < BISECT_STEPS; it++) {
		double mid = 0.5 * (lo + hi);
		if (pairs_density(m, pp, sel, mid, 1) < target)
			lo = mid;
		else
			hi = mid;
	}
	return 0.5 * (lo + hi);
}

/* Step 1: the largest voxel target among voxel centres inside t, else
 * the target field at t's centroid. */
static float tet_target(const struct mstate *m, size_t t)
{
	const struct voxels *v = m->vox;
	struct box3 b = box3_empty();
	struct vec3 c = v3(0, 0, 0), P[4];
	double best = -1, vol6;
	int i0[3], i1[3];

	for (int i = 0; i < 4; i++) {
		P[i] = m->p[m->tet[t].v[i]];
		box3_add(&b, P[i]);
		c = v3_add(c, v3_scale(P[i], 0.25));
	}
	vol6 = v3_dot(v3_sub(P[1], P[0]), v3_cross(v3_sub(P[2], P[0]), v3_sub(P[3], P[0])));
	for (int a = 0; a < 3; a++) {
		i0[a] = (int)ceil((v3_comp(b.lo, a) - v3_comp(v->lo, a)) / v->h - 0.5);
		i1[a] = (int)floor((v3_comp(b.hi, a) - v3_comp(v->lo, a)) / v->h - 0.5);
		if (i0[a] < 0)
			i0[a] = 0;
		if (i1[a] > v->n[a] - 1)
			i1[a] = v->n[a] - 1;
	}
	for (int k = i0[2]; k <= i1[2] && vol6 > 0; k++)
		for (int j = i0[1]; j <= i1[1]; j++)
			for (int i = i0[0]; i <= i1[0]; i++) {
				size_t idx = ((size_t)k * v->n[1] + j) * v->n[0] + i;
				struct vec3 q = box3_center(lattice_vox_box(v, idx));
				int in = 1;
				/* inside iff every face keeps q on the tet's side */
				for (int f = 0; f < 4 && in; f++) {
					struct vec3 F[4];
					for (int g = 0; g < 4; g++)
						F[g] = g == f ? q : P[g];
					in = v3_dot(v3_sub(F[1], F[0]),
						    v3_cross(v3_sub(F[2], F[0]), v3_sub(F[3], F[0]))) >= 0;
				}
				if (in && v->frac[idx] > 0)
					best = fmax(best, v->target[idx]);
			}
	return (float)(best >= 0 ? best : lattice_density_at(m->o->density, c));
}

/* ---- step 2: subdivision ---- */

struct subdiv_ctx {
	struct mstate *m;
	const uint32_t *cand; /* candidate tets */
	uint8_t *split;
};

static void subdiv_test(void *ctx, size_t i, int tid)
{
	struct subdiv_ctx *x = ctx;
	struct mstate *m = x->m;
	size_t t = x->cand[i];
	struct strut_pairs *pp = &m->pairs[tid];
	struct rng r;
	double lmin = INFINITY;

	x->split[i] = 0;
	if (m->tet[t].level >= m->o->max_subdiv)
		return;
	for (int j = 0; j < 6; j++)
		lmin = fmin(lmin, v3_dist(m->p[m->tet[t].v[EV[j][0]]], m->p[m->tet[t].v[EV[j][1]]]));
	if (lmin / 2 < 4 * m->r0)
		return; /* the children's edges would be shorter than 4 r (Appendix I) */
	strut_pairs_reset(pp);
	rng_seed(&r, tet_seed(m, t));
	for (int s = 0; s < TET_SAMPLES; s++)
		if (strut_pairs_add_point(pp, &m->grid, tet_sample(m, t, &r)))
			return;
	/* rho*: the density at the largest radius (the paper doubles the
	 * radii; here they may grow to rcap, see RCAP_RATIO) */
	x->split[i] = pairs_density(m, pp, NULL, 1, m->rcap / m->r0) < m->tet[t].target;
}

static int new_mid(struct mstate *m, uint32_t a, uint32_t b, uint32_t *out, struct err *e)
{
	uint64_t k = ekey(a, b);

	if (emap_get(&m->mid, k, out))
		return 0;
	if (m->np >= UINT32_MAX - 1)
		return ERR_SET(e, ERR_LIMIT, "too many lattice nodes");
	if (mem_grow((void **)&m->p, &m->pcap, m->np + 1, sizeof *m->p))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	m->p[m->np] = v3_lerp(m->p[a], m->p[b], 0.5);
	*out = (uint32_t)m->np++;
	if (emap_put(&m->mid, k, *out))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	return 0;
}

static void orient(const struct mstate *m, uint32_t *q)
{
	struct vec3 a = m->p[q[0]];
	if (v3_dot(v3_sub(m->p[q[1]], a), v3_cross(v3_sub(m->p[q[2]], a), v3_sub(m->p[q[3]], a))) <
	    0) {
		uint32_t t = q[2];
		q[2] = q[3];
		q[3] = t;
	}
}

/* Replace tet t by its 8 children (fig. 11): t becomes the first, seven
 * are appended.  The inner octahedron is split along its shortest
 * diagonal (the paper's one non-parallel "red" edge). */
static int split_tet(struct mstate *m, size_t t, struct err *e)
{
	uint32_t v[4], mm[4][4], ch[8][4];
	uint8_t level = (uint8_t)(m->tet[t].level + 1);
	int rc;

	memcpy(v, m->tet[t].v, sizeof v);
	for (int j = 0; j < 6; j++) {
		int a = EV[j][0], b = EV[j][1];
		if ((rc = new_mid(m, v[a], v[b], &mm[a][b], e)) != 0)
			return rc;
		mm[b][a] = mm[a][b];
	}
	for (int c = 0; c < 4; c++)
		for (int i = 0; i < 4; i++)
			ch[c][i] = i == c ? v[c] : mm[c][i];
	{
		uint32_t d[3][2] = {{mm[0][1], mm[2][3]}, {mm[0][2], mm[1][3]}, {mm[0][3], mm[1][2]}};
		int best = 0;
		double bl = INFINITY;
		for (int i = 0; i < 3; i++) {
			double l = v3_dist(m->p[d[i][0]], m->p[d[i][1]]);
			if (l < bl) {
				bl = l;
				best = i;
			}
		}
		{
			/* the other two opposite pairs alternate around the diagonal */
			const uint32_t *c1 = d[(best + 1) % 3], *c2 = d[(best + 2) % 3];
			uint32_t cyc[4] = {c1[0], c2[0], c1[1], c2[1]};
			for (int i = 0; i < 4; i++) {
				ch[4 + i][0] = d[best][0];
				ch[4 + i][1] = d[best][1];
				ch[4 + i][2] = cyc[i];
				ch[4 + i][3] = cyc[(i + 1) % 4];
			}
		}
	}
	if (mem_grow((void **)&m->tet, &m->tcap, m->nt + 7, sizeof *m->tet))
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	for (int c = 0; c < 8; c++) {
		size_t dst = c == 0 ? t : m->nt + (size_t)c - 1;
		memcpy(m->tet[dst].v, ch[c], sizeof ch[c]);
		orient(m, m->tet[dst].v);
		m->tet[dst].level = level;
	}
	m->nt += 7;
	m->tet[t].target = tet_target(m, t);
	for (int c = 1; c < 8; c++)
		m->tet[m->nt - 8 + c].target = tet_target(m, m->nt - 8 + c);
	return 0;
}

/* ---- step 3: per-tet radius factor ---- */

struct tune_ctx {
	struct mstate *m;
	double *factor; /* per tet */
	uint8_t *sel[MAX_THREADS];
};

static void tune_one(void *ctx, size_t t, int tid)
{
	struct tune_ctx *x = ctx;
	struct mstate *m = x->m;
	struct strut_pairs *pp = &m->pairs[tid];
	uint8_t *sel = x->sel[tid];
	uint32_t own[96];
	size_t n = tet_struts(m, t, own, 96);
	struct rng r;

	strut_pairs_reset(pp);
	rng_seed(&r, tet_seed(m, t) ^ 0x5bd1e995u);
	for (int s = 0; s < TET_SAMPLES; s++)
		if (strut_pairs_add_point(pp, &m->grid, tet_sample(m, t, &r))) {
			x->factor[t] = 1;
			return;
		}
	for (size_t i = 0; i < n; i++)
		sel[own[i]] = 1;
	x->factor[t] = bisect_scale(m, pp, sel, m->tet[t].target, m->o->r_min_mm / m->r0,
				    m->rcap / m->r0);
	for (size_t i = 0; i < n; i++)
		sel[own[i]] = 0;
}

/* ---- step 4: per-voxel common ratio ---- */

/* Segment a-b meets box b (slab test). */
static int seg_box(struct vec3 a, struct vec3 b, struct box3 bx)
{
	double t0 = 0, t1 = 1;
	for (int k = 0; k < 3; k++) {
		double o = v3_comp(a, k), d = v3_comp(b, k) - o;
		double lo = v3_comp(bx.lo, k), hi = v3_comp(bx.hi, k);
		if (fabs(d) < 1e-300) {
			if (o < lo || o > hi)
				return 0;
			continue;
		}
		{
			double ta = (lo - o) / d, tb = (hi - o) / d;
			if (ta > tb) {
				double t = ta;
				ta = tb;
				tb = t;
			}
			t0 = fmax(t0, ta);
			t1 = fmin(t1, tb);
			if (t0 > t1)
				return 0;
		}
	}
	return 1;
}

/* The struts crossing voxel idx (unique), appended to *list. */
static int voxel_struts(const struct mstate *m, size_t idx, uint32_t **list, size_t *n,
			size_t *cap, uint8_t *mark)
{
	struct box3 b = lattice_vox_box(m->vox, idx);
	int c0[3], c1[3];
	const struct strut_grid *g = &m->grid;
	size_t start = *n;
	int rc = 0;

	for (int a = 0; a < 3; a++) {
		double q0 = (v3_comp(b.lo, a) - v3_comp(g->lo, a)) / g->cell;
		double q1 = (v3_comp(b.hi, a) - v3_comp(g->lo, a)) / g->cell;
		c0[a] = q0 < 0 ? 0 : q0 > g->n[a] - 1 ? g->n[a] - 1 : (int)q0;
		c1[a] = q1 < 0 ? 0 : q1 > g->n[a] - 1 ? g->n[a] - 1 : (int)q1;
	}
	for (int k = c0[2]; k <= c1[2] && !rc; k++)
		for (int j = c0[1]; j <= c1[1] && !rc; j++)
			for (int i = c0[0]; i <= c1[0] && !rc; i++) {
				size_t c = ((size_t)k * g->n[1] + j) * g->n[0] + i;
				for (uint32_t q = g->start[c]; q < g->start[c + 1]; q++) {
					uint32_t s = g->item[q];
					if (mark[s] ||
					    !seg_box(m->p[m->ab[2 * s]], m->p[m->ab[2 * s + 1]], b))
						continue;
					if (mem_grow((void **)list, cap, *n + 1, sizeof **list)) {
						rc = ERR_NOMEM;
						break;
					}
					mark[s] = 1;
					(*list)[(*n)++] = s;
				}
			}
	for (size_t i = start; i < *n; i++)
		mark[(*list)[i]] = 0;
	return rc;
}

/* The voxel -> struts lists of the matched voxels (at least half inside). */
static int build_voxel_struts(struct mstate *m, struct err *e)
{
	size_t nv = lattice_vox_count(m->vox), n = 0, cap = 0;
	uint32_t *items = NULL;
	uint8_t *mark;

	if (m->vs_valid)
		return 0;
	mem_free(m->vs_start);
	mem_free(m->vs_item);
	m->vs_item = NULL;
	m->vs_start = mem_alloc((nv + 1) * sizeof *m->vs_start);
	mark = mem_calloc(m->ns ? m->ns : 1, 1);
	if (!m->vs_start || !mark)
		goto nomem;
	for (size_t v = 0; v < nv; v++) {
		m->vs_start[v] = (uint32_t)n;
		if (m->vox->frac[v] >= 0.5 && voxel_struts(m, v, &items, &n, &cap, mark))
			goto nomem;
		if (n > UINT32_MAX / 2) {
			mem_free(mark);
			mem_free(items);
			return ERR_SET(e, ERR_LIMIT, "too many voxel/strut pairs");
		}
	}
	m->vs_start[nv] = (uint32_t)n;
	m->vs_item = items;
	m->vs_valid = 1;
	mem_free(mark);
	return 0;
nomem:
	mem_free(mark);
	mem_free(items);
	return ERR_SET(e, ERR_NOMEM, "out of memory for voxel strut lists");
}

struct vox_ctx {
	struct mstate *m;
	double *ratio; /* per voxel, NAN = skipped */
	uint8_t *sel[MAX_THREADS];
	int failed;
};

static void vox_one(void *ctx, size_t idx, int tid)
{
	struct vox_ctx *x = ctx;
	struct mstate *m = x->m;
	const struct voxels *v = m->vox;
	struct strut_pairs *pp = &m->pairs[tid];
	const uint32_t *list = m->vs_item + m->vs_start[idx];
	size_t n = m->vs_start[idx + 1] - m->vs_start[idx];
	int ns = v->side * v->side * v->side;

	x->ratio[idx] = NAN;
	if (v->frac[idx] < 0.5 || n == 0)
		return;
	strut_pairs_reset(pp);
	for (int s = 0; s < ns; s++)
		if (lattice_vox_inside(v, idx, s))
			if (strut_pairs_add_point(pp, &m->grid, lattice_vox_sample(v, idx, s, 1))) {
				x->failed = 1;
				return;
			}
	for (size_t i = 0; i < n; i++)
		x->sel[tid][list[i]] = 1;
	x->ratio[idx] = bisect_scale(m, pp, x->sel[tid], v->target[idx], 0.25, 4.0);
	for (size_t i = 0; i < n; i++)
		x->sel[tid][list[i]] = 0;
}

/* mode 0: a strut keeps the smallest ratio of its voxels (the paper's
 * rule: never over-dense, often under-dense where voxels share struts);
 * mode 1: the geometric mean of its voxels' ratios (lets radii move both
 * ways; repeated passes converge on the coupled voxels). */
static int voxel_pass(struct mstate *m, int mode, struct err *e)
{
	size_t nv = lattice_vox_count(m->vox);
	struct vox_ctx x;
	double *sr = NULL;
	uint32_t *cnt = NULL;
	int threads = m->d->threads < MAX_THREADS ? m->d->threads : MAX_THREADS, rc;

	if ((rc = build_voxel_struts(m, e)) != 0)
		return rc;
	memset(&x, 0, sizeof x);
	x.m = m;
	x.ratio = mem_alloc(nv * sizeof *x.ratio);
	sr = mem_alloc((m->ns ? m->ns : 1) * sizeof *sr);
	cnt = mem_calloc(m->ns ? m->ns : 1, sizeof *cnt);
	if (!x.ratio || !sr || !cnt)
		goto nomem;
	for (int t = 0; t < threads; t++)
		if (!(x.sel[t] = mem_calloc(m->ns ? m->ns : 1, 1)))
			goto nomem;
	parfor_run(nv, threads, 1, vox_one, &x);
	if (x.failed)
		goto nomem;
	for (size_t s = 0; s < m->ns; s++)
		sr[s] = mode == 0 ? INFINITY : 0;
	for (size_t v = 0; v < nv; v++) {
		if (isnan(x.ratio[v]))
			continue;
		for (uint32_t i = m->vs_start[v]; i < m->vs_start[v + 1]; i++) {
			uint32_t j = m->vs_item[i];
			if (mode == 0)
				sr[j] = fmin(sr[j], x.ratio[v]);
			else
				sr[j] += log(x.ratio[v]);
			cnt[j]++;
		}
	}
	for (size_t s = 0; s < m->ns; s++)
		if (cnt[s])
			m->r[s] = clamp_r(m, m->r[s] * (mode == 0 ? sr[s] : exp(sr[s] / cnt[s])));
	rc = 0;
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "out of memory matching voxel densities");
out:
	for (int t = 0; t < MAX_THREADS; t++)
		mem_free(x.sel[t]);
	mem_free(x.ratio);
	mem_free(sr);
	mem_free(cnt);
	return rc;
}

/* ---- driver ---- */

static void mstate_fini(struct mstate *m)
{
	mem_free(m->vs_start);
	mem_free(m->vs_item);
	mem_free(m->p);
	mem_free(m->tet);
	mem_free(m->mid.key);
	mem_free(m->mid.val);
	mem_free(m->ab);
	mem_free(m->skey);
	mem_free(m->r);
	strut_grid_fini(&m->grid);
	for (int t = 0; t < MAX_THREADS; t++)
		strut_pairs_fini(&m->pairs[t]);
}

static int report(struct progress *p, double f, struct err *e)
{
	return p ? progress_update(p, f, e) : 0;
}

int lattice_match_density(struct lattice_tetmesh *t, const struct lattice_domain *d,
			  const struct lattice_match_opts *o, struct lattice **out,
			  struct lattice_match_stats *st, struct err *e)
{
	struct mstate m;
	struct voxels vox;
	struct lattice *q = NULL;
	uint32_t *remap = NULL;
	double t0 = progress_now_s(), t1, t2;
	int threads = d->threads < 1 ? 1 : d->threads > MAX_THREADS ? MAX_THREADS : d->threads;
	int rc;

	memset(&m, 0, sizeof m);
	memset(st, 0, sizeof *st);
	if (!(o->r_min_mm > 0) || !(o->r_init_mm >= o->r_min_mm) || !(o->support_factor > 1) ||
	    !(o->voxel_mm > 0) || o->samples < 8 || o->passes < 0)
		return ERR_SET(e, ERR_PARAM, "bad density matching options");
	if ((rc = lattice_voxels_init(&vox, d, o->density, o->voxel_mm, o->samples, o->seed, 1, e)) != 0)
		goto out;
	m.o = o;
	m.d = d;
	m.vox = &vox;
	m.r0 = o->r_init_mm;
	m.rcap = RCAP_RATIO * m.r0;
	m.R = o->support_factor * m.rcap;
	/* take over the tet mesh */
	m.p = mem_alloc((t->np ? t->np : 1) * sizeof *m.p);
	m.tet = mem_alloc((t->nt ? t->nt : 1) * sizeof *m.tet);
	if (!m.p || !m.tet) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	memcpy(m.p, t->p, t->np * sizeof *m.p);
	m.np = m.pcap = t->np;
	m.nt = m.tcap = t->nt;
	for (size_t i = 0; i < t->nt; i++) {
		memcpy(m.tet[i].v, t->tet + 4 * i, sizeof m.tet[i].v);
		m.tet[i].level = 0;
	}
	for (size_t i = 0; i < m.nt; i++)
		m.tet[i].target = tet_target(&m, i);

	/* step 2: subdivision rounds */
	{
		uint32_t *cand = mem_alloc((m.nt ? m.nt : 1) * sizeof *cand), *next = NULL;
		size_t ncand = m.nt;

		if (!cand) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory");
			goto out;
		}
		for (size_t i = 0; i < m.nt; i++)
			cand[i] = (uint32_t)i;
		for (int level = 0; level < o->max_subdiv && ncand > 0 && !rc; level++) {
			struct subdiv_ctx x = {&m, cand, NULL};
			size_t nn = 0;

			if ((rc = rebuild_struts(&m, e)) != 0)
				break;
			x.split = mem_alloc(ncand);
			if (!x.split) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory");
				break;
			}
			parfor_run(ncand, threads, 8, subdiv_test, &x);
			for (size_t i = 0; i < ncand; i++)
				nn += x.split[i];
			/* the children of every split tet are the next candidates */
			next = mem_alloc((nn ? nn : 1) * 8 * sizeof *next);
			if (!next) {
				mem_free(x.split);
				rc = ERR_SET(e, ERR_NOMEM, "out of memory");
				break;
			}
			nn = 0;
			for (size_t i = 0; i < ncand && !rc; i++) {
				if (!x.split[i])
					continue;
				if ((rc = split_tet(&m, cand[i], e)) != 0)
					break;
				next[nn++] = cand[i];
				for (size_t c = m.nt - 7; c < m.nt; c++)
					next[nn++] = (uint32_t)c;
			}
			mem_free(x.split);
			mem_free(cand);
			cand = next;
			next = NULL;
			st->subdivided_tets += nn / 8;
			ncand = nn;
			if (!rc)
				rc = report(o->progress, 0.1 + 0.1 * level, e);
		}
		mem_free(cand);
		if (rc)
			goto out;
	}
	if ((rc = rebuild_struts(&m, e)) != 0)
		goto out;
	t1 = progress_now_s();
	st->seconds_subdiv = t1 - t0;

	/* step 3: per-tet factors, a strut takes the mean of its tets' */
	{
		struct tune_ctx x;
		double *sum = mem_calloc(m.ns ? m.ns : 1, sizeof *sum);
		uint32_t *cnt = mem_calloc(m.ns ? m.ns : 1, sizeof *cnt);
		memset(&x, 0, sizeof x);
		x.m = &m;
		x.factor = mem_alloc((m.nt ? m.nt : 1) * sizeof *x.factor);
		for (int i = 0; i < threads; i++)
			x.sel[i] = mem_calloc(m.ns ? m.ns : 1, 1);
		rc = (!sum || !cnt || !x.factor) ? ERR_NOMEM : 0;
		for (int i = 0; i < threads && !rc; i++)
			rc = x.sel[i] ? 0 : ERR_NOMEM;
		if (!rc) {
			parfor_run(m.nt, threads, 8, tune_one, &x);
			for (size_t tt = 0; tt < m.nt; tt++) {
				uint32_t own[96];
				size_t n = tet_struts(&m, tt, own, 96);
				for (size_t i = 0; i < n; i++) {
					sum[own[i]] += x.factor[tt];
					cnt[own[i]]++;
				}
			}
			for (size_t s = 0; s < m.ns; s++)
				m.r[s] = clamp_r(&m, m.r0 * (cnt[s] ? sum[s] / cnt[s] : 1));
		}
		mem_free(sum);
		mem_free(cnt);
		mem_free(x.factor);
		for (int i = 0; i < threads; i++)
			mem_free(x.sel[i]);
		if (rc) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory tuning radii");
			goto out;
		}
	}
	if ((rc = report(o->progress, 0.5, e)) != 0)
		goto out;

	/* step 4: per-voxel common scaling */
	for (int pass = 0; pass < o->passes; pass++) {
		if ((rc = voxel_pass(&m, pass == 0 ? 0 : 1, e)) != 0)
			goto out;
		if ((rc = report(o->progress, 0.5 + 0.3 * (pass + 1) / o->passes, e)) != 0)
			goto out;
	}
	/* R = factor * the largest radius actually used; re-match under it */
	{
		double rmax = 0;
		for (size_t s = 0; s < m.ns; s++)
			rmax = fmax(rmax, m.r[s]);
		if (rmax > 0 && o->support_factor * rmax < 0.97 * m.R) {
			m.R = o->support_factor * rmax;
			m.rcap = rmax;
			if ((rc = rebuild_struts(&m, e)) != 0)
				goto out;
			for (int pass = 0; pass < (o->passes > 0 ? 2 : 0); pass++)
				if ((rc = voxel_pass(&m, 1, e)) != 0)
					goto out;
		}
	}
	t2 = progress_now_s();
	st->seconds_tune = t2 - t1;

	/* the lattice: nodes used by struts, struts with their radii */
	q = lattice_new();
	remap = mem_alloc((m.np ? m.np : 1) * sizeof *remap);
	if (!q || !remap) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	memset(remap, 0xff, m.np * sizeof *remap);
	for (size_t s = 0; s < 2 * m.ns; s++)
		remap[m.ab[s]] = 0;
	if ((rc = lattice_reserve(q, m.np, m.ns)) != 0) {
		rc = ERR_SET(e, rc, "out of memory for the lattice");
		goto out;
	}
	for (size_t i = 0; i < m.np; i++)
		if (remap[i] == 0) {
			remap[i] = (uint32_t)q->nnodes;
			lattice_add_node(q, m.p[i]);
		}
	for (size_t s = 0; s < m.ns; s++)
		lattice_add_edge(q, remap[m.ab[2 * s]], remap[m.ab[2 * s + 1]], m.r[s]);
	q->support_mm = m.R;
	st->support_mm = m.R;
	for (size_t v = 0; v < lattice_vox_count(&vox); v++)
		st->voxels += vox.frac[v] >= 0.5;
	*out = q;
	q = NULL;
	rc = 0;
out:
	lattice_free(q);
	mem_free(remap);
	lattice_voxels_fini(&vox);
	mstate_fini(&m);
	return rc;
}

