/* restrip.c - a void's strips rebuilt top-down, with its support-free start.
 *
 * The strips of void.c join loops at their initial positions (offset 0).
 * The start (start.c) then collapses the top loop onto its poles and
 * walks down; where the collapse scatters neighbouring top vertices along
 * a medial-axis branch (a rectangle's corner: vertices d apart on the
 * sides land sqrt 2 d apart on the diagonal), a lower vertex's cross edges
 * fan out to upper vertices no single offset along its fixed direction
 * reaches, and the void fails its own check (docs/hollow.md, known issue 1).
 * The connectivity is ours to choose (the paper fixes it once, section
 * 8.1), so here strips and offsets are chosen together, top-down, with the
 * top loop on its poles and loop k+1 already placed (positions Q):
 *
 * - a vertex of loop k inside Q's polygon at offset 0 is a floor vertex
 *   (the surface there faces up, eq. 5 does not apply): offset 0, any
 *   cross edge;
 * - any other vertex i may join upper vertex j only at offsets in
 *   I_ij = {t in [0, ub_i] : |v_i + t r_i - q_j| <= reach}, reach = 0.95 h
 *   tan alpha, h the pair's rise (an interval: a ray meets a disc once);
 * - a strip is a monotone path on the toroidal grid (strip.c); vertex i's
 *   cross edges are the cells of its run (i, j0..j1), so it needs the
 *   intersection of I_ij over its run non-empty.  The dynamic programme
 *   carries that intersection along each cell's best path (an i-step
 *   starts the new vertex's interval afresh) and refuses a cell where it
 *   empties; a triangle costs its area (strip.c's cost, the lower vertex
 *   at the low end of its interval so far).  The choice at a cell is the
 *   cheapest feasible path, not every feasible interval, so the DP can miss
 *   a strip that exists; it never returns an infeasible one;
 * - each vertex takes the low end of its run's interval (the largest void).
 * Every cross edge from a non-floor vertex is then within h tan alpha, so
 * (start.c's argument) every face facing down is too: the start is
 * support-free by construction.  Clearance to the surface is tested on the
 * path's triangles at offset 0, as void.c does.  A pair with no such strip
 * (a slab leaning past alpha: no offset reaches the loop above) ends the
 * void there.  O(n m) per pair of loops of n and m vertices up to
 * HL_DP_FULL_CELLS cells; larger pairs (a 156 mm gear's loops: 4,734 x
 * 4,734) search the bands of dpband.h (HL_DP_*: 25 bytes a cell here),
 * O(n (n / 32)) time and memory, where the full grid took 22 M cells
 * (560 MB) and about 4 s a pair.  A band can miss a strip the full grid holds, never return one
 * that fails the check below; a pair no band within the cap joins ends
 * the void there.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/dpband.h"
#include "engine/hollow/opt/opt_int.h"

/* Offsets t with |w + t r| <= D (r unit): [t0, t1]; 0 if none. */
static int ray_disc(double wx, double wy, double rx, double ry, double D, double *t0, double *t1)
{
	double b = rx * wx + ry * wy, c = wx * wx + wy * wy - D * D, disc = b * b - c;

	if (disc < 0)
		return 0;
	*t0 = -b - sqrt(disc);
	*t1 = -b + sqrt(disc);
	return 1;
}

/* One strip's problem: lower loop (ids a0.., na), upper positions Q. */
struct rs {
	const struct hl_void *v;
	size_t a0, na, b0, nb, ia0, jb0;
	const double *Q;
	const unsigned char *flr;
	double reach;
	double floor2; /* squared longest cross edge from a floor vertex (mm^2) */
	/* DP grid: row i (0..na) holds cells j = ws(i) .. ws(i) + bw - 1
	 * of 0..nb (bw = nb + 1: the full grid) */
	double *cost, *lo, *hi;
	unsigned char *from;
	size_t bw;
};

/* First cell (column) of row i's band. */
static size_t band_start(const struct rs *s, size_t i)
{
	size_t half = s->bw / 2;
	double c = (double)i * (double)s->nb / (double)s->na;
	size_t ws = c > (double)half ? (size_t)(c - (double)half) : 0;

	return ws + s->bw > s->nb + 1 ? s->nb + 1 - s->bw : ws;
}

