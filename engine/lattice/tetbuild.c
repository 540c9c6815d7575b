/* tetbuild.c - the initial tetrahedral lattice of a part (gen.h).
 *
 * The paper remeshes the surface adaptively and meshes the volume with
 * TetGen; a dense input surface must not force tiny tetrahedra.  Here the
 * graded spacing comes from sampling instead (docs/lattice.md 4.2): nodes
 * are a graded Poisson-disk sample (surface points first, then interior
 * points; the accepted ones in the hash grid of engine/geom/pointgrid.h)
 * with radius beta * L(p), L from the Appendix I estimate, drawn
 * in the space compressed by 1/k along z (SO, section 5.2.1); TetGen's
 * Delaunay tetrahedra of the samples are kept where their centroid lies
 * inside the part, then the nodes are stretched back by k.  This works on
 * open or self-intersecting input too (the inside test is a generalised
 * winding number), and its cost follows the node count, not the input's
 * triangle count.  Complexity: O(n) samples with O(1) neighbour checks,
 * Delaunay O(n log n), restriction O(t) inside tests.
 */
#include "engine/lattice/gen.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/progress.h"
#include "engine/core/rng.h"
#include "engine/geom/pointgrid.h"
#include "engine/mesh/mesh.h"
#include "engine/mesh/tetra.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Poisson-disk radius as a fraction of the target edge length: the mean
 * Delaunay edge of a maximal Poisson sample of radius delta is about
 * 1.51 delta (measured, docs/lattice.md 4.2), so delta = L / 1.51. */
#define POISSON_BETA (1.0 / 1.51)
#define MAX_CELLS (16u << 20)

enum cell_class { CELL_MIXED = 0, CELL_IN, CELL_OUT };

struct sampler {
	const struct lattice_domain *d;
	const struct lattice_build_opts *o;
	double k;
	struct box3 cb; /* compressed box (slightly inflated) */
	double dmin, dmax;
	/* accepted points (compressed coordinates) in a hash grid of cell dmin */
	struct pointgrid g;
	/* classification grid */
	double ccell;
	int cn[3];
	uint8_t *cls;
};

static struct vec3 decompress(const struct sampler *s, struct vec3 c)
{
	return v3(c.x, c.y, c.z * s->k);
}

static double delta_at(const struct sampler *s, struct vec3 c)
{
	double rho = lattice_density_at(s->o->density, decompress(s, c));
	return POISSON_BETA * lattice_spacing_for_density(rho, s->o->r_mm);
}

/* ---- classification ---- */

struct classify_ctx {
	struct sampler *s;
};

static void classify_one(void *ctx, size_t idx, int tid)
{
	struct sampler *s = ((struct classify_ctx *)ctx)->s;
	size_t nx = (size_t)s->cn[0], ny = (size_t)s->cn[1];
	int i = (int)(idx % nx), j = (int)(idx / nx % ny), kk = (int)(idx / (nx * ny));
	struct vec3 c = v3(s->cb.lo.x + (i + 0.5) * s->ccell, s->cb.lo.y + (j + 0.5) * s->ccell,
			   s->cb.lo.z + (kk + 0.5) * s->ccell);
	struct vec3 p = decompress(s, c);
	/* half diagonal of the cell in the original frame (z stretched by k) */
	double hd = 0.5 * s->ccell * sqrt(2 + s->k * s->k);
	double dist = s->d->distance(s->d->ctx, p);
	int in = s->d->inside(s->d->ctx, p);

	(void)tid;
	if (in && dist > hd + 0.5 * s->dmax * s->k)
		s->cls[idx] = CELL_IN;
	else if (!in && dist > hd)
		s->cls[idx] = CELL_OUT;
	else
		s->cls[idx] = CELL_MIXED;
}

static int cls_at(const struct sampler *s, struct vec3 c)
{
	int ijk[3];

	pointgrid_cell(s->cb.lo, s->ccell, s->cn, c, ijk);
	return s->cls[((size_t)ijk[2] * s->cn[1] + ijk[1]) * s->cn[0] + ijk[0]];
}

/* ---- Poisson acceptance ---- */

static int far_from_all(const struct sampler *s, struct vec3 c, double delta)
{
	return pointgrid_far_from_all(&s->g, c, delta);
}

