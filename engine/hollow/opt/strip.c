/* strip.c - optimal strip triangulation between two loops (paper 004,
 * section 8.1, after Fuchs, Kedem and Uselton 1977).
 *
 * A strip between lower loop A (a_0..a_{n-1}) and upper loop B is a
 * monotone path on the grid (0,0) -> (n,m): a step in i adds triangle
 * (a_i, b_j, a_{i+1}), a step in j adds (b_j, b_{j+1}, a_i); the grid
 * point (i, j) is the cross edge a_i b_j.  Both triangle kinds are written
 * so their normal (right-hand rule) points into the void: for a vertical
 * cylinder, (a_{i+1} - a_i) x (b_j - a_i) points outward, so the order is
 * (a_i, b_j, a_{i+1}).  Dynamic programming minimises the total area
 * (plus a small cross-edge length term that breaks ties, see tri_cost);
 * triangles the caller blocks (they meet the outer surface) cost
 * infinity, which is what keeps the strip clear of the part's skin.  The
 * start pair is a_0 and its nearest b.  A band of width W around the
 * diagonal is searched first (O(n W) area evaluations and memory), the
 * full grid (O(n m)) only if the band has no admissible path and the
 * grid is small (dpband.h, HL_DP_*: 9 bytes a cell here).
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/dpband.h"
#include "engine/hollow/opt/opt_int.h"

struct strip_in {
	const double *pa, *pb;
	double za, zb;
	size_t na, nb, ia0, jb0;
	const struct hl_block *block;
	double reach2; /* squared longest cross edge considered (mm^2) */
	int use_block; /* test clearance inside the DP (second pass only) */
};

static struct vec3 pa_at(const struct strip_in *s, size_t i)
{
	size_t k = (s->ia0 + i) % s->na;
	return v3(s->pa[2 * k], s->pa[2 * k + 1], s->za);
}

static struct vec3 pb_at(const struct strip_in *s, size_t j)
{
	size_t k = (s->jb0 + j) % s->nb;
	return v3(s->pb[2 * k], s->pb[2 * k + 1], s->zb);
}

/* Area plus a tie-breaker: on straight, parallel stretches every
 * triangle has the same area (h * s / 2) and a fan would be as cheap as
 * a zigzag; adding half the layer height times the new cross edge's
 * length prefers short cross edges, which eq. 5 also wants. */
static double tri_area_cost(const struct strip_in *s, struct vec3 a, struct vec3 b,
			    struct vec3 c, struct vec3 n0, struct vec3 n1)
{
	return 0.5 * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a))) +
	       0.5 * fabs(s->zb - s->za) * v3_dist(n0, n1);
}

static int tri_blocked(const struct strip_in *s, struct vec3 a, struct vec3 b, struct vec3 c)
{
	return s->use_block && s->block && s->block->blocked &&
	       s->block->blocked(s->block->ctx, a, b, c);
}

/* Row i's window of the band |j - i nb / na| <= band: columns jlo..jhi. */
static void band_row(const struct strip_in *s, size_t band, size_t i, size_t *jlo, size_t *jhi)
{
	double jc = (double)i * (double)s->nb / (double)s->na;

	*jlo = jc > (double)band ? (size_t)(jc - (double)band) : 0;
	*jhi = (size_t)fmin((double)s->nb, jc + (double)band);
}

/* Cells a row of the band stores (band >= max(na, nb): the full grid). */
static size_t band_width(const struct strip_in *s, size_t band)
{
	return 2 * band + 2 < s->nb + 1 ? 2 * band + 2 : s->nb + 1;
}

/* Index of cell (i, j) in the band's storage, SIZE_MAX outside it. */
static size_t band_cell(const struct strip_in *s, size_t band, size_t i, size_t j)
{
	size_t jlo, jhi;

	band_row(s, band, i, &jlo, &jhi);
	return j >= jlo && j <= jhi ? i * band_width(s, band) + (j - jlo) : SIZE_MAX;
}

/* DP within |j - i * nb / na| <= band (band >= max(na, nb): full grid).
 * cost/from: (na + 1) x band_width cells, row i holding its window.
 * Returns the final cost. */