/* Index of cell (i, j) in the band storage, or SIZE_MAX outside it. */
static size_t cell_at(const struct rs *s, size_t i, size_t j)
{
	size_t ws = band_start(s, i);

	return j >= ws && j < ws + s->bw ? i * s->bw + (j - ws) : SIZE_MAX;
}

/* I_ij for grid cell (i, j) (indices relative to the start pair). */
static int cell_iv(const struct rs *s, size_t i, size_t j, double *t0, double *t1)
{
	size_t a = s->a0 + (s->ia0 + i) % s->na, b = (s->jb0 + j) % s->nb;
	const struct hl_void *v = s->v;

	if (s->flr[a]) {
		double dx = v->p[2 * a] - s->Q[2 * b], dy = v->p[2 * a + 1] - s->Q[2 * b + 1];
		*t0 = *t1 = 0;
		return dx * dx + dy * dy <= s->floor2;
	}
	if (!ray_disc(v->p[2 * a] - s->Q[2 * b], v->p[2 * a + 1] - s->Q[2 * b + 1], v->dir[2 * a],
		      v->dir[2 * a + 1], s->reach, t0, t1))
		return 0;
	*t0 = fmax(*t0, 0);
	*t1 = fmin(*t1, v->ub[a]);
	return *t0 <= *t1;
}

static struct vec3 lower_at(const struct rs *s, size_t i, double t)
{
	size_t a = s->a0 + (s->ia0 + i) % s->na;
	const struct hl_void *v = s->v;

	return v3(v->p[2 * a] + t * v->dir[2 * a], v->p[2 * a + 1] + t * v->dir[2 * a + 1],
		  v->vz[a]);
}

static struct vec3 upper_at(const struct rs *s, size_t j)
{
	size_t b = (s->jb0 + j) % s->nb;

	return v3(s->Q[2 * b], s->Q[2 * b + 1], s->v->vz[s->b0 + b]);
}