static int accept_point(struct sampler *s, struct vec3 c, struct err *e)
{
	if (s->g.np >= s->o->max_nodes || s->g.np >= INT32_MAX)
		return ERR_SET(e, ERR_LIMIT,
			       "the lattice would need more than %zu nodes; lower the density or "
			       "raise min_radius_mm",
			       s->o->max_nodes);
	return pointgrid_insert(&s->g, c, e);
}

/* ---- surface samples ---- */

static int sample_surface(struct sampler *s, struct rng *rg, struct err *e)
{
	const struct mesh *m = s->d->surface;
	struct vec3 *cand = NULL;
	size_t nc = 0, cc = 0;
	int rc = 0;

	if (!m)
		return 0;
	for (size_t t = 0; t < m->nt; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], b = m->v[m->tri[3 * t + 1]];
		struct vec3 c = m->v[m->tri[3 * t + 2]];
		double area, dl, want;
		struct vec3 ca, cb, cc3;

		ca = v3(a.x, a.y, a.z / s->k);
		cb = v3(b.x, b.y, b.z / s->k);
		cc3 = v3(c.x, c.y, c.z / s->k);
		area = 0.5 * v3_len(v3_cross(v3_sub(cb, ca), v3_sub(cc3, ca)));
		if (!(area > 0))
			continue;
		dl = delta_at(s, v3_scale(v3_add(v3_add(ca, cb), cc3), 1.0 / 3));
		/* oversample 4x the disc packing count, stochastically rounded */
		want = 4 * area / (dl * dl);
		{
			size_t cnt = (size_t)want + (rng_uniform(rg) < want - floor(want));
			for (size_t q = 0; q < cnt; q++) {
				double u = rng_uniform(rg), v = rng_uniform(rg);
				if (u + v > 1) {
					u = 1 - u;
					v = 1 - v;
				}
				if (mem_grow((void **)&cand, &cc, nc + 1, sizeof *cand)) {
					rc = ERR_SET(e, ERR_NOMEM, "out of memory for surface samples");
					goto out;
				}
				cand[nc++] = v3_add(ca, v3_add(v3_scale(v3_sub(cb, ca), u),
							       v3_scale(v3_sub(cc3, ca), v)));
			}
		}
	}
	for (size_t i = nc; i > 1; i--) { /* random order: unbiased dart throwing */
		size_t j = (size_t)rng_below(rg, i);
		struct vec3 t = cand[i - 1];
		cand[i - 1] = cand[j];
		cand[j] = t;
	}
	for (size_t i = 0; i < nc; i++)
		if (far_from_all(s, cand[i], delta_at(s, cand[i])) &&
		    (rc = accept_point(s, cand[i], e)) != 0)
			goto out;
out:
	mem_free(cand);
	return rc;
}

/* ---- interior samples ---- */

struct exact_ctx {
	struct sampler *s;
	const struct vec3 *cand;
	const uint32_t *idx; /* candidates needing the exact test */
	uint8_t *ok;
};

static void exact_one(void *ctx, size_t i, int tid)
{
	struct exact_ctx *x = ctx;
	struct vec3 c = x->cand[x->idx[i]], p = decompress(x->s, c);

	(void)tid;
	x->ok[x->idx[i]] = x->s->d->inside(x->s->d->ctx, p) &&
			   x->s->d->distance(x->s->d->ctx, p) >= 0.5 * delta_at(x->s, c);
}