static double run_dp(const struct strip_in *s, size_t band, double *cost, unsigned char *from)
{
	size_t na = s->na, nb = s->nb, W = band_width(s, band);

	for (size_t k = 0; k < (na + 1) * W; k++)
		cost[k] = INFINITY;
	cost[0] = 0;
	for (size_t i = 0; i <= na; i++) {
		size_t jlo, jhi, nlo = 0, nhi = 0;
		band_row(s, band, i, &jlo, &jhi);
		if (i < na)
			band_row(s, band, i + 1, &nlo, &nhi);
		for (size_t j = jlo; j <= jhi; j++) {
			size_t at = i * W + (j - jlo);
			size_t to = i < na && j >= nlo && j <= nhi ? (i + 1) * W + (j - nlo) : SIZE_MAX;
			double c = cost[at];
			struct vec3 ai = pa_at(s, i), bj = pb_at(s, j);
			if (!isfinite(c))
				continue;
			/* a cross edge this long is never part of a good strip */
			if ((ai.x - bj.x) * (ai.x - bj.x) + (ai.y - bj.y) * (ai.y - bj.y) > s->reach2)
				continue;
			/* the (expensive) clearance test only for a triangle that
			 * would improve its target cell */
			if (to != SIZE_MAX) {
				/* triangle (a_i, b_j, a_{i+1}) */
				struct vec3 A = pa_at(s, i), B = pb_at(s, j), C = pa_at(s, i + 1);
				double t = c + tri_area_cost(s, A, B, C, C, B);
				if (t < cost[to] && !tri_blocked(s, A, B, C)) {
					cost[to] = t;
					from[to] = 0;
				}
			}
			if (j < jhi) { /* triangle (b_j, b_{j+1}, a_i) */
				struct vec3 A = pb_at(s, j), B = pb_at(s, j + 1), C = pa_at(s, i);
				double t = c + tri_area_cost(s, A, B, C, C, B);
				if (t < cost[at + 1] && !tri_blocked(s, A, B, C)) {
					cost[at + 1] = t;
					from[at + 1] = 1;
				}
			}
		}
	}
	return cost[band_cell(s, band, na, nb)];
}

