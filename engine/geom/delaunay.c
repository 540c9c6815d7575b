/* delaunay.c - Bowyer-Watson Delaunay triangulation with a ghost vertex
 * (see delaunay.h for the contract and complexity).
 *
 * Representation while building: triangles (finite and ghost) in one
 * array; a ghost triangle (a, b, G) stands behind hull edge a->b and keeps
 * G = n at index 2, so "outside the hull" is to the LEFT of a->b.  A new
 * point q conflicts with a finite triangle when it is strictly inside its
 * circumcircle, with a ghost one when it is strictly left of a->b or on
 * the open segment ab (the limit of the circumcircle as the third vertex
 * goes to infinity).  The conflict region is star-shaped from q, so its
 * boundary is one cycle and q is joined to every boundary edge.
 */
#include "engine/geom/delaunay.h"

#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/predicates.h"

struct bw {
	const struct pt2 *p;
	uint32_t n, ghost;
	struct dt_tri *t;
	size_t nt, cap;
	uint32_t *stamp;   /* per triangle: id of the last insertion that saw it in conflict */
	size_t stamp_cap;
	uint32_t *start;   /* per vertex (n + 1): new triangle starting there (insertion scratch) */
	uint32_t *cav;     /* cavity triangles of the current insertion */
	size_t ncav, cav_cap;
	struct edge_rec {
		uint32_t u, w, out;
	} *bnd;            /* cavity boundary edges u->w with the triangle outside */
	size_t nbnd, bnd_cap;
	uint32_t *stack;
	size_t nstack, stack_cap;
	uint32_t last;     /* a recently created triangle: walk start */
	uint64_t rng;
};

void delaunay_init(struct delaunay *dt)
{
	memset(dt, 0, sizeof *dt);
}

void delaunay_fini(struct delaunay *dt)
{
	mem_free(dt->tri);
	mem_free(dt->vtri);
	mem_free(dt->dup);
	memset(dt, 0, sizeof *dt);
}

static int is_ghost(const struct bw *b, uint32_t t)
{
	return b->t[t].v[2] == b->ghost;
}

/* q on the open segment ab, given a, b, q collinear. */
static int strictly_between(struct pt2 a, struct pt2 b, struct pt2 q)
{
	__int128 d1 = (__int128)(q.x - a.x) * (b.x - a.x) + (__int128)(q.y - a.y) * (b.y - a.y);
	__int128 d2 = (__int128)(q.x - b.x) * (a.x - b.x) + (__int128)(q.y - b.y) * (a.y - b.y);
	return d1 > 0 && d2 > 0;
}

static int in_conflict(const struct bw *b, uint32_t t, struct pt2 q)
{
	const struct dt_tri *T = &b->t[t];

	if (T->v[2] == b->ghost) {
		int o = geom_orient2d(b->p[T->v[0]], b->p[T->v[1]], q);
		if (o != 0)
			return o > 0;
		return strictly_between(b->p[T->v[0]], b->p[T->v[1]], q);
	}
	return geom_incircle(b->p[T->v[0]], b->p[T->v[1]], b->p[T->v[2]], q) > 0;
}

static uint32_t rng_next(struct bw *b)
{
	b->rng = b->rng * 6364136223846793005ULL + 1442695040888963407ULL;
	return (uint32_t)(b->rng >> 33);
}

/* A triangle in conflict with q: visibility walk from b->last over finite
 * triangles; stepping across a hull edge lands in a ghost that conflicts.
 * The walk terminates on Delaunay triangulations; a step cap guards it
 * anyway and falls back to a scan. */