static int sample_interior(struct sampler *s, struct rng *rg, struct err *e)
{
	struct vec3 sz = box3_size(s->cb);
	double h = s->dmin * 0.5;
	size_t n[3], total, nc = 0, nx = 0;
	struct vec3 *cand = NULL;
	uint32_t *mixed = NULL;
	uint8_t *ok = NULL;
	int rc = 0;

	n[0] = (size_t)ceil(sz.x / h);
	n[1] = (size_t)ceil(sz.y / h);
	n[2] = (size_t)ceil(sz.z / h);
	total = n[0] * n[1] * n[2];
	if (total > 64u * MAX_CELLS)
		return ERR_SET(e, ERR_LIMIT, "sampling grid of %zu cells is too large", total);
	/* one jittered candidate per fine cell not known to be outside */
	for (size_t pass = 0; pass < 2; pass++) {
		for (size_t k = 0; k < n[2]; k++)
			for (size_t j = 0; j < n[1]; j++)
				for (size_t i = 0; i < n[0]; i++) {
					struct vec3 c = v3(s->cb.lo.x + (i + rng_uniform(rg)) * h,
							   s->cb.lo.y + (j + rng_uniform(rg)) * h,
							   s->cb.lo.z + (k + rng_uniform(rg)) * h);
					int cl = cls_at(s, c);
					if (cl == CELL_OUT)
						continue;
					if (pass == 0) {
						nc++;
						nx += cl == CELL_MIXED;
						continue;
					}
					cand[nc] = c;
					if (cl == CELL_MIXED)
						mixed[nx++] = (uint32_t)nc;
					ok[nc++] = cl == CELL_IN;
				}
		if (pass == 0) {
			if (nc > UINT32_MAX)
				return ERR_SET(e, ERR_LIMIT, "too many sampling candidates");
			cand = mem_alloc((nc ? nc : 1) * sizeof *cand);
			mixed = mem_alloc((nx ? nx : 1) * sizeof *mixed);
			ok = mem_alloc(nc ? nc : 1);
			if (!cand || !mixed || !ok) {
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu candidates", nc);
				goto out;
			}
			nc = nx = 0;
		}
	}
	{
		struct exact_ctx x = {s, cand, mixed, ok};
		parfor_run(nx, s->d->threads, 64, exact_one, &x);
	}
	/* random order over the candidates */
	for (size_t i = nc; i > 1; i--) {
		size_t j = (size_t)rng_below(rg, i);
		struct vec3 t = cand[i - 1];
		uint8_t tk = ok[i - 1];
		cand[i - 1] = cand[j];
		cand[j] = t;
		ok[i - 1] = ok[j];
		ok[j] = tk;
	}
	for (size_t i = 0; i < nc; i++) {
		if (!ok[i] || !far_from_all(s, cand[i], delta_at(s, cand[i])))
			continue;
		if ((rc = accept_point(s, cand[i], e)) != 0)
			goto out;
		if (s->o->progress && (i & 0xffff) == 0 &&
		    (rc = progress_update(s->o->progress, 0.2 + 0.3 * i / nc, e)) != 0)
			goto out;
	}
out:
	mem_free(cand);
	mem_free(mixed);
	mem_free(ok);
	return rc;
}

/* ---- restriction ---- */

struct restrict_ctx {
	struct sampler *s;
	const struct tetra_mesh *tm;
	uint8_t *keep;
};

/* Inside the part, by the classification grid where it is certain. */
static int inside_c(const struct sampler *s, struct vec3 c)
{
	int cl = cls_at(s, c);
	return cl == CELL_MIXED ? s->d->inside(s->d->ctx, decompress(s, c)) : cl == CELL_IN;
}

/* Keep a tet when its centroid and its edges' midpoints lie inside the
 * part and no edge is longer than 2.5 target spacings: Delaunay tets whose
 * centroid is inside may still bridge a concavity with a long edge. */
