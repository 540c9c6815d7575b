/* optimize.c - design updates that refine the rhombic hierarchy: uniform
 * refinement, and stiffness by greedy refinement ranked by the
 * sensitivity of eq. 10-13 on the voxel FEA of engine/fea (docs/rhombic.md
 * section 5).
 */
#include "engine/rhombic/optimize.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/progress.h"
#include "engine/fea/fea.h"
#include "engine/mesh/mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* fea_relax_bound's stopping rule for the bound (docs/rhombic.md 8) */
#define RH_BOUND_MAX_ITER 300
#define RH_BOUND_GAP 0.002

int rh_uniform(struct rh_tree *t, double part_vol, double target, int *steps, struct err *e)
{
	int32_t *leaves = NULL;
	size_t cap = 0;
	int rc = 0;

	*steps = 0;
	while (t->cavities > 0 && (part_vol - t->cavity_volume_mm3) / part_vol < target) {
		size_t n = 0;
		if (mem_grow((void **)&leaves, &cap, t->cavities, sizeof *leaves)) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
			break;
		}
		for (size_t i = 0; i < t->n; i++)
			if (t->c[i].state == RH_CAVITY && n < cap)
				leaves[n++] = (int32_t)i;
		for (size_t k = 0; k < n && !rc; k++)
			rc = rh_tree_refine(t, leaves[k], NULL, e);
		if (rc)
			break;
		(*steps)++;
	}
	mem_free(leaves);
	return rc;
}

/* ---- stiffness: section 5.1 ---- */

struct stiff {
	struct rh_tree *t;
	const struct rh_stiff_opts *o;
	struct fea_grid g;       /* densities handed to the solver (g.rho) */
	float *part;             /* part fraction per element (the voxeliser's) */
	uint16_t *cnt;           /* cavity sample points per element, of ss^3 */
	float *energy;           /* u_e^T K0 u_e per element (N mm) */
	struct fea_solver *sv;
	int ss;
	size_t ne;
	/* per cell: its S_C cache as a range of the pool, start -1 = none */
	int64_t *cstart;
	int32_t *clen;
	size_t ccap;
	uint32_t *pe;            /* pool: element index */
	float *pd;               /* pool: d_e, the fraction of e in S_C */
	size_t pn, pcap;
};

/* Element index range [i0, i1] x [j0, j1] x [k0, k1] covering cell c. */
static void cell_elements(const struct stiff *st, const struct rh_cell *c, int r[6])
{
	const struct rh_frame *f = &st->t->f;
	const struct fea_grid *g = &st->g;
	struct rh_geom cg;
	double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
	int n[3] = {g->nx, g->ny, g->nz};
	double o[3] = {g->lo_mm.x, g->lo_mm.y, g->lo_mm.z};

	rh_cell_geom(f, c, &cg);
	for (int q = 0; q < 8; q++) {
		double u = q < 4 ? cg.cu + ((q & 1) ? cg.a : -cg.a) : cg.cu;
		double z = q < 4 ? cg.cz : cg.cz + ((q & 1) ? cg.b : -cg.b);
		double p[3];
		rh_to_printer(f, u, (q & 2) ? cg.vhi : cg.vlo, &p[0], &p[1]);
		p[2] = z;
		for (int a = 0; a < 3; a++) {
			lo[a] = fmin(lo[a], p[a]);
			hi[a] = fmax(hi[a], p[a]);
		}
	}
	for (int a = 0; a < 3; a++) {
		int i0 = (int)floor((lo[a] - o[a]) / g->h_mm), i1 = (int)floor((hi[a] - o[a]) / g->h_mm);
		r[2 * a] = i0 < 0 ? 0 : i0;
		r[2 * a + 1] = i1 >= n[a] ? n[a] - 1 : i1;
	}
}

/* Sample point s (0 .. ss^3 - 1) of element (i, j, k): sub-cell centres. */
static struct vec3 sample_point(const struct stiff *st, int i, int j, int k, int s)
{
	const struct fea_grid *g = &st->g;
	int ss = st->ss, a = s % ss, b = s / ss % ss, c = s / (ss * ss);

	return v3(g->lo_mm.x + (i + (a + 0.5) / ss) * g->h_mm,
		  g->lo_mm.y + (j + (b + 0.5) / ss) * g->h_mm,
		  g->lo_mm.z + (k + (c + 0.5) / ss) * g->h_mm);
}

