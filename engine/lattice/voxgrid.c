/* voxgrid.c - voxel grids for density matching, and the independent
 * per-voxel density measurement (gen.h lattice_measure_density). */
#include "engine/lattice/voxgrid.h"
#include "engine/lattice/kernel.h"
#include "engine/lattice/strutgrid.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/rng.h"

#include <math.h>
#include <string.h>

#define MEASURE_SAMPLES 1728 /* 12^3 regular points per voxel */

/* ---- voxels ---- */


size_t lattice_vox_count(const struct voxels *v)
{
	return (size_t)v->n[0] * v->n[1] * v->n[2];
}

struct box3 lattice_vox_box(const struct voxels *v, size_t idx)
{
	size_t nx = (size_t)v->n[0], ny = (size_t)v->n[1];
	int i = (int)(idx % nx), j = (int)(idx / nx % ny), k = (int)(idx / (nx * ny));
	struct box3 b;

	b.lo = v3(v->lo.x + i * v->h, v->lo.y + j * v->h, v->lo.z + k * v->h);
	b.hi = v3_add(b.lo, v3(v->h, v->h, v->h));
	return b;
}

/* Sample s of voxel idx: jittered stratified (jitter 0 = cell centres,
 * the independent measurement's regular grid). */
struct vec3 lattice_vox_sample(const struct voxels *v, size_t idx, int s, int jitter)
{
	struct box3 b = lattice_vox_box(v, idx);
	int i = s % v->side, j = s / v->side % v->side, k = s / (v->side * v->side);
	double c = v->h / v->side, u = 0.5, w = 0.5, t = 0.5;

	if (jitter) {
		struct rng r;
		rng_seed(&r, v->seed ^ (idx * 0x9E3779B97F4A7C15ull) ^ ((uint64_t)s << 40));
		u = rng_uniform(&r);
		w = rng_uniform(&r);
		t = rng_uniform(&r);
	}
	return v3(b.lo.x + (i + u) * c, b.lo.y + (j + w) * c, b.lo.z + (k + t) * c);
}

struct vox_setup {
	struct voxels *v;
	const struct lattice_domain *d;
	const struct lattice_density *den;
	int jitter;
};

#define SUB 4 /* sub-cells per axis for classifying a voxel cut by the surface */

/* Classify the voxel's samples: the voxel as a whole when its centre is
 * farther from the surface than its half diagonal, else per sub-cell
 * (SUB^3) the same way, and only samples of sub-cells cut by the surface
 * get their own inside test (those are the expensive queries). */
static void vox_setup_one(void *ctx, size_t idx, int tid)
{
	struct vox_setup *x = ctx;
	struct voxels *v = x->v;
	struct box3 b = lattice_vox_box(v, idx);
	struct vec3 c = box3_center(b);
	double hd = 0.5 * v->h * sqrt(3.0), dist = x->d->distance(x->d->ctx, c);
	int in_c = x->d->inside(x->d->ctx, c), ns = v->side * v->side * v->side, cnt = 0;
	uint8_t *bits = v->inside + idx * v->bytes_per;
	signed char sub[SUB * SUB * SUB]; /* 0/1 uniform, -1 cut */
	double tsum = 0, sh = v->h / SUB;

	(void)tid;
	memset(bits, 0, v->bytes_per);
	for (int q = 0; q < SUB * SUB * SUB; q++) {
		struct vec3 sc;
		if (dist > hd) {
			sub[q] = (signed char)in_c;
			continue;
		}
		sc = v3(b.lo.x + (q % SUB + 0.5) * sh, b.lo.y + (q / SUB % SUB + 0.5) * sh,
			b.lo.z + (q / (SUB * SUB) + 0.5) * sh);
		sub[q] = x->d->distance(x->d->ctx, sc) > 0.5 * sh * sqrt(3.0)
				 ? (signed char)x->d->inside(x->d->ctx, sc)
				 : -1;
	}
	for (int s = 0; s < ns; s++) {
		struct vec3 p = lattice_vox_sample(v, idx, s, x->jitter);
		int i = s % v->side, j = s / v->side % v->side, k = s / (v->side * v->side);
		int q = (i * SUB / v->side) + SUB * (j * SUB / v->side) +
			SUB * SUB * (k * SUB / v->side);
		int in = sub[q] >= 0 ? sub[q] : x->d->inside(x->d->ctx, p);
		if (in) {
			bits[s >> 3] |= (uint8_t)(1u << (s & 7));
			cnt++;
			tsum += lattice_density_at(x->den, p);
		}
	}
	v->frac[idx] = (float)cnt / ns;
	v->target[idx] = cnt ? tsum / cnt : 0;
}