static void restrict_one(void *ctx, size_t t, int tid)
{
	static const int ev[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
	struct restrict_ctx *x = ctx;
	const uint32_t *q = x->tm->tet + 4 * t;
	struct vec3 c = v3(0, 0, 0), p[4];

	(void)tid;
	for (int i = 0; i < 4; i++) {
		p[i] = v3(x->tm->xyz[3 * q[i]], x->tm->xyz[3 * q[i] + 1], x->tm->xyz[3 * q[i] + 2]);
		c = v3_add(c, v3_scale(p[i], 0.25));
	}
	x->keep[t] = 0;
	if (!inside_c(x->s, c))
		return;
	for (int j = 0; j < 6; j++) {
		struct vec3 m = v3_lerp(p[ev[j][0]], p[ev[j][1]], 0.5);
		double lim = 2.5 * delta_at(x->s, m) / POISSON_BETA;
		if (v3_dist(p[ev[j][0]], p[ev[j][1]]) > lim || !inside_c(x->s, m))
			return;
	}
	x->keep[t] = 1;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
	return x < y ? -1 : x > y;
}

struct face {
	uint32_t v[3]; /* sorted */
};

static int cmp_face(const void *pa, const void *pb)
{
	const struct face *a = pa, *b = pb;
	for (int i = 0; i < 3; i++)
		if (a->v[i] != b->v[i])
			return a->v[i] < b->v[i] ? -1 : 1;
	return 0;
}

/* Faces used by exactly one kept tet bound the complex: their nodes are
 * fixed (PO never moves them).  O(t log t). */
static int mark_boundary(struct lattice_tetmesh *t, struct err *e)
{
	static const int fv[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
	size_t nf = 4 * t->nt;
	struct face *f = mem_alloc((nf ? nf : 1) * sizeof *f);

	if (!f)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	for (size_t k = 0; k < t->nt; k++)
		for (int j = 0; j < 4; j++) {
			uint32_t a = t->tet[4 * k + fv[j][0]], b = t->tet[4 * k + fv[j][1]];
			uint32_t c = t->tet[4 * k + fv[j][2]], x;
			if (a > b) { x = a; a = b; b = x; }
			if (b > c) { x = b; b = c; c = x; }
			if (a > b) { x = a; a = b; b = x; }
			f[4 * k + j].v[0] = a;
			f[4 * k + j].v[1] = b;
			f[4 * k + j].v[2] = c;
		}
	qsort(f, nf, sizeof *f, cmp_face);
	for (size_t i = 0; i < nf;) {
		size_t j = i + 1;
		while (j < nf && cmp_face(&f[j], &f[i]) == 0)
			j++;
		if (j - i == 1)
			for (int k = 0; k < 3; k++)
				t->fixed[f[i].v[k]] = 1;
		i = j;
	}
	mem_free(f);
	return 0;
}

void lattice_tetmesh_fini(struct lattice_tetmesh *t)
{
	if (!t)
		return;
	mem_free(t->p);
	mem_free(t->tet);
	mem_free(t->fixed);
	memset(t, 0, sizeof *t);
}

int lattice_tetmesh_edges(const struct lattice_tetmesh *t, uint32_t **edges, size_t *nedges,
			  struct err *e)
{
	static const int ev[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
	size_t n = 6 * t->nt, m = 0;
	uint64_t *k = mem_alloc((n ? n : 1) * sizeof *k);
	uint32_t *out;

	if (!k)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu edges", n);
	for (size_t i = 0; i < t->nt; i++)
		for (int j = 0; j < 6; j++) {
			uint64_t a = t->tet[4 * i + ev[j][0]], b = t->tet[4 * i + ev[j][1]];
			k[6 * i + j] = a < b ? a << 32 | b : b << 32 | a;
		}
	qsort(k, n, sizeof *k, cmp_u64);
	for (size_t i = 0; i < n; i++)
		if (i == 0 || k[i] != k[i - 1])
			k[m++] = k[i];
	out = mem_alloc((m ? m : 1) * 2 * sizeof *out);
	if (!out) {
		mem_free(k);
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu edges", m);
	}
	for (size_t i = 0; i < m; i++) {
		out[2 * i] = (uint32_t)(k[i] >> 32);
		out[2 * i + 1] = (uint32_t)k[i];
	}
	mem_free(k);
	*edges = out;
	*nedges = m;
	return 0;
}

int lattice_build_tetmesh(const struct lattice_domain *d, const struct lattice_build_opts *o,
			  struct lattice_tetmesh *out, struct lattice_build_stats *st,
			  struct err *e)
{
	struct sampler s;
	struct rng rg;
	struct tetra_mesh tm = {0};
	struct lattice_tetmesh t = {0};
	uint8_t *keep = NULL;
	uint32_t *remap = NULL;
	double *xyz = NULL, t0 = progress_now_s(), t1, t2;
	size_t nsurf;
	int rc;

	memset(&s, 0, sizeof s);
	memset(st, 0, sizeof *st);
	if (!(o->so_k >= 1) || !(o->r_mm > 0) || box3_is_empty(d->box))
		return ERR_SET(e, ERR_PARAM, "bad lattice build options");
	s.d = d;
	s.o = o;
	s.k = o->so_k;
	rng_seed(&rg, o->seed);
	s.dmin = POISSON_BETA * lattice_spacing_for_density(fmax(o->density->hi, 1e-3), o->r_mm);
	s.dmax = POISSON_BETA * lattice_spacing_for_density(fmax(o->density->lo, 1e-3), o->r_mm);
	s.cb = d->box;
	s.cb.lo.z /= s.k;
	s.cb.hi.z /= s.k;
	s.cb = box3_inflate(s.cb, 1e-6 * (1 + v3_len(box3_size(s.cb))));

	/* hash grid for accepted samples and the classification grid */
	if ((rc = pointgrid_init(&s.g, s.cb, s.dmin, MAX_CELLS, e)) != 0)
		goto out;
	s.ccell = s.dmin;
	pointgrid_dims(s.cb, MAX_CELLS, &s.ccell, s.cn);
	{
		size_t ncl = (size_t)s.cn[0] * s.cn[1] * s.cn[2];
		s.cls = mem_alloc(ncl);
		if (!s.cls) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory for the sampling grids");
			goto out;
		}
		{
			struct classify_ctx cx = {&s};
			parfor_run(ncl, d->threads, 256, classify_one, &cx);
		}
	}
	if (o->progress && (rc = progress_update(o->progress, 0.1, e)) != 0)
		goto out;
	if ((rc = sample_surface(&s, &rg, e)) != 0)
		goto out;
	nsurf = s.g.np;
	if ((rc = sample_interior(&s, &rg, e)) != 0)
		goto out;
	st->surface_nodes = nsurf;
	st->interior_nodes = s.g.np - nsurf;
	t1 = progress_now_s();
	st->seconds_sample = t1 - t0;

	/* Delaunay in the compressed space */
	xyz = mem_alloc((s.g.np ? s.g.np : 1) * 3 * sizeof *xyz);
	if (!xyz) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	for (size_t i = 0; i < s.g.np; i++) {
		xyz[3 * i] = s.g.pts[i].x;
		xyz[3 * i + 1] = s.g.pts[i].y;
		xyz[3 * i + 2] = s.g.pts[i].z;
	}
	if ((rc = tetra_delaunay(xyz, s.g.np, &tm, e)) != 0) {
		err_prefix(e, "meshing %zu lattice nodes", s.g.np);
		goto out;
	}
	st->delaunay_tets = tm.ntets;
	t2 = progress_now_s();
	st->seconds_tetgen = t2 - t1;
	if (o->progress && (rc = progress_update(o->progress, 0.7, e)) != 0)
		goto out;

	/* keep tets inside the part; compact the nodes they use */
	keep = mem_alloc(tm.ntets ? tm.ntets : 1);
	remap = mem_alloc((tm.npoints ? tm.npoints : 1) * sizeof *remap);
	if (!keep || !remap) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	{
		struct restrict_ctx x = {&s, &tm, keep};
		parfor_run(tm.ntets, d->threads, 256, restrict_one, &x);
	}
	memset(remap, 0xff, tm.npoints * sizeof *remap);
	for (size_t k = 0; k < tm.ntets; k++)
		if (keep[k]) {
			t.nt++;
			for (int i = 0; i < 4; i++)
				remap[tm.tet[4 * k + i]] = 0;
		}
	for (size_t i = 0; i < tm.npoints; i++)
		if (remap[i] == 0)
			remap[i] = (uint32_t)t.np++;
	t.p = mem_alloc((t.np ? t.np : 1) * sizeof *t.p);
	t.tet = mem_alloc((t.nt ? t.nt : 1) * 4 * sizeof *t.tet);
	t.fixed = mem_calloc(t.np ? t.np : 1, 1);
	if (!t.p || !t.tet || !t.fixed) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	t.pcap = t.np;
	t.tcap = t.nt;
	for (size_t i = 0; i < tm.npoints; i++)
		if (remap[i] != UINT32_MAX) {
			/* stretch back: the SO re-scaling by k */
			t.p[remap[i]] = v3(tm.xyz[3 * i], tm.xyz[3 * i + 1], tm.xyz[3 * i + 2] * s.k);
			if (i < nsurf)
				t.fixed[remap[i]] = 1; /* on the part's surface */
		}
	{
		size_t m = 0;
		for (size_t k = 0; k < tm.ntets; k++)
			if (keep[k]) {
				for (int i = 0; i < 4; i++)
					t.tet[4 * m + i] = remap[tm.tet[4 * k + i]];
				m++;
			}
	}
	if (t.nt == 0) {
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "no lattice cell fits inside the part (too thin for the strut spacing; "
			     "raise the density or lower min_radius_mm)");
		goto out;
	}
	if ((rc = mark_boundary(&t, e)) != 0)
		goto out;
	st->kept_tets = t.nt;
	st->seconds_restrict = progress_now_s() - t2;
	*out = t;
	memset(&t, 0, sizeof t);
	rc = 0;
out:
	lattice_tetmesh_fini(&t);
	tetra_mesh_fini(&tm);
	mem_free(keep);
	mem_free(remap);
	mem_free(xyz);
	pointgrid_fini(&s.g);
	mem_free(s.cls);
	return rc;
}