static uint32_t locate(struct bw *b, struct pt2 q)
{
	uint32_t t = b->last;
	size_t steps = 0, cap = 4 * b->nt + 64;

	if (is_ghost(b, t))
		t = b->t[t].nb[2];
	while (steps++ < cap) {
		const struct dt_tri *T = &b->t[t];
		uint32_t r = rng_next(b) % 3;
		int moved = 0;

		if (T->v[2] == b->ghost)
			return t;
		for (uint32_t k = 0; k < 3; k++) {
			uint32_t i = (r + k) % 3;
			if (geom_orient2d(b->p[T->v[(i + 1) % 3]], b->p[T->v[(i + 2) % 3]], q) < 0) {
				t = T->nb[i];
				moved = 1;
				break;
			}
		}
		if (!moved)
			return t;
	}
	for (size_t i = 0; i < b->nt; i++)
		if (b->t[i].v[0] != DT_NONE && in_conflict(b, (uint32_t)i, q))
			return (uint32_t)i;
	return DT_NONE;
}

static int push_u32(uint32_t **arr, size_t *n, size_t *cap, uint32_t v)
{
	void *a = *arr;

	if (*n == *cap) {
		if (mem_grow(&a, cap, *n + 1, sizeof **arr))
			return ERR_NOMEM;
		*arr = a;
	}
	(*arr)[(*n)++] = v;
	return 0;
}

static int new_slot(struct bw *b, uint32_t *out)
{
	if (b->nt == b->cap) {
		void *a = b->t;
		if (mem_grow(&a, &b->cap, b->nt + 1, sizeof *b->t))
			return ERR_NOMEM;
		b->t = a;
	}
	if (b->nt >= b->stamp_cap) {
		void *a = b->stamp;
		size_t old = b->stamp_cap;
		if (mem_grow(&a, &b->stamp_cap, b->nt + 1, sizeof *b->stamp))
			return ERR_NOMEM;
		b->stamp = a;
		memset(b->stamp + old, 0xff, (b->stamp_cap - old) * sizeof *b->stamp);
	}
	*out = (uint32_t)b->nt++;
	return 0;
}

/* Index j of the edge u->w in triangle t (the edge opposite v[j]). */
static int edge_index(const struct dt_tri *T, uint32_t u, uint32_t w)
{
	for (int j = 0; j < 3; j++)
		if (T->v[(j + 1) % 3] == u && T->v[(j + 2) % 3] == w)
			return j;
	return -1;
}

/* Rotate so that the ghost vertex, if any, sits at index 2. */
static void ghost_last(struct bw *b, struct dt_tri *T)
{
	while (T->v[0] == b->ghost || T->v[1] == b->ghost) {
		struct dt_tri r = {{T->v[1], T->v[2], T->v[0]}, {T->nb[1], T->nb[2], T->nb[0]}};
		*T = r;
	}
}