static void count_element(struct stiff *st, int i, int j, int k)
{
	size_t e = ((size_t)k * (size_t)st->g.ny + (size_t)j) * (size_t)st->g.nx + (size_t)i;
	int n = 0, s3 = st->ss * st->ss * st->ss;

	if (!(st->part[e] > 0))
		return;
	for (int s = 0; s < s3; s++) {
		struct vec3 p = sample_point(st, i, j, k, s);
		n += rh_tree_in_cavity(st->t, p.x, p.y, p.z);
	}
	st->cnt[e] = (uint16_t)n;
}

static void count_slice(void *ctx, size_t k, int tid)
{
	struct stiff *st = ctx;

	(void)tid;
	for (int j = 0; j < st->g.ny; j++)
		for (int i = 0; i < st->g.nx; i++)
			count_element(st, i, j, (int)k);
}

/* rho_e = max(part - cavity, rho_min) where the part is, 0 elsewhere
 * (the present set never changes); solid: the part alone. */
static void set_densities(struct stiff *st, int solid)
{
	double s3 = (double)(st->ss * st->ss * st->ss);

	for (size_t e = 0; e < st->ne; e++) {
		double r = st->part[e];
		if (!(r > 0)) {
			st->g.rho[e] = 0;
			continue;
		}
		if (!solid)
			r -= st->cnt[e] / s3;
		st->g.rho[e] = (float)(r > st->o->rho_min ? r : st->o->rho_min);
	}
}

/* The FEA options of every solve here: the defaults with the caller's
 * threads and SIMP law (penal, rho_min). */
static void stiff_fea_opts(const struct stiff *st, struct fea_opts *fo)
{
	fea_opts_default(fo);
	fo->threads = st->o->threads;
	fo->penal = st->o->penal;
	fo->rho_min = st->o->rho_min;
}

static int solve(struct stiff *st, const struct fea_loads *loads, struct rh_stiff_report *r,
		 double fraction, struct fea_result *res, struct err *e)
{
	struct fea_opts fo;
	int rc;

	if (!st->sv) {
		stiff_fea_opts(st, &fo);
		if (st->o->fea_tol > 0)
			fo.tol = st->o->fea_tol;
		rc = fea_solver_new(&st->g, loads, &fo, &st->sv, e);
	} else {
		rc = fea_solver_set_rho(st->sv, st->g.rho, e);
	}
	if (rc || (rc = fea_solve(st->sv, res, e)) != 0)
		return rc;
	if (mem_grow((void **)&r->hist, &r->caphist, r->nhist + 1, sizeof *r->hist))
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
	r->hist[r->nhist].fraction = fraction;
	r->hist[r->nhist].compliance_nmm = res->compliance_nmm;
	r->hist[r->nhist].max_displacement_mm = res->max_displacement_mm;
	r->hist[r->nhist].cg_iterations = res->iterations;
	r->hist[r->nhist].solve_s = res->solve_s;
	r->nhist++;
	r->solve_s += res->solve_s;
	r->elements = res->elements;
	return 0;
}

/* The result's solve again at the FEA's default tolerance when the loop
 * ranked on looser ones (warm start: it continues from the last
 * displacement); its figures replace the last history entry's. */
static int tighten(struct stiff *st, struct rh_stiff_report *r, struct fea_result *res,
		   struct err *e)
{
	struct fea_opts def;
	struct rh_stiff_step *h;
	int rc;

	fea_opts_default(&def);
	if (!(st->o->fea_tol > def.tol) || !r->nhist)
		return 0;
	if ((rc = fea_solver_set_tol(st->sv, def.tol, e)) != 0 ||
	    (rc = fea_solve(st->sv, res, e)) != 0)
		return rc;
	h = &r->hist[r->nhist - 1];
	h->compliance_nmm = res->compliance_nmm;
	h->max_displacement_mm = res->max_displacement_mm;
	h->cg_iterations += res->iterations;
	h->solve_s += res->solve_s;
	r->solve_s += res->solve_s;
	r->compliance_nmm = res->compliance_nmm;
	r->max_displacement_mm = res->max_displacement_mm;
	return 0;
}

/* The bound of rh_stiff_report.bound_nmm: fea_relax_bound from the initial
 * densities (floor) to the solid part's (st->g.rho after
 * set_densities(st, 1)), with the result's material and the stiffness
 * solves' load vector (spread once by the initial densities). */