int lattice_voxels_init(struct voxels *v, const struct lattice_domain *d,
		       const struct lattice_density *den, double h, int samples, uint64_t seed,
		       int jitter, struct err *e)
{
	struct vec3 s = box3_size(d->box);
	size_t n;

	memset(v, 0, sizeof *v);
	v->h = h;
	v->side = (int)ceil(cbrt((double)samples));
	if (v->side < 2)
		v->side = 2;
	v->seed = seed;
	v->lo = d->box.lo;
	for (int a = 0; a < 3; a++) {
		double len = v3_comp(s, a);
		v->n[a] = (int)ceil(len / h);
		if (v->n[a] < 1)
			v->n[a] = 1;
	}
	/* centre the grid on the box */
	v->lo = v3_sub(v->lo, v3(0.5 * (v->n[0] * h - s.x), 0.5 * (v->n[1] * h - s.y),
				 0.5 * (v->n[2] * h - s.z)));
	n = lattice_vox_count(v);
	if (n > (4u << 20))
		return ERR_SET(e, ERR_LIMIT, "%zu density voxels are too many; raise voxel_mm", n);
	v->bytes_per = (size_t)(v->side * v->side * v->side + 7) / 8;
	v->inside = mem_alloc(n * v->bytes_per);
	v->target = mem_alloc(n * sizeof *v->target);
	v->frac = mem_alloc(n * sizeof *v->frac);
	if (!v->inside || !v->target || !v->frac)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu voxels", n);
	{
		struct vox_setup x = {v, d, den, jitter};
		parfor_run(n, d->threads, 4, vox_setup_one, &x);
	}
	return 0;
}

void lattice_voxels_fini(struct voxels *v)
{
	mem_free(v->inside);
	mem_free(v->target);
	mem_free(v->frac);
}

/* ---- independent measurement ---- */

struct measure_ctx {
	const struct voxels *v;
	const struct strut_grid *g;
	const double *w; /* weight per strut */
	double *dens;    /* per voxel, NAN = not counted */
};

static void measure_one(void *ctx, size_t idx, int tid)
{
	struct measure_ctx *x = ctx;
	const struct voxels *v = x->v;
	int ns = v->side * v->side * v->side, in = 0, hit = 0;

	(void)tid;
	x->dens[idx] = NAN;
	if (v->frac[idx] < 0.5)
		return;
	for (int s = 0; s < ns; s++) {
		const uint32_t *it;
		size_t cnt;
		struct vec3 p;
		double f = 0;

		if (!lattice_vox_inside(v, idx, s))
			continue;
		p = lattice_vox_sample(v, idx, s, 0);
		strut_grid_cell(x->g, p, &it, &cnt);
		for (size_t k = 0; k < cnt && f <= 1; k++) {
			uint32_t j = it[k];
			f += x->w[j] * lattice_kernel_integral(p, x->g->node[x->g->ab[2 * j]],
							       x->g->node[x->g->ab[2 * j + 1]], x->g->R);
		}
		in++;
		hit += f > 1;
	}
	x->dens[idx] = in ? (double)hit / in : NAN;
}

int lattice_measure_density(const struct lattice *q, const struct lattice_domain *d,
			    const struct lattice_density *target, double voxel_mm, int threads,
			    double *mean_err, double *max_err, size_t *voxels, struct err *e)
{
	struct voxels v;
	struct strut_grid g;
	uint32_t *ab = NULL;
	double *w = NULL, *dens = NULL, R = lattice_support(q, 1.5), sum = 0, mx = 0;
	size_t n = 0;
	int rc;

	memset(&g, 0, sizeof g);
	/* a regular 12^3 grid per voxel (jitter 0): not the matching's samples */
	if ((rc = lattice_voxels_init(&v, d, target, voxel_mm, MEASURE_SAMPLES, 0, 0, e)) != 0)
		goto out;
	ab = mem_alloc((q->nedges ? q->nedges : 1) * 2 * sizeof *ab);
	w = mem_alloc((q->nedges ? q->nedges : 1) * sizeof *w);
	dens = mem_alloc(lattice_vox_count(&v) * sizeof *dens);
	if (!ab || !w || !dens) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory");
		goto out;
	}
	for (size_t i = 0; i < q->nedges; i++) {
		ab[2 * i] = q->edge[i].a;
		ab[2 * i + 1] = q->edge[i].b;
		w[i] = lattice_weight_for_radius(q->edge[i].radius_mm, 1.0, R);
	}
	if ((rc = strut_grid_init(&g, q->node, ab, q->nedges, R,
				  fmax(0.6 * R, q->nedges ? 0.25 * lattice_total_length(q) / q->nedges
							  : R),
				  e)) != 0)
		goto out;
	{
		struct measure_ctx x = {&v, &g, w, dens};
		parfor_run(lattice_vox_count(&v), threads, 1, measure_one, &x);
	}
	for (size_t i = 0; i < lattice_vox_count(&v); i++) {
		double err;
		if (isnan(dens[i]))
			continue;
		err = fabs(dens[i] - v.target[i]);
		sum += err;
		mx = fmax(mx, err);
		n++;
	}
	*mean_err = n ? sum / n : 0;
	*max_err = mx;
	*voxels = n;
	rc = 0;
out:
	strut_grid_fini(&g);
	lattice_voxels_fini(&v);
	mem_free(ab);
	mem_free(w);
	mem_free(dens);
	return rc;
}