static int insert(struct bw *b, uint32_t qi, uint32_t id, struct err *e)
{
	struct pt2 q = b->p[qi];
	uint32_t t0 = locate(b, q);
	size_t k;

	if (t0 == DT_NONE)
		return ERR_SET(e, ERR_INTERNAL, "delaunay: point %u not located", qi);
	b->ncav = b->nbnd = b->nstack = 0;
	b->stamp[t0] = id;
	if (push_u32(&b->stack, &b->nstack, &b->stack_cap, t0))
		goto nomem;
	while (b->nstack) {
		uint32_t t = b->stack[--b->nstack];
		if (push_u32(&b->cav, &b->ncav, &b->cav_cap, t))
			goto nomem;
		for (int i = 0; i < 3; i++) {
			uint32_t nbt = b->t[t].nb[i];
			if (b->stamp[nbt] == id)
				continue;
			if (in_conflict(b, nbt, q)) {
				b->stamp[nbt] = id;
				if (push_u32(&b->stack, &b->nstack, &b->stack_cap, nbt))
					goto nomem;
			} else {
				if (b->nbnd == b->bnd_cap) {
					void *a = b->bnd;
					if (mem_grow(&a, &b->bnd_cap, b->nbnd + 1, sizeof *b->bnd))
						goto nomem;
					b->bnd = a;
				}
				b->bnd[b->nbnd].u = b->t[t].v[(i + 1) % 3];
				b->bnd[b->nbnd].w = b->t[t].v[(i + 2) % 3];
				b->bnd[b->nbnd].out = nbt;
				b->nbnd++;
			}
		}
	}
	/* Reuse the cavity's slots; two more are needed (Euler). */
	while (b->ncav < b->nbnd) {
		uint32_t s;
		if (new_slot(b, &s))
			goto nomem;
		if (push_u32(&b->cav, &b->ncav, &b->cav_cap, s))
			goto nomem;
	}
	if (b->ncav != b->nbnd)
		return ERR_SET(e, ERR_INTERNAL, "delaunay: cavity of %zu triangles has %zu edges",
			       b->ncav, b->nbnd);
	for (k = 0; k < b->nbnd; k++) {
		uint32_t x = b->cav[k];
		struct dt_tri *X = &b->t[x];
		struct dt_tri *O = &b->t[b->bnd[k].out];
		int j = edge_index(O, b->bnd[k].w, b->bnd[k].u);

		if (j < 0)
			return ERR_SET(e, ERR_INTERNAL, "delaunay: broken adjacency");
		X->v[0] = b->bnd[k].u;
		X->v[1] = b->bnd[k].w;
		X->v[2] = qi;
		X->nb[2] = b->bnd[k].out;
		O->nb[j] = x;
		b->start[b->bnd[k].u] = x;
	}
	for (k = 0; k < b->nbnd; k++) {
		uint32_t x = b->cav[k];
		uint32_t y = b->start[b->t[x].v[1]];
		b->t[x].nb[0] = y; /* edge w->q of x is edge q->w of y */
		b->t[y].nb[1] = x;
	}
	for (k = 0; k < b->nbnd; k++)
		ghost_last(b, &b->t[b->cav[k]]);
	b->last = b->cav[0];
	return 0;
nomem:
	return ERR_SET(e, ERR_NOMEM, "delaunay: out of memory");
}

/* Hilbert index of (x, y) on a 2^16 grid. */
static uint64_t hilbert_d(uint32_t x, uint32_t y)
{
	uint64_t d = 0;

	for (uint32_t s = 1u << 15; s > 0; s >>= 1) {
		uint32_t rx = (x & s) > 0, ry = (y & s) > 0;
		d += (uint64_t)s * s * ((3 * rx) ^ ry);
		if (ry == 0) {
			if (rx == 1) {
				x = s - 1 - x;
				y = s - 1 - y;
			}
			uint32_t tmp = x;
			x = y;
			y = tmp;
		}
	}
	return d;
}

struct key {
	uint64_t k;
	uint32_t i;
};

static int cmp_key(const void *a, const void *b)
{
	const struct key *x = a, *y = b;
	if (x->k != y->k)
		return x->k < y->k ? -1 : 1;
	return (x->i > y->i) - (x->i < y->i);
}

struct xyi {
	struct pt2 p;
	uint32_t i;
};

static int cmp_xyi(const void *a, const void *b)
{
	const struct xyi *u = a, *w = b;
	if (u->p.x != w->p.x)
		return u->p.x < w->p.x ? -1 : 1;
	if (u->p.y != w->p.y)
		return u->p.y < w->p.y ? -1 : 1;
	return (u->i > w->i) - (u->i < w->i);
}

static void bw_fini(struct bw *b)
{
	mem_free(b->t);
	mem_free(b->stamp);
	mem_free(b->start);
	mem_free(b->cav);
	mem_free(b->bnd);
	mem_free(b->stack);
}