static double tri_area(struct vec3 a, struct vec3 b, struct vec3 c)
{
	return 0.5 * v3_len(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

/* The DP from cell (0, 0) to (na, nb) (the same edge) over the band of
 * width s->bw; 1 if a path exists. */
static int run_dp(struct rs *s)
{
	size_t na = s->na, nb = s->nb, bw = s->bw;
	double t0, t1;

	for (size_t k = 0; k < (na + 1) * bw; k++)
		s->cost[k] = INFINITY;
	if (!cell_iv(s, 0, 0, &t0, &t1))
		return 0;
	s->cost[0] = 0;
	s->lo[0] = t0;
	s->hi[0] = t1;
	for (size_t i = 0; i <= na; i++) {
		size_t ws = band_start(s, i);
		for (size_t j = ws; j < ws + bw; j++) {
			size_t c = i * bw + (j - ws), cd;
			double c0 = s->cost[c];
			if (!isfinite(c0))
				continue;
			/* i-step: triangle (a_i, b_j, a_{i+1}); a_{i+1} starts afresh */
			if (i < na && (cd = cell_at(s, i + 1, j)) != SIZE_MAX &&
			    cell_iv(s, i + 1, j, &t0, &t1)) {
				double t = c0 + tri_area(lower_at(s, i, s->lo[c]), upper_at(s, j),
							 lower_at(s, i + 1, t0));
				if (i + 1 == na && j == nb) { /* closing cell: a_0's interval */
					t0 = fmax(t0, s->lo[0]);
					t1 = fmin(t1, s->hi[0]);
				}
				if (t0 <= t1 && t < s->cost[cd]) {
					s->cost[cd] = t;
					s->lo[cd] = t0;
					s->hi[cd] = t1;
					s->from[cd] = 0;
				}
			}
			/* j-step: triangle (b_j, b_{j+1}, a_i); a_i's interval narrows */
			if (j < nb && j + 1 < ws + bw && cell_iv(s, i, j + 1, &t0, &t1)) {
				double l0 = fmax(t0, s->lo[c]), l1 = fmin(t1, s->hi[c]);
				double t = c0 + tri_area(upper_at(s, j), upper_at(s, j + 1),
							 lower_at(s, i, l0));
				if (i == na && j + 1 == nb) {
					l0 = fmax(l0, s->lo[0]);
					l1 = fmin(l1, s->hi[0]);
				}
				if (l0 <= l1 && t < s->cost[c + 1]) {
					s->cost[c + 1] = t;
					s->lo[c + 1] = l0;
					s->hi[c + 1] = l1;
					s->from[c + 1] = 1;
				}
			}
		}
	}
	return isfinite(s->cost[cell_at(s, na, nb)]);
}

/* Strip between loop k (lower) and k+1 (placed at Q): offsets of loop k
 * into l, faces and cross edges appended.  0, 1 (none), or ERR_NOMEM. */
static int restrip_pair(struct hl_void *v, size_t k, const double *Q, double reach_mm,
			const struct hl_block *block, double *l, unsigned char *flr,
			uint32_t **tri, size_t *nt, size_t *tcap, struct hl_xedge **xe,
			size_t *nxe, size_t *xcap)
{
	struct rs s = {v, v->off[k], v->off[k + 1] - v->off[k], v->off[k + 1],
		       v->off[k + 2] - v->off[k + 1], 0, 0, Q, flr, reach_mm, 0,
		       NULL, NULL, NULL, NULL, 0};
	size_t na = s.na, nb = s.nb, steps = na + nb, cells = (na + 1) * (nb + 1);
	size_t nmax = na > nb ? na : nb, bands[3], nbands = 0;
	size_t *pi = NULL, *pj = NULL, cand[3] = {0, 0, 0};
	double *lo = NULL, *hi = NULL;
	double best[3] = {INFINITY, INFINITY, INFINITY};
	int rc = 1, found = 0;
	void *arr;

	{
		/* floor cross edges: strip.c's bound, a quarter of the lower
		 * loop's size, at least 3 mm */
		double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY, r;
		for (size_t i = s.a0; i < s.a0 + na; i++) {
			x0 = fmin(x0, v->p[2 * i]);
			x1 = fmax(x1, v->p[2 * i]);
			y0 = fmin(y0, v->p[2 * i + 1]);
			y1 = fmax(y1, v->p[2 * i + 1]);
			flr[i] = (unsigned char)hl_loop_inside(Q, nb, v->p[2 * i], v->p[2 * i + 1]);
		}
		r = fmax(3.0, 0.25 * fmax(x1 - x0, y1 - y0));
		s.floor2 = r * r;
	}
	/* start pairs: a_0 with the three upper vertices it reaches at the
	 * smallest offsets (a_0 must be on every strip) */
	for (size_t j = 0; j < nb; j++) {
		double t0, t1;
		s.jb0 = j;
		if (!cell_iv(&s, 0, 0, &t0, &t1))
			continue;
		if (flr[s.a0])
			t0 = hypot(v->p[2 * s.a0] - Q[2 * j], v->p[2 * s.a0 + 1] - Q[2 * j + 1]);
		for (int c = 0; c < 3; c++)
			if (t0 < best[c]) {
				for (int d = 2; d > c; d--) {
					best[d] = best[d - 1];
					cand[d] = cand[d - 1];
				}
				best[c] = t0;
				cand[c] = j;
				break;
			}
	}
	/* the full grid, or the bands HL_DP_NARROW_HW and HL_DP_WIDE_HW,
	 * each within the cap */
	if (cells <= HL_DP_FULL_CELLS) {
		bands[nbands++] = nb + 1;
	} else {
		size_t hw[2] = {HL_DP_NARROW_HW(nmax), HL_DP_WIDE_HW(nmax)};
		for (int b = 0; b < 2; b++) {
			size_t bw = 2 * hw[b] + 1 < nb + 1 ? 2 * hw[b] + 1 : nb + 1;
			if ((na + 1) * bw <= HL_DP_MAX_CELLS && (!nbands || bw > bands[nbands - 1]))
				bands[nbands++] = bw;
		}
		if (!nbands)
			goto out; /* no strip within the cap: the void ends here */
	}
	cells = (na + 1) * bands[nbands - 1];
	s.cost = mem_alloc(cells * sizeof *s.cost);
	s.lo = mem_alloc(cells * sizeof *s.lo);
	s.hi = mem_alloc(cells * sizeof *s.hi);
	s.from = mem_alloc(cells);
	pi = mem_alloc((steps + 1) * sizeof *pi);
	pj = mem_alloc((steps + 1) * sizeof *pj);
	lo = mem_alloc(na * sizeof *lo);
	hi = mem_alloc(na * sizeof *hi);
	if (!s.cost || !s.lo || !s.hi || !s.from || !pi || !pj || !lo || !hi) {
		rc = ERR_NOMEM;
		goto out;
	}
	for (size_t t = 0; t < 3 * nbands && !found; t++) {
		int c = (int)(t % 3);
		size_t i = na, j = nb;
		if (!isfinite(best[c]))
			continue;
		s.bw = bands[t / 3];
		s.jb0 = cand[c];
		if (!run_dp(&s))
			continue;
		/* walk back: grid points of the path, last to first */
		for (size_t q = steps + 1; q-- > 0;) {
			size_t cc = cell_at(&s, i, j);
			pi[q] = i;
			pj[q] = j;
			if (q == 0)
				break;
			if (s.from[cc] == 0)
				i--;
			else
				j--;
		}
		/* each vertex's offset: the low end of the intersection of I_ij
		 * over its cells (a_0's run wraps: cells (0, ..) and (na, ..));
		 * recomputed here, so the DP's bookkeeping is checked, not trusted */
		found = 1;
		for (size_t a = 0; a < na; a++) {
			lo[a] = 0;
			hi[a] = INFINITY;
		}
		for (size_t q = 0; q <= steps && found; q++) {
			double t0, t1;
			size_t a = pi[q] % na;
			found = cell_iv(&s, pi[q], pj[q], &t0, &t1);
			lo[a] = fmax(lo[a], t0);
			hi[a] = fmin(hi[a], t1);
		}
		for (size_t a = 0; a < na && found; a++) {
			found = lo[a] <= hi[a];
			l[s.a0 + a] = lo[a];
		}
		for (size_t q = 0; q < steps && found && block && block->blocked; q++) {
			size_t a = s.a0 + (pi[q] % na), a1 = s.a0 + ((pi[q] + 1) % na);
			size_t b = s.b0 + (s.jb0 + pj[q]) % nb, b1 = s.b0 + (s.jb0 + pj[q] + 1) % nb;
			if (pi[q + 1] > pi[q])
				found = !block->blocked(block->ctx, hl_void_pos(v, a, 0),
							hl_void_pos(v, b, 0), hl_void_pos(v, a1, 0));
			else
				found = !block->blocked(block->ctx, hl_void_pos(v, b, 0),
							hl_void_pos(v, b1, 0), hl_void_pos(v, a, 0));
		}
	}
	if (!found)
		goto out;
	arr = *tri;
	if (mem_grow(&arr, tcap, 3 * (*nt + steps), sizeof **tri)) {
		rc = ERR_NOMEM;
		goto out;
	}
	*tri = arr;
	arr = *xe;
	if (mem_grow(&arr, xcap, *nxe + steps, sizeof **xe)) {
		rc = ERR_NOMEM;
		goto out;
	}
	*xe = arr;
	{
		size_t f0 = *nt;
		for (size_t q = 0; q < steps; q++) {
			uint32_t a = (uint32_t)(s.a0 + pi[q] % na);
			uint32_t b = (uint32_t)(s.b0 + (s.jb0 + pj[q]) % nb);
			uint32_t *t = *tri + 3 * (*nt)++;
			struct hl_xedge *x = *xe + (*nxe)++;
			if (pi[q + 1] > pi[q]) { /* (a_i, b_j, a_{i+1}): normal into the void */
				t[0] = a;
				t[1] = b;
				t[2] = (uint32_t)(s.a0 + (pi[q] + 1) % na);
			} else {
				t[0] = b;
				t[1] = (uint32_t)(s.b0 + (s.jb0 + pj[q] + 1) % nb);
				t[2] = a;
			}
			/* cross edge at grid point q joins faces q-1 and q */
			x->lo = a;
			x->hi = b;
			x->f[0] = (uint32_t)(f0 + (q == 0 ? steps - 1 : q - 1));
			x->f[1] = (uint32_t)(f0 + q);
		}
	}
	rc = 0;
out:
	mem_free(s.cost);
	mem_free(s.lo);
	mem_free(s.hi);
	mem_free(s.from);
	mem_free(pi);
	mem_free(pj);
	mem_free(lo);
	mem_free(hi);
	return rc;
}

/* Keep loops [first, nloops) of v: shift the per-vertex and per-loop
 * arrays and renumber the (already rebuilt) faces and cross edges. */
static void keep_from(struct hl_void *v, size_t first, double *l)
{
	size_t o = v->off[first], nl = v->nloops - first, nv = v->nv - o;

	memmove(v->slice, v->slice + first, nl * sizeof *v->slice);
	memmove(v->z, v->z + first, nl * sizeof *v->z);
	for (size_t k = 0; k <= nl; k++)
		v->off[k] = v->off[k + first] - o;
	memmove(v->p, v->p + 2 * o, 2 * nv * sizeof *v->p);
	memmove(v->dir, v->dir + 2 * o, 2 * nv * sizeof *v->dir);
	memmove(v->vz, v->vz + o, nv * sizeof *v->vz);
	memmove(v->ub, v->ub + o, nv * sizeof *v->ub);
	memmove(l, l + o, nv * sizeof *l);
	for (size_t t = 0; t < 3 * v->nt; t++)
		v->tri[t] -= (uint32_t)o;
	for (size_t x = 0; x < v->nxe; x++) {
		v->xe[x].lo -= (uint32_t)o;
		v->xe[x].hi -= (uint32_t)o;
	}
	v->nloops = nl;
	v->nv = nv;
}

int hl_void_restrip(struct hl_void *v, double reach_slope, const struct hl_block *block,
		    size_t *first, struct err *e)
{
	size_t nv = v->nv, top = v->nloops - 1, k, tcap = 0, xcap = 0, nt = 0, nxe = 0;
	double *l = mem_alloc((nv + 1) * sizeof *l), *pos = mem_alloc((2 * nv + 1) * sizeof *pos);
	unsigned char *flr = mem_alloc(nv + 1);
	uint32_t *tri = NULL;
	struct hl_xedge *xe = NULL;
	int rc = 0;

	*first = 0;
	if (!l || !pos || !flr) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory rebuilding a void's strips");
		goto out;
	}
	for (size_t j = v->off[top]; j < nv; j++)
		l[j] = v->ub[j];
	for (k = top + 1; k-- > 0;) {
		for (size_t j = v->off[k]; j < v->off[k + 1]; j++) {
			pos[2 * j] = v->p[2 * j] + l[j] * v->dir[2 * j];
			pos[2 * j + 1] = v->p[2 * j + 1] + l[j] * v->dir[2 * j + 1];
		}
		if (k == 0)
			break;
		/* reach over this pair's rise (slices may differ in thickness) */
		rc = restrip_pair(v, k - 1, pos + 2 * v->off[k],
				  reach_slope * (v->z[k] - v->z[k - 1]), block, l, flr, &tri,
				  &nt, &tcap, &xe, &nxe, &xcap);
		if (rc == ERR_NOMEM) {
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory rebuilding a void's strips");
			goto out;
		}
		if (rc == 1) {
			rc = 0;
			*first = k;
			break;
		}
	}
	mem_free(v->tri);
	mem_free(v->xe);
	v->tri = tri;
	v->nt = nt;
	v->xe = xe;
	v->nxe = nxe;
	tri = NULL;
	xe = NULL;
	if (*first > 0)
		keep_from(v, *first, l);
	mem_free(v->start);
	v->start = l;
	l = NULL;
	rc = v->nloops >= 2 ? 0 : 1;
out:
	mem_free(l);
	mem_free(pos);
	mem_free(flr);
	mem_free(tri);
	mem_free(xe);
	return rc;
}