static int bound(struct stiff *st, const struct fea_loads *loads, float *floor_rho, double vol,
		 struct rh_stiff_report *r, struct err *e)
{
	struct fea_grid g = st->g;
	struct fea_opts fo;
	struct fea_bound_opts bo = {.max_iter = RH_BOUND_MAX_ITER, .gap = RH_BOUND_GAP,
				    .progress = st->o->progress, .f0 = 0.95, .f1 = 1.0};
	struct fea_bound b;
	int rc;

	g.rho = floor_rho;
	stiff_fea_opts(st, &fo); /* default tolerance: the bound holds at any accuracy */
	rc = fea_relax_bound(&g, st->g.rho, vol, loads, fea_solver_force(st->sv), &fo, &bo, &b, e);
	if (rc)
		return rc;
	r->bound_nmm = b.lower_nmm;
	r->bound_upper_nmm = b.upper_nmm;
	r->bound_iterations = b.iterations;
	r->bound_s = b.solve_s;
	return 0;
}

static int pool_grow(struct stiff *st)
{
	size_t cap = st->pcap ? 2 * st->pcap : 4096;
	uint32_t *pe = mem_realloc_array(st->pe, cap, sizeof *pe);
	float *pd;

	if (!pe)
		return ERR_NOMEM;
	st->pe = pe;
	pd = mem_realloc_array(st->pd, cap, sizeof *pd);
	if (!pd)
		return ERR_NOMEM;
	st->pd = pd;
	st->pcap = cap;
	return 0;
}

static int in_cavity(const struct rh_cavity *c, double u, double z, double v)
{
	return fabs(u - c->cu) / c->a + fabs(z - c->cz) / c->b < c->k && v > c->vlo && v < c->vhi;
}

/* S_C of leaf idx (its cavity less its children's, or all of it when the
 * children would be below the minimum size) as (element, fraction) in the
 * pool, by the ss^3 sample points of each element. */
static int leaf_cache(struct stiff *st, int32_t idx, struct err *e)
{
	const struct rh_tree *t = st->t;
	const struct rh_frame *f = &t->f;
	const struct rh_cell *c = &t->c[idx];
	struct rh_cavity cv, ch[8];
	int r[6], split = rh_tree_can_split(t, idx), s3 = st->ss * st->ss * st->ss;
	int L = c->level + 1, nchild = 0;

	rh_cell_cavity(f, c, &cv);
	if (split) {
		nchild = t->f.vsplit[L] > t->f.vsplit[c->level] ? 8 : 4;
		for (int q = 0; q < nchild; q++) {
			struct rh_cell cc = *c;
			cc.level = (uint8_t)L;
			cc.i = 2 * c->i + (q & 1);
			cc.j = 2 * c->j + ((q >> 1) & 1);
			cc.kv = nchild == 8 ? 2 * c->kv + (q >> 2) : c->kv;
			rh_cell_cavity(f, &cc, &ch[q]);
		}
	}
	st->cstart[idx] = (int64_t)st->pn;
	st->clen[idx] = 0;
	cell_elements(st, c, r);
	for (int k = r[4]; k <= r[5]; k++)
		for (int j = r[2]; j <= r[3]; j++)
			for (int i = r[0]; i <= r[1]; i++) {
				size_t el = ((size_t)k * (size_t)st->g.ny + (size_t)j) * (size_t)st->g.nx +
					    (size_t)i;
				int n = 0;
				if (!(st->part[el] > 0))
					continue;
				for (int s = 0; s < s3; s++) {
					struct vec3 p = sample_point(st, i, j, k, s);
					double u, v;
					rh_to_cell(f, p.x, p.y, &u, &v);
					if (!in_cavity(&cv, u, p.z, v))
						continue;
					if (split) {
						/* the child holding p: the quadrant of the parent's
						 * sheared square (s, r) = ((du + dz)/2, (dz - du)/2),
						 * and the half along v */
						double du = (u - cv.cu) / cv.a, dz = (p.z - cv.cz) / cv.b;
						int di = du + dz >= 0, dj = dz - du >= 0, dv = 0;
						if (nchild == 8)
							dv = v >= (cv.vlo + cv.vhi) / 2;
						if (in_cavity(&ch[(dv * 2 + dj) * 2 + di], u, p.z, v))
							continue;
					}
					n++;
				}
				if (!n)
					continue;
				if (st->pn >= st->pcap && pool_grow(st))
					return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for the "
						       "sensitivity caches");
				st->pe[st->pn] = (uint32_t)el;
				st->pd[st->pn] = (float)n / (float)s3;
				st->pn++;
				st->clen[idx]++;
			}
	return 0;
}