int delaunay_build(const struct pt2 *p, size_t n, struct delaunay *dt, struct err *e)
{
	struct bw b;
	struct delaunay out;
	uint32_t *remap = NULL, *uniq = NULL;
	struct xyi *order = NULL;
	struct key *keys = NULL;
	size_t nu = 0, k;
	uint32_t a0, a1, a2 = DT_NONE;
	int rc = 0;

	memset(&b, 0, sizeof b);
	delaunay_init(&out);
	if (n > (size_t)INT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "delaunay: %zu points (max %d)", n, INT32_MAX);
	if (!geom_pred_range_ok(p, n))
		return ERR_SET(e, ERR_LIMIT, "delaunay: points span more than %lld nm",
			       (long long)GEOM_PRED_MAX_RANGE_NM);
	out.n = n;
	out.vtri = mem_alloc((n ? n : 1) * sizeof *out.vtri);
	out.dup = mem_alloc((n ? n : 1) * sizeof *out.dup);
	order = mem_alloc((n ? n : 1) * sizeof *order);
	if (!out.vtri || !out.dup || !order)
		goto nomem;
	for (k = 0; k < n; k++) {
		order[k].p = p[k];
		order[k].i = (uint32_t)k;
		out.vtri[k] = DT_NONE;
		out.dup[k] = (uint32_t)k;
	}
	/* exact duplicates: sort by (x, y), keep the lowest index */
	qsort(order, n, sizeof *order, cmp_xyi);
	uniq = mem_alloc((n ? n : 1) * sizeof *uniq);
	if (!uniq)
		goto nomem;
	for (k = 0; k < n; k++) {
		if (k > 0 && order[k].p.x == order[k - 1].p.x && order[k].p.y == order[k - 1].p.y) {
			out.dup[order[k].i] = out.dup[order[k - 1].i];
			continue;
		}
		uniq[nu++] = order[k].i;
	}
	/* first three non-collinear points (in sorted order: a0, a1 extreme) */
	if (nu < 3)
		goto done;
	a0 = uniq[0];
	a1 = uniq[1];
	for (k = 2; k < nu; k++)
		if (geom_orient2d(p[a0], p[a1], p[uniq[k]]) != 0) {
			a2 = uniq[k];
			break;
		}
	if (a2 == DT_NONE)
		goto done; /* all collinear */
	if (geom_orient2d(p[a0], p[a1], p[a2]) < 0) {
		uint32_t t = a1;
		a1 = a2;
		a2 = t;
	}
	b.p = p;
	b.n = (uint32_t)n;
	b.ghost = (uint32_t)n;
	b.rng = 0x9e3779b97f4a7c15ULL;
	b.start = mem_alloc((n + 1) * sizeof *b.start);
	if (!b.start)
		goto nomem;
	{
		uint32_t s[4];
		for (int i = 0; i < 4; i++)
			if (new_slot(&b, &s[i]))
				goto nomem;
		/* T0 = (a0,a1,a2); ghosts behind a0->a1, a1->a2, a2->a0 (reversed) */
		b.t[s[0]] = (struct dt_tri){{a0, a1, a2}, {s[2], s[3], s[1]}};
		b.t[s[1]] = (struct dt_tri){{a1, a0, b.ghost}, {s[3], s[2], s[0]}};
		b.t[s[2]] = (struct dt_tri){{a2, a1, b.ghost}, {s[1], s[3], s[0]}};
		b.t[s[3]] = (struct dt_tri){{a0, a2, b.ghost}, {s[2], s[1], s[0]}};
		b.last = s[0];
	}
	/* Hilbert order of the remaining unique points */
	keys = mem_alloc(nu * sizeof *keys);
	if (!keys)
		goto nomem;
	{
		struct pt2 lo = p[uniq[0]], hi = p[uniq[0]];
		size_t nk = 0;
		for (k = 0; k < nu; k++) {
			struct pt2 q = p[uniq[k]];
			lo.x = q.x < lo.x ? q.x : lo.x;
			lo.y = q.y < lo.y ? q.y : lo.y;
			hi.x = q.x > hi.x ? q.x : hi.x;
			hi.y = q.y > hi.y ? q.y : hi.y;
		}
		double sx = hi.x > lo.x ? 65535.0 / (double)(hi.x - lo.x) : 0;
		double sy = hi.y > lo.y ? 65535.0 / (double)(hi.y - lo.y) : 0;
		for (k = 0; k < nu; k++) {
			uint32_t i = uniq[k];
			if (i == a0 || i == a1 || i == a2)
				continue;
			keys[nk].k = hilbert_d((uint32_t)((double)(p[i].x - lo.x) * sx),
					       (uint32_t)((double)(p[i].y - lo.y) * sy));
			keys[nk].i = i;
			nk++;
		}
		qsort(keys, nk, sizeof *keys, cmp_key);
		for (k = 0; k < nk; k++) {
			rc = insert(&b, keys[k].i, (uint32_t)k, e);
			if (rc)
				goto out;
		}
	}
	/* compact: drop ghosts and dead slots */
	remap = mem_alloc(b.nt * sizeof *remap);
	if (!remap)
		goto nomem;
	for (k = 0; k < b.nt; k++)
		remap[k] = is_ghost(&b, (uint32_t)k) ? DT_NONE : (uint32_t)out.nt++;
	out.tri = mem_alloc((out.nt ? out.nt : 1) * sizeof *out.tri);
	if (!out.tri)
		goto nomem;
	for (k = 0; k < b.nt; k++) {
		struct dt_tri T;
		if (remap[k] == DT_NONE)
			continue;
		T = b.t[k];
		for (int i = 0; i < 3; i++) {
			T.nb[i] = remap[T.nb[i]];
			out.vtri[T.v[i]] = remap[k];
		}
		out.tri[remap[k]] = T;
	}
done:
	delaunay_fini(dt);
	*dt = out;
	memset(&out, 0, sizeof out);
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "delaunay: out of memory (%zu points)", n);
out:
	delaunay_fini(&out);
	bw_fini(&b);
	mem_free(order);
	mem_free(uniq);
	mem_free(keys);
	mem_free(remap);
	return rc;
}