int hl_strip(const double *pa, double za, size_t na, uint32_t ida, const double *pb, double zb,
	     size_t nb, uint32_t idb, const struct hl_block *block, uint32_t **tri, size_t *nt,
	     size_t *tcap, struct hl_xedge **xe, size_t *nxe, size_t *xcap, struct err *e)
{
	struct strip_in s = {pa, pb, za, zb, na, nb, 0, 0, block, 0, 0};
	size_t steps = na + nb, i, j, k, bands[3], nbands = 0;
	double *cost = NULL, best = INFINITY;
	unsigned char *from = NULL;
	size_t *pi = NULL, *pj = NULL;
	void *arr;
	int rc = 0;

	if (na < 3 || nb < 3)
		return ERR_SET(e, ERR_INTERNAL, "strip between loops of %zu and %zu vertices", na, nb);
	for (j = 0; j < nb; j++) {
		double d = hypot(pb[2 * j] - pa[0], pb[2 * j + 1] - pa[1]);
		if (d < best) {
			best = d;
			s.jb0 = j;
		}
	}
	{
		/* longest cross edge considered: a quarter of loop a's bounding
		 * box (its larger side), at least 3 mm; rule 2 of the grouping
		 * keeps the two loops within a factor two in area, so either
		 * loop gives about the same reach */
		double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, r;
		for (i = 0; i < na; i++)
			for (int a = 0; a < 2; a++) {
				lo[a] = fmin(lo[a], pa[2 * i + a]);
				hi[a] = fmax(hi[a], pa[2 * i + a]);
			}
		r = fmax(3.0, 0.25 * fmax(hi[0] - lo[0], hi[1] - lo[1]));
		s.reach2 = r * r;
	}
	{
		/* the bands tried, narrow to wide: HL_DP_WIDE_HW then the full
		 * grid; past HL_DP_FULL_CELLS HL_DP_NARROW_HW first and none
		 * over HL_DP_MAX_CELLS */
		size_t nmax = na > nb ? na : nb, full = na + nb;
		if ((na + 1) * (nb + 1) <= HL_DP_FULL_CELLS) {
			bands[nbands++] = HL_DP_WIDE_HW(nmax);
			if (HL_DP_WIDE_HW(nmax) < nmax)
				bands[nbands++] = full;
		} else {
			size_t cand[3] = {HL_DP_NARROW_HW(nmax), HL_DP_WIDE_HW(nmax), full};
			for (int b = 0; b < 3; b++)
				if ((na + 1) * band_width(&s, cand[b]) <= HL_DP_MAX_CELLS &&
				    (!nbands || band_width(&s, cand[b]) > band_width(&s, bands[nbands - 1])))
					bands[nbands++] = cand[b];
			if (!nbands) {
				rc = 1; /* no strip within the cap */
				goto out;
			}
		}
	}
	cost = mem_alloc((na + 1) * band_width(&s, bands[nbands - 1]) * sizeof *cost);
	from = mem_alloc((na + 1) * band_width(&s, bands[nbands - 1]));
	pi = mem_alloc((steps + 1) * sizeof *pi);
	pj = mem_alloc((steps + 1) * sizeof *pj);
	if (!cost || !from || !pi || !pj)
		goto nomem;
	/* Pass 1 without the clearance test (almost always admissible); the
	 * triangles of its path are then tested, and only if one is blocked
	 * does pass 2 run the DP with the test inside (clearance tests cost
	 * BVH queries; pass 2 needs them on every improving candidate). */
	for (s.use_block = 0; s.use_block <= 1; s.use_block++) {
		size_t band = 0;
		int ok = 1;
		for (size_t b = 0; b < nbands && !band; b++)
			if (isfinite(run_dp(&s, bands[b], cost, from)))
				band = bands[b];
		if (!band) {
			if (s.use_block) {
				rc = 1; /* no admissible strip */
				goto out;
			}
			continue;
		}
		/* walk back: grid points of the path, last to first */
		i = na;
		j = nb;
		for (k = steps + 1; k-- > 0;) {
			pi[k] = i;
			pj[k] = j;
			if (k == 0)
				break;
			if (from[band_cell(&s, band, i, j)] == 0)
				i--;
			else
				j--;
		}
		if (s.use_block || !block || !block->blocked)
			break;
		for (k = 0; k < steps && ok; k++) {
			if (pi[k + 1] > pi[k])
				ok = !block->blocked(block->ctx, pa_at(&s, pi[k]), pb_at(&s, pj[k]),
						     pa_at(&s, pi[k] + 1));
			else
				ok = !block->blocked(block->ctx, pb_at(&s, pj[k]), pb_at(&s, pj[k] + 1),
						     pa_at(&s, pi[k]));
		}
		if (ok)
			break;
	}
	/* faces: step k goes from grid point k to k + 1 */
	arr = *tri;
	if (mem_grow(&arr, tcap, 3 * (*nt + steps), sizeof **tri))
		goto nomem;
	*tri = arr;
	arr = *xe;
	if (mem_grow(&arr, xcap, *nxe + steps, sizeof **xe))
		goto nomem;
	*xe = arr;
	{
		size_t f0 = *nt;
		for (k = 0; k < steps; k++) {
			uint32_t ai = ida + (uint32_t)((s.ia0 + pi[k]) % na);
			uint32_t bj = idb + (uint32_t)((s.jb0 + pj[k]) % nb);
			uint32_t *t = *tri + 3 * (*nt);
			if (pi[k + 1] > pi[k]) {
				t[0] = ai;
				t[1] = bj;
				t[2] = ida + (uint32_t)((s.ia0 + pi[k] + 1) % na);
			} else {
				t[0] = bj;
				t[1] = idb + (uint32_t)((s.jb0 + pj[k] + 1) % nb);
				t[2] = ai;
			}
			(*nt)++;
		}
		/* cross edge at grid point k (1..steps-1) joins faces k-1 and k;
		 * grid points 0 and steps are the same edge a_0 b_0 */
		for (k = 0; k < steps; k++) {
			struct hl_xedge *x = *xe + (*nxe)++;
			x->lo = ida + (uint32_t)((s.ia0 + pi[k]) % na);
			x->hi = idb + (uint32_t)((s.jb0 + pj[k]) % nb);
			x->f[0] = (uint32_t)(f0 + (k == 0 ? steps - 1 : k - 1));
			x->f[1] = (uint32_t)(f0 + k);
		}
	}
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "strip triangulation %zu x %zu: out of memory", na, nb);
out:
	mem_free(cost);
	mem_free(from);
	mem_free(pi);
	mem_free(pj);
	return rc;
}
