/* tcs.c - the tetrahedral crystal structure (paper 003 section 5.2): a
 * diamond cubic ball-and-stick lattice as capsules (hybrid.h).
 *
 * The conventional cubic cell of edge a holds 8 atoms: the fcc sites
 * (0,0,0), (0,1/2,1/2), (1/2,0,1/2), (1/2,1/2,0) (sublattice A) and the
 * same shifted by (1/4,1/4,1/4) (sublattice B).  Every A atom bonds to the
 * 4 B atoms at A + (a/4)(1,1,1), (1,-1,-1), (-1,1,-1), (-1,-1,1); every B
 * atom is reached from 4 A atoms that way, so each bond is generated once,
 * from its A end.  Bond length sqrt(3)/4 a; with the cube axes along x, y,
 * z every bond direction is (+-1,+-1,+-1)/sqrt 3, acos(1/sqrt 3) =
 * 54.7356 deg from the vertical.  The paper clips the lattice by a 3D
 * boolean; here the caller clips the capsules' union by its own mask.
 */
#include "engine/hybrid/structure.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>

static const double fcc[4][3] = {{0, 0, 0}, {0, 0.5, 0.5}, {0.5, 0, 0.5}, {0.5, 0.5, 0}};
static const double bond_dir[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};

/* Atoms kept: within one bond length of the box on every axis. */
struct tcs_box {
	struct vec3 lo, hi; /* the box grown by the bond length */
};

static int in_grown(const struct tcs_box *b, struct vec3 p)
{
	return p.x >= b->lo.x && p.x <= b->hi.x && p.y >= b->lo.y && p.y <= b->hi.y &&
	       p.z >= b->lo.z && p.z <= b->hi.z;
}

/* The A atom pa, its B partner pa + (a/4)(1,1,1) and pa's 4 bonds: stored
 * from out[n] on when out != NULL; returns the new count. */
static size_t tcs_site(const struct tcs_box *b, struct vec3 pa, double a, double ball_mm,
		       double stick_r, int balls, struct capsule *out, size_t n)
{
	double q4 = 0.25 * a;
	struct vec3 pb = v3_add(pa, v3(q4, q4, q4));

	if (balls && in_grown(b, pa)) {
		if (out)
			out[n] = (struct capsule){pa, pa, ball_mm};
		n++;
	}
	if (balls && in_grown(b, pb)) {
		if (out)
			out[n] = (struct capsule){pb, pb, ball_mm};
		n++;
	}
	if (!in_grown(b, pa))
		return n;
	for (int d = 0; d < 4; d++) {
		struct vec3 q = v3(pa.x + q4 * bond_dir[d][0], pa.y + q4 * bond_dir[d][1],
				   pa.z + q4 * bond_dir[d][2]);
		if (!in_grown(b, q))
			continue;
		if (out) {
			/* lower end first: z-sorted users like it */
			struct vec3 lo = pa.z <= q.z ? pa : q, hi = pa.z <= q.z ? q : pa;
			out[n] = (struct capsule){lo, hi, stick_r};
		}
		n++;
	}
	return n;
}

/* Walk the atoms and bonds; with out != NULL store them (balls when
 * balls != 0).  Returns the count. */
static size_t tcs_walk(const struct tcs_box *b, const long c0[3], const long c1[3], double a,
		       struct vec3 shift, double ball_mm, double stick_r, int balls,
		       struct capsule *out)
{
	size_t n = 0;

	for (long k = c0[2]; k <= c1[2]; k++)
		for (long j = c0[1]; j <= c1[1]; j++)
			for (long i = c0[0]; i <= c1[0]; i++)
				for (int f = 0; f < 4; f++)
					n = tcs_site(b, v3(shift.x + a * ((double)i + fcc[f][0]),
							   shift.y + a * ((double)j + fcc[f][1]),
							   shift.z + a * ((double)k + fcc[f][2])),
						     a, ball_mm, stick_r, balls, out, n);
	return n;
}

int hy_tcs_build(struct vec3 lo, struct vec3 hi, double cell_mm, double ball_mm,
		 double stick_mm, struct vec3 shift_mm, size_t max_caps, struct capsule **caps,
		 size_t *n_out, double *steepest_deg, struct err *e)
{
	double a = cell_mm, bond = sqrt(3.0) / 4 * cell_mm, stick_r = 0.5 * stick_mm, cells = 1;
	struct tcs_box b;
	long c0[3], c1[3];
	int balls;
	size_t n;
	struct capsule *out;

	if (!(cell_mm > 0) || !isfinite(cell_mm))
		return ERR_FIELD(e, "cell_mm", "TCS cell must be > 0 mm (got %g)", cell_mm);
	if (!(stick_mm > 0) || !(stick_r < bond))
		return ERR_FIELD(e, "stick_mm",
				 "TCS stick diameter must be in (0, %g) mm for a %g mm cell "
				 "(got %g)",
				 2 * bond, cell_mm, stick_mm);
	if (!(ball_mm >= 0) || !(ball_mm < 0.5 * cell_mm))
		return ERR_FIELD(e, "ball_mm",
				 "TCS ball radius must be in [0, %g) mm for a %g mm cell (got %g)",
				 0.5 * cell_mm, cell_mm, ball_mm);
	if (!isfinite(lo.x) || !isfinite(lo.y) || !isfinite(lo.z) || !isfinite(hi.x) ||
	    !isfinite(hi.y) || !isfinite(hi.z) || !(hi.x >= lo.x) || !(hi.y >= lo.y) ||
	    !(hi.z >= lo.z) || !isfinite(shift_mm.x) || !isfinite(shift_mm.y) ||
	    !isfinite(shift_mm.z))
		return ERR_SET(e, ERR_PARAM, "TCS box or shift is empty or not finite");
	b.lo = v3(lo.x - bond, lo.y - bond, lo.z - bond);
	b.hi = v3(hi.x + bond, hi.y + bond, hi.z + bond);
	for (int ax = 0; ax < 3; ax++) {
		double l = v3_comp(b.lo, ax) - v3_comp(shift_mm, ax);
		double h = v3_comp(b.hi, ax) - v3_comp(shift_mm, ax);
		double f0 = floor(l / a) - 1, f1 = ceil(h / a) + 1;
		cells *= f1 - f0 + 1;
		/* 24 capsules per cell at most; the range's padding cells and a
		 * thin box can make the exact count a few times smaller */
		if (!(cells * 24 <= 8.0 * (double)max_caps + 1e6))
			return ERR_SET(e, ERR_LIMIT,
				       "the TCS of a %g mm cell over this box needs more than %zu "
				       "capsules",
				       cell_mm, max_caps);
		c0[ax] = (long)f0;
		c1[ax] = (long)f1;
	}
	/* a ball no larger than the sticks' radius lies inside the sticks' own
	 * end balls: skip it */
	balls = ball_mm > stick_r;
	n = tcs_walk(&b, c0, c1, a, shift_mm, ball_mm, stick_r, balls, NULL);
	if (n > max_caps)
		return ERR_SET(e, ERR_LIMIT,
			       "the TCS of a %g mm cell over this box needs %zu capsules (at most "
			       "%zu)",
			       cell_mm, n, max_caps);
	out = mem_alloc((n ? n : 1) * sizeof *out);
	if (!out)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu TCS capsules", n);
	tcs_walk(&b, c0, c1, a, shift_mm, ball_mm, stick_r, balls, out);
	*caps = out;
	*n_out = n;
	/* every bond direction has |dz| / |d| = 1 / sqrt 3 */
	*steepest_deg = acos(1 / sqrt(3.0)) * (180 / M_PI);
	return 0;
}