static int ensure_cells(struct stiff *st, struct err *e)
{
	size_t n = st->t->n, cap = n * 2;
	int64_t *cs;
	int32_t *cl;

	if (n <= st->ccap)
		return 0;
	cs = mem_realloc_array(st->cstart, cap, sizeof *cs);
	if (!cs)
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
	st->cstart = cs;
	cl = mem_realloc_array(st->clen, cap, sizeof *cl);
	if (!cl)
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
	st->clen = cl;
	for (size_t i = st->ccap; i < cap; i++) {
		st->cstart[i] = -1;
		st->clen[i] = 0;
	}
	st->ccap = cap;
	return 0;
}

struct leaf_key {
	double g;
	int32_t idx;
};

static int cmp_desc(const void *pa, const void *pb)
{
	const struct leaf_key *a = pa, *b = pb;

	if (a->g != b->g)
		return a->g > b->g ? -1 : 1;
	return a->idx < b->idx ? -1 : a->idx > b->idx;
}

/* Eq. 10-13 for every leaf: G_C = (p/2) sum_e d_e rho_e^(p-1) E_e /
 * sum_e d_e, E_e = u_e^T K0 u_e, d_e the fraction of e the split fills;
 * rho_e the element's density (eq. 10 at the current design), or rho_min
 * for every element (o->binary: the paper's S_C of cavity elements). */
static int rank_leaves(struct stiff *st, struct leaf_key **keys, size_t *cap, size_t *nk,
		       struct err *e)
{
	const double pe = st->o->penal, wmin = pow(st->o->rho_min, pe - 1);
	struct rh_tree *t = st->t;
	int rc;

	*nk = 0;
	if ((rc = ensure_cells(st, e)) != 0)
		return rc;
	if (mem_grow((void **)keys, cap, t->cavities, sizeof **keys))
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
	for (size_t i = 0; i < t->n; i++) {
		double num = 0, den = 0;
		if (t->c[i].state != RH_CAVITY || *nk >= *cap)
			continue;
		if (st->cstart[i] < 0 && (rc = leaf_cache(st, (int32_t)i, e)) != 0)
			return rc;
		for (int32_t q = 0; q < st->clen[i]; q++) {
			size_t p = (size_t)st->cstart[i] + (size_t)q;
			double w = st->o->binary ? wmin : pow(st->g.rho[st->pe[p]], pe - 1);
			num += st->pd[p] * w * st->energy[st->pe[p]];
			den += st->pd[p];
		}
		(*keys)[*nk].g = den > 0 ? pe / 2 * num / den : 0;
		(*keys)[(*nk)++].idx = (int32_t)i;
	}
	qsort(*keys, *nk, sizeof **keys, cmp_desc);
	return 0;
}

void rh_stiff_report_fini(struct rh_stiff_report *r)
{
	mem_free(r->hist);
	memset(r, 0, sizeof *r);
}

