/* sdf.c - the shape diameter function per facet (Shapira, Shamir,
 * Cohen-Or 2008) and the paper's log normalisation (paper 003, section
 * 4.1).  Rays in a cone around the inward normal, cast on the mesh BVH,
 * outliers dropped around the median, the rest averaged with weights
 * 1 / angle.  Method, deviations and figures: docs/hybrid.md, "Partition".
 */
#include "engine/hybrid/hybrid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/parfor.h"
#include "engine/core/rng.h"
#include "engine/mesh/mesh.h"

#define SDF_MAX_RAYS 1024
#define SDF_MAX_THREADS 64
/* Re-casts past a hit on the ray's own facet (only possible when the
 * nudge is lost to rounding on a huge or sliver facet). */
#define SDF_MAX_RECASTS 2

void hy_sdf_opts_default(struct hy_sdf_opts *o)
{
	o->rays = 30;
	o->cone_deg = 120;
	o->threads = 1;
	o->seed = 0;
}

/* One ray of the pattern in the cone's own frame: z along the cone axis. */
struct sdf_ray {
	struct vec3 d;   /* unit, d.z = cos(angle) */
	double weight;   /* 1 / max(angle, floor) */
};

struct sdf_ctx {
	const struct mesh *m;
	const struct mesh_bvh *b;
	const struct vec3 *normal; /* nt unit outward normals, zero for degenerate facets */
	const struct sdf_ray *pattern;
	int rays;
	double nudge_mm;
	double *len_mm;            /* SDF_MAX_THREADS * rays scratch, by tid */
	double *sdf_mm;
	unsigned char *has;        /* nt: 1 when some ray was kept */
};

static int cmp_double(const void *a, const void *b)
{
	double x = *(const double *)a, y = *(const double *)b;

	return (x > y) - (x < y);
}

/* A unit vector orthogonal to the unit n, chosen by n's smallest
 * component so it never degenerates. */
static struct vec3 any_orthogonal(struct vec3 n)
{
	double ax = fabs(n.x), ay = fabs(n.y), az = fabs(n.z);
	struct vec3 t = ax <= ay && ax <= az ? v3(1, 0, 0) : ay <= az ? v3(0, 1, 0) : v3(0, 0, 1);

	return v3_normalize(v3_cross(n, t));
}

/* Length (mm) of the ray o + t d to the opposite wall, or -1 when it
 * leaves through a wall facing back at it (the ray is outside the solid:
 * a self-intersection, a hole, or a facet whose normal is wrong) or
 * misses.  mesh_bvh_ray is two-sided: it returns the nearest triangle
 * whatever its orientation, so the facing test is made here. */
static double cast(const struct sdf_ctx *c, size_t f, struct vec3 o, struct vec3 d)
{
	double skipped = 0;

	for (int k = 0; k <= SDF_MAX_RECASTS; k++) {
		size_t tri = 0;
		double t = mesh_bvh_ray(c->b, o, d, &tri);
		if (!isfinite(t))
			return -1;
		if (tri == f) {
			/* own facet: step past it and look further */
			o = v3_madd(o, d, t + c->nudge_mm);
			skipped += t + c->nudge_mm;
			continue;
		}
		return v3_dot(c->normal[tri], d) > 0 ? skipped + t : -1;
	}
	return -1;
}

static void sdf_facet(void *vctx, size_t f, int tid)
{
	struct sdf_ctx *c = vctx;
	const uint32_t *tri = c->m->tri + 3 * f;
	struct vec3 n = c->normal[f], axis, e1, e2, o;
	double *len = c->len_mm + (size_t)tid * (size_t)c->rays;
	double *sorted = len + (size_t)c->rays * SDF_MAX_THREADS; /* second half */
	double med, mean = 0, var = 0, sd, wsum = 0, lsum = 0;
	int i, nhit = 0;

	c->has[f] = 0;
	if (v3_len2(n) == 0)
		return; /* degenerate facet: filled from the others */
	axis = v3_scale(n, -1);
	e1 = any_orthogonal(axis);
	e2 = v3_cross(axis, e1);
	o = v3_scale(v3_add(v3_add(c->m->v[tri[0]], c->m->v[tri[1]]), c->m->v[tri[2]]), 1.0 / 3);
	o = v3_madd(o, axis, c->nudge_mm);
	for (i = 0; i < c->rays; i++) {
		const struct sdf_ray *r = &c->pattern[i];
		struct vec3 d = v3_add(v3_add(v3_scale(e1, r->d.x), v3_scale(e2, r->d.y)),
				       v3_scale(axis, r->d.z));
		len[i] = cast(c, f, o, d);
		if (len[i] >= 0)
			sorted[nhit++] = len[i];
	}
	if (nhit == 0)
		return;
	qsort(sorted, (size_t)nhit, sizeof *sorted, cmp_double);
	med = nhit & 1 ? sorted[nhit / 2] : 0.5 * (sorted[nhit / 2 - 1] + sorted[nhit / 2]);
	for (i = 0; i < nhit; i++)
		mean += sorted[i];
	mean /= nhit;
	for (i = 0; i < nhit; i++)
		var += (sorted[i] - mean) * (sorted[i] - mean);
	sd = sqrt(var / nhit);
	for (i = 0; i < c->rays; i++) {
		/* <= keeps every ray when all lengths are equal (sd = 0) */
		if (len[i] < 0 || fabs(len[i] - med) > sd)
			continue;
		wsum += c->pattern[i].weight;
		lsum += c->pattern[i].weight * len[i];
	}
	if (wsum > 0) {
		c->sdf_mm[f] = lsum / wsum;
		c->has[f] = 1;
	}
}

