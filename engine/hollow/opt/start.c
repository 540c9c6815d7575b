/* start.c - a support-free starting point for the offset optimisation.
 *
 * Top-down sweep over a void's loops: the top loop sits on its poles
 * (collapsed, eq. 6); every vertex of a lower loop takes the smallest
 * offset that keeps it within reach = reach_slope dz (horizontally) of every
 * vertex of the loop above it is joined to by a cross edge, dz the rise
 * between the two loops (slices may differ in thickness).  With
 * reach_slope <= tan alpha every cross edge satisfies eq. 5, and then every
 * strip face satisfies eq. 3 too: a face's steepest line runs from one
 * corner to the opposite edge, at most reach horizontally over dz.  The result is
 * feasible (if conservative: floors are held to the same slope) and is
 * both Ipopt's starting point and the fallback when a solve fails.
 * O(cross edges).
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/opt_int.h"

/* Interval of t with |w + t r| <= D (r unit); 0 if empty. */
static int ray_disc(double wx, double wy, double rx, double ry, double D, double *t0, double *t1)
{
	double b = rx * wx + ry * wy, c = wx * wx + wy * wy - D * D, disc = b * b - c;

	if (disc < 0)
		return 0;
	*t0 = -b - sqrt(disc);
	*t1 = -b + sqrt(disc);
	return 1;
}

double hl_reach_slope(double alpha_rad)
{
	return 0.95 * tan(alpha_rad);
}

int hl_void_support_start(const struct hl_void *v, double reach_slope, double *l, struct err *e)
{
	size_t *cnt, *adj = NULL;
	size_t top = v->nloops - 1;

	if (v->start) {
		memcpy(l, v->start, v->nv * sizeof *l);
		return 0;
	}
	cnt = mem_calloc(v->nv + 1, sizeof *cnt);
	if (!cnt)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	/* CSR of upward neighbours per lower vertex */
	for (size_t k = 0; k < v->nxe; k++)
		cnt[v->xe[k].lo + 1]++;
	for (size_t i = 0; i < v->nv; i++)
		cnt[i + 1] += cnt[i];
	adj = mem_alloc((v->nxe + 1) * sizeof *adj);
	if (!adj) {
		mem_free(cnt);
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	}
	{
		size_t *fill = mem_alloc((v->nv + 1) * sizeof *fill);
		if (!fill) {
			mem_free(cnt);
			mem_free(adj);
			return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		}
		for (size_t i = 0; i <= v->nv; i++)
			fill[i] = cnt[i];
		for (size_t k = 0; k < v->nxe; k++)
			adj[fill[v->xe[k].lo]++] = v->xe[k].hi;
		mem_free(fill);
	}
	for (size_t j = v->off[top]; j < v->off[top + 1]; j++)
		l[j] = v->ub[j];
	for (size_t k = top; k-- > 0;) {
		double reach_mm = reach_slope * (v->z[k + 1] - v->z[k]);
		for (size_t i = v->off[k]; i < v->off[k + 1]; i++) {
			double lo = 0, hi = v->ub[i], rx = v->dir[2 * i], ry = v->dir[2 * i + 1];
			int ok = 1;
			for (size_t a = cnt[i]; a < cnt[i + 1]; a++) {
				struct vec3 q = hl_void_pos(v, adj[a], l[adj[a]]);
				double t0, t1;
				if (!ray_disc(v->p[2 * i] - q.x, v->p[2 * i + 1] - q.y, rx, ry, reach_mm,
					      &t0, &t1)) {
					ok = 0;
					break;
				}
				lo = fmax(lo, t0);
				hi = fmin(hi, t1);
			}
			if (ok && lo <= hi) {
				l[i] = lo;
				continue;
			}
			/* no offset reaches every neighbour: minimise the worst miss */
			double best = INFINITY;
			l[i] = v->ub[i];
			for (int s = 0; s <= 64; s++) {
				double t = v->ub[i] * s / 64, worst = 0;
				for (size_t a = cnt[i]; a < cnt[i + 1]; a++) {
					struct vec3 q = hl_void_pos(v, adj[a], l[adj[a]]);
					worst = fmax(worst, hypot(v->p[2 * i] + t * rx - q.x,
								  v->p[2 * i + 1] + t * ry - q.y));
				}
				if (worst < best) {
					best = worst;
					l[i] = t;
				}
			}
		}
	}
	mem_free(cnt);
	mem_free(adj);
	return 0;
}