int rh_stiffness(struct rh_tree *t, const struct mesh *part, const struct fea_loads *loads,
		 const struct rh_stiff_opts *o, struct rh_stiff_report *r, struct err *e)
{
	struct stiff st;
	struct fea_result res;
	struct leaf_key *keys = NULL;
	int32_t *done = NULL;
	size_t capk = 0, capd = 0;
	double pv = o->part_vol_mm3, frac0 = (pv - t->cavity_volume_mm3) / pv;
	int stop = 0, rc;
	float *floor_rho = NULL; /* o->bound: the initial structure's densities */
	double design_sum = 0;

	memset(&st, 0, sizeof st);
	memset(r, 0, sizeof *r);
	st.t = t;
	st.o = o;
	st.ss = o->supersample < 1 ? 1 : o->supersample > 6 ? 6 : o->supersample;
	r->fea_voxel_mm = o->fea_voxel_mm;
	if ((rc = fea_voxelize_mesh(part, o->fea_voxel_mm, 4, o->max_elements, o->threads, &st.g,
				    e)) != 0)
		goto out;
	st.ne = (size_t)st.g.nx * (size_t)st.g.ny * (size_t)st.g.nz;
	st.part = mem_alloc(st.ne * sizeof *st.part);
	st.cnt = mem_calloc(st.ne, sizeof *st.cnt);
	st.energy = mem_alloc(st.ne * sizeof *st.energy);
	if (!st.part || !st.cnt || !st.energy) {
		rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for %zu elements", st.ne);
		goto out;
	}
	memcpy(st.part, st.g.rho, st.ne * sizeof *st.part);
	parfor_run((size_t)st.g.nz, o->threads, 1, count_slice, &st);
	set_densities(&st, 0);
	if (o->bound && o->adaptive) {
		floor_rho = mem_alloc(st.ne * sizeof *floor_rho);
		if (!floor_rho) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for the bound");
			goto out;
		}
		memcpy(floor_rho, st.g.rho, st.ne * sizeof *floor_rho);
	}
	for (;;) {
		double frac = (pv - t->cavity_volume_mm3) / pv;
		size_t nk = 0, nsplit, nd = 0;
		if ((rc = solve(&st, loads, r, frac, &res, e)) != 0)
			goto out;
		r->compliance_nmm = res.compliance_nmm;
		r->max_displacement_mm = res.max_displacement_mm;
		if (!o->adaptive || stop || r->iterations >= o->max_iterations || t->cavities == 0)
			break;
		fea_element_energy(st.sv, st.energy);
		if ((rc = rank_leaves(&st, &keys, &capk, &nk, e)) != 0)
			goto out;
		nsplit = (size_t)ceil(o->split_pct / 100 * (double)nk);
		nsplit = nsplit < 1 ? 1 : nsplit > nk ? nk : nsplit;
		if (mem_grow((void **)&done, &capd, nsplit, sizeof *done)) {
			rc = ERR_SET(e, ERR_NOMEM, "rhombic: out of memory");
			goto out;
		}
		for (size_t k = 0; k < nsplit; k++) {
			int32_t idx = keys[k].idx;
			double add = rh_tree_refine_gain(t, idx);
			/* eq. 7: stop as soon as the next split would pass V* */
			if ((pv - (t->cavity_volume_mm3 - add)) / pv > o->target) {
				stop = 1;
				break;
			}
			if ((rc = rh_tree_refine(t, idx, NULL, e)) != 0)
				goto out;
			done[nd++] = idx;
		}
		if (!nd)
			break; /* nothing changed: the last solve is the result's */
		/* the densities change inside the split cells only */
		for (size_t q = 0; q < nd; q++) {
			int b[6];
			cell_elements(&st, &t->c[done[q]], b);
			for (int k = b[4]; k <= b[5]; k++)
				for (int j = b[2]; j <= b[3]; j++)
					for (int i = b[0]; i <= b[1]; i++)
						count_element(&st, i, j, k);
		}
		set_densities(&st, 0);
		r->iterations++;
		if (o->progress && o->target > frac0 &&
		    (rc = progress_update(o->progress,
					  0.5 + 0.45 * fmin(1, (frac - frac0) / (o->target - frac0)),
					  e)) != 0)
			goto out;
	}
	if ((rc = tighten(&st, r, &res, e)) != 0)
		goto out;
	for (size_t q = 0; floor_rho && q < st.ne; q++)
		design_sum += st.g.rho[q]; /* the bound's budget */
	/* the solid part under the same load (normalisation, Fig. 11) */
	set_densities(&st, 1);
	if ((rc = solve(&st, loads, r, 1.0, &res, e)) != 0)
		goto out;
	r->compliance_solid_nmm = res.compliance_nmm;
	r->max_displacement_solid_mm = res.max_displacement_mm;
	if (floor_rho && (rc = bound(&st, loads, floor_rho, design_sum, r, e)) != 0)
		goto out;
out:
	mem_free(floor_rho);
	fea_solver_free(st.sv);
	fea_grid_fini(&st.g);
	mem_free(st.part);
	mem_free(st.cnt);
	mem_free(st.energy);
	mem_free(st.cstart);
	mem_free(st.clen);
	mem_free(st.pe);
	mem_free(st.pd);
	mem_free(keys);
	mem_free(done);
	return rc;
}