size_t delaunay_fan(const struct delaunay *dt, uint32_t v, uint32_t *out, size_t max,
		    int *closed)
{
	uint32_t t0, t;
	size_t n = 0;

	*closed = 0;
	if (v >= dt->n || dt->vtri[v] == DT_NONE)
		return 0;
	t0 = t = dt->vtri[v];
	/* walk clockwise to the first triangle of the fan (or all the way round) */
	for (;;) {
		const struct dt_tri *T = &dt->tri[t];
		int i = T->v[0] == v ? 0 : T->v[1] == v ? 1 : 2;
		uint32_t prev = T->nb[(i + 2) % 3];
		if (prev == DT_NONE)
			break;
		t = prev;
		if (t == t0) {
			*closed = 1;
			break;
		}
	}
	t0 = t;
	do {
		const struct dt_tri *T = &dt->tri[t];
		int i = T->v[0] == v ? 0 : T->v[1] == v ? 1 : 2;
		if (n < max)
			out[n] = t;
		n++;
		t = T->nb[(i + 1) % 3];
	} while (t != DT_NONE && t != t0);
	return n < max ? n : max;
}

void delaunay_circumcenter_mm(const struct delaunay *dt, const struct pt2 *p, uint32_t t,
			      double *x_mm, double *y_mm)
{
	const struct dt_tri *T = &dt->tri[t];
	struct pt2 a = p[T->v[0]], b = p[T->v[1]], c = p[T->v[2]];
	/* relative to a, in mm: exact differences, then double */
	double bx = geom_nm_to_mm(b.x - a.x), by = geom_nm_to_mm(b.y - a.y);
	double cx = geom_nm_to_mm(c.x - a.x), cy = geom_nm_to_mm(c.y - a.y);
	double d = 2.0 * (bx * cy - by * cx);
	double b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;

	/* d != 0: finite Delaunay triangles are never degenerate */
	*x_mm = geom_nm_to_mm(a.x) + (cy * b2 - by * c2) / d;
	*y_mm = geom_nm_to_mm(a.y) + (bx * c2 - cx * b2) / d;
}