/* The ray pattern: n rays uniform in solid angle over the cap of half
 * angle h around +z, on a Fibonacci spiral (ray i at cos(angle) = 1 -
 * (i + 1/2) / n (1 - cos h), azimuth i times the golden angle plus a
 * phase drawn from the seed).  No ray lies on the axis; the weight
 * 1 / angle is capped at 1 / a0, where a0 is the half angle of a cap
 * holding 1 / n of the cone's solid angle, so rays nearer the axis than
 * their own share of the cone (and a ray on the axis, were there one)
 * get the finite weight 1 / a0. */
static void make_pattern(struct sdf_ray *p, int n, double half_rad, uint64_t seed)
{
	const double golden = M_PI * (3 - sqrt(5.0));
	double one_minus = 1 - cos(half_rad), a0 = acos(1 - one_minus / n), phase;
	struct rng r;

	rng_seed(&r, seed);
	phase = 2 * M_PI * rng_uniform(&r);
	for (int i = 0; i < n; i++) {
		double cz = 1 - (i + 0.5) / n * one_minus, sz = sqrt(fmax(0, 1 - cz * cz));
		double az = phase + i * golden, ang = acos(cz);
		p[i].d = v3(sz * cos(az), sz * sin(az), cz);
		p[i].weight = 1 / fmax(ang, a0);
	}
}

int hy_sdf(const struct mesh *m, const struct mesh_bvh *b, const struct hy_sdf_opts *o,
	   double *sdf_mm, struct err *e)
{
	struct sdf_ctx c;
	struct sdf_ray *pattern = NULL;
	struct vec3 *normal = NULL;
	double *len = NULL, fill = 0;
	unsigned char *has = NULL;
	struct box3 bb = box3_empty();
	size_t f, nfill = 0;
	int rc = 0, threads = o->threads < 1 ? 1 : o->threads > SDF_MAX_THREADS ? SDF_MAX_THREADS
										 : o->threads;

	if (o->rays < 1 || o->rays > SDF_MAX_RAYS)
		return ERR_FIELD(e, "sdf_rays", "rays per facet must be 1..%d, not %d", SDF_MAX_RAYS,
				 o->rays);
	if (!(o->cone_deg > 0 && o->cone_deg < 180))
		return ERR_FIELD(e, "sdf_cone_deg", "cone opening must be in (0, 180) deg, not %g",
				 o->cone_deg);
	if (m->nt == 0)
		return 0;
	pattern = mem_alloc((size_t)o->rays * sizeof *pattern);
	normal = mem_alloc(m->nt * sizeof *normal);
	/* two halves: lengths by ray, then the sorted hits, per thread */
	len = mem_alloc(2 * SDF_MAX_THREADS * (size_t)o->rays * sizeof *len);
	has = mem_alloc(m->nt);
	if (!pattern || !normal || !len || !has) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for the SDF of %zu facets", m->nt);
		goto out;
	}
	for (f = 0; f < m->nt; f++) {
		const uint32_t *t = m->tri + 3 * f;
		struct vec3 a = m->v[t[0]], p = m->v[t[1]], q = m->v[t[2]];
		normal[f] = v3_normalize(v3_cross(v3_sub(p, a), v3_sub(q, a)));
		box3_add(&bb, a);
		box3_add(&bb, p);
		box3_add(&bb, q);
	}
	make_pattern(pattern, o->rays, o->cone_deg * M_PI / 360, o->seed);
	memset(&c, 0, sizeof c);
	c.m = m;
	c.b = b;
	c.normal = normal;
	c.pattern = pattern;
	c.rays = o->rays;
	/* far below any facet of a printable part, far above double rounding
	 * of the coordinates (1e-16 relative) */
	c.nudge_mm = 1e-7 * v3_len(box3_size(bb));
	c.len_mm = len;
	c.sdf_mm = sdf_mm;
	c.has = has;
	parfor_run(m->nt, threads, 64, sdf_facet, &c);
	for (f = 0; f < m->nt; f++)
		if (has[f]) {
			fill += sdf_mm[f];
			nfill++;
		}
	fill = nfill ? fill / (double)nfill : 0;
	for (f = 0; f < m->nt; f++)
		if (!has[f])
			sdf_mm[f] = fill;
out:
	mem_free(pattern);
	mem_free(normal);
	mem_free(len);
	mem_free(has);
	return rc;
}

void hy_nsdf(const double *sdf_mm, size_t n, double alpha, double *nsdf)
{
	double lo = INFINITY, hi = -INFINITY;
	size_t i;

	for (i = 0; i < n; i++) {
		lo = fmin(lo, sdf_mm[i]);
		hi = fmax(hi, sdf_mm[i]);
	}
	for (i = 0; i < n; i++) {
		double x = hi > lo ? (sdf_mm[i] - lo) / (hi - lo) : 0;
		/* alpha -> 0 is the linear normalisation (the limit of the log form) */
		nsdf[i] = alpha > 0 ? log(x * alpha + 1) / log(alpha + 1) : x;
	}
}
