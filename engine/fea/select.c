/* select.c - from a load case to the solver's node mask and load vector:
 * which nodes each fixed / force statement selects (fea.h), the checks of
 * fea_solver_new (empty selections, forces on fixed directions, parts
 * not held against rigid motion), and holding force-free parts that no
 * constraint reaches.  Method: docs/fea.md, "Loads and constraints".
 */
#include "engine/fea/fea_int.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

/* An index range [lo, hi] of node coordinates along one axis. */
struct range {
	int lo, hi;
};

/* Nodes i in [0, n] with x0 <= lo + i h <= x1 (tolerance 1e-6 h). */
static struct range node_range(double lo, double h, int n, double x0, double x1)
{
	struct range r;
	double a = ceil((x0 - lo) / h - 1e-6), b = floor((x1 - lo) / h + 1e-6);

	r.lo = a < 0 ? 0 : a > n ? n + 1 : (int)a;
	r.hi = b > n ? n : b < 0 ? -1 : (int)b;
	return r;
}

/* The node box a place selects (before the "touches an element" test). */
static void place_ranges(const struct fea_grid *g, enum fea_at at, const double box[6],
			 struct range r[3])
{
	const double lo[3] = {g->lo_mm.x, g->lo_mm.y, g->lo_mm.z};
	const double plo[3] = {g->part_lo_mm.x, g->part_lo_mm.y, g->part_lo_mm.z};
	const int n[3] = {g->nx, g->ny, g->nz};
	double h = g->h_mm;

	for (int a = 0; a < 3; a++)
		r[a] = node_range(lo[a], h, n[a], -INFINITY, INFINITY);
	if (at == FEA_AT_BOX) {
		for (int a = 0; a < 3; a++)
			r[a] = node_range(lo[a], h, n[a], plo[a] + box[a], plo[a] + box[3 + a]);
	} else if (at == FEA_AT_PLATE) {
		r[2] = node_range(lo[2], h, n[2], g->part_lo_mm.z - h / 2, g->part_lo_mm.z + h / 2);
	} else {
		r[2] = node_range(lo[2], h, n[2], g->part_hi_mm.z - 1, INFINITY);
	}
}

static void place_name(char *b, size_t len, const char *kind, size_t idx, enum fea_at at,
		       const double box[6])
{
	if (at == FEA_AT_BOX)
		snprintf(b, len, "%s box %zu [%g,%g,%g,%g,%g,%g]", kind, idx, box[0], box[1], box[2],
			 box[3], box[4], box[5]);
	else
		snprintf(b, len, "%s %s %zu", kind, at == FEA_AT_PLATE ? "plate" : "top", idx);
}

static size_t user_node(const struct fea_solver *s, int i, int j, int k)
{
	return ((size_t)k * (size_t)(s->uy + 1) + (size_t)j) * (size_t)(s->ux + 1) + (size_t)i;
}

/* Union-find with path halving over padded nodes. */
static int32_t uf_find(int32_t *par, int32_t x)
{
	while (par[x] != x) {
		par[x] = par[par[x]];
		x = par[x];
	}
	return x;
}

static void uf_union(int32_t *par, int32_t a, int32_t b)
{
	a = uf_find(par, a);
	b = uf_find(par, b);
	if (a != b) {
		if (a < b)
			par[b] = a;
		else
			par[a] = b;
	}
}

/* Eigenvalues of a symmetric 6 x 6 matrix (cyclic Jacobi), into ev. */
static void eig6(double a[36], double ev[6])
{
	for (int sweep = 0; sweep < 60; sweep++) {
		double off = 0, tot = 0;
		for (int i = 0; i < 6; i++)
			for (int j = 0; j < 6; j++)
				if (i == j)
					tot += a[i * 6 + j] * a[i * 6 + j];
				else
					off += a[i * 6 + j] * a[i * 6 + j];
		if (off <= 1e-30 * (tot + off))
			break;
		for (int p = 0; p < 6; p++)
			for (int q = p + 1; q < 6; q++) {
				double apq = a[p * 6 + q];
				if (apq == 0)
					continue;
				double theta = (a[q * 6 + q] - a[p * 6 + p]) / (2 * apq);
				double t = (theta >= 0 ? 1 : -1) / (fabs(theta) + sqrt(theta * theta + 1));
				double c = 1 / sqrt(t * t + 1), sn = t * c;
				for (int k = 0; k < 6; k++) { /* columns */
					double akp = a[k * 6 + p], akq = a[k * 6 + q];
					a[k * 6 + p] = c * akp - sn * akq;
					a[k * 6 + q] = sn * akp + c * akq;
				}
				for (int k = 0; k < 6; k++) { /* rows */
					double apk = a[p * 6 + k], aqk = a[q * 6 + k];
					a[p * 6 + k] = c * apk - sn * aqk;
					a[q * 6 + k] = sn * apk + c * aqk;
				}
			}
	}
	for (int i = 0; i < 6; i++)
		ev[i] = a[i * 6 + i];
}

/* Per connected part: what holds it. */
struct part {
	size_t nodes, fixed_dofs, force_nodes;
	double c[3];  /* centroid of the fixed dofs' nodes, mm */
	double g[36]; /* Gram matrix of the rigid motions at the fixed dofs */
};

/* The rigid-motion rows of unknown (x, axis a), x relative to the centroid:
 * translations t_x, t_y, t_z then rotations w_x, w_y, w_z (u = t + w x r). */
static void rigid_row(const double x[3], int a, double row[6])
{
	memset(row, 0, 6 * sizeof *row);
	row[a] = 1;
	if (a == 0)
		row[4] = x[2], row[5] = -x[1];
	else if (a == 1)
		row[3] = -x[2], row[5] = x[0];
	else
		row[3] = x[1], row[4] = -x[0];
}

/* Rigid motions (of 6) that the fixed dofs of part p do not stop. */
static int free_motions(struct part *p)
{
	double g[36], ev[6], rr = 0, mx = 0;
	int free_n = 0;

	if (p->fixed_dofs == 0)
		return 6;
	/* scale rotations by the fixed set's radius so both blocks are O(1) */
	for (int a = 3; a < 6; a++)
		rr += p->g[a * 6 + a];
	rr = sqrt(rr / (double)p->fixed_dofs);
	if (!(rr > 0))
		rr = 1;
	for (int i = 0; i < 6; i++)
		for (int j = 0; j < 6; j++)
			g[i * 6 + j] = p->g[i * 6 + j] / (i >= 3 ? rr : 1) / (j >= 3 ? rr : 1);
	eig6(g, ev);
	for (int i = 0; i < 6; i++)
		mx = fmax(mx, ev[i]);
	for (int i = 0; i < 6; i++)
		free_n += ev[i] <= 1e-9 * mx;
	return free_n;
}

int fea_select(struct fea_solver *s, const struct fea_grid *g, const struct fea_loads *l,
	       struct err *e)
{
	const struct fea_level *L0 = &s->lv[0];
	int NX = L0->nx, NY = L0->ny, NZ = L0->nz;
	size_t nn = (size_t)s->cs;
	uint8_t *m = s->mask0;
	int32_t *par = NULL, *cid = NULL;
	struct part *parts = NULL;
	size_t nparts = 0, unconstrained_force = 0, rigid_bad = 0, rigid_nodes = 0;
	int rigid_free = 0, rc = 0;
	char name[160];

	if (l->nfixed == 0)
		return ERR_FIELD(e, "loads", "loads: no constraint (add a 'fixed' statement)");

	/* absent nodes: touching no present element (and the halo) */
	memset(m, FEA_NODE_ALL | FEA_NODE_ABSENT, (size_t)s->cs);
	for (int k = 0; k <= NZ; k++)
		for (int j = 0; j <= NY; j++)
			for (int i = 0; i <= NX; i++) {
				ptrdiff_t n = fea_n0(s, i, j, k);
				int present = 0;
				for (int p = 0; p < 8; p++)
					present |= s->w0[n + s->k0.eoff[p]] > 0;
				m[n] = present ? 0 : FEA_NODE_ALL | FEA_NODE_ABSENT;
			}

	/* constraints */
	for (size_t f = 0; f < l->nfixed; f++) {
		const struct fea_fix *fx = &l->fixed[f];
		struct range r[3];
		size_t hit = 0;

		place_ranges(g, fx->at, fx->box_mm, r);
		for (int k = r[2].lo; k <= r[2].hi; k++)
			for (int j = r[1].lo; j <= r[1].hi; j++)
				for (int i = r[0].lo; i <= r[0].hi; i++) {
					uint8_t *mk = &m[fea_n0(s, i, j, k)];
					if (*mk & FEA_NODE_ABSENT)
						continue;
					*mk |= (uint8_t)(fx->axes & FEA_NODE_ALL);
					hit++;
				}
		if (!hit) {
			place_name(name, sizeof name, "fixed", f + 1, fx->at, fx->box_mm);
			return ERR_FIELD(e, "loads", "loads: %s holds no material node", name);
		}
	}

	/* forces, spread over the selected nodes in proportion to the
	 * stiffness around each (the sum of the rho^p weights of the elements
	 * touching it): on full voxels a face's nodes then carry the
	 * consistent loads of a uniform traction (1 : 2 : 4 at corners, edges
	 * and inside), and a node touching only a sliver of material (a voxel
	 * a few percent full) a matching sliver of the load instead of an
	 * equal share it could only hold by moving far. */
	memset(s->f_user, 0, 3 * s->un_nodes * sizeof *s->f_user);
	for (size_t f = 0; f < l->nforces; f++) {
		const struct fea_force *fo = &l->forces[f];
		struct range r[3];
		size_t hit = 0, clash = 0;
		int clash_axis = 0;
		double wsum = 0;

		place_ranges(g, fo->at, fo->box_mm, r);
		for (int pass = 0; pass < 2; pass++)
			for (int k = r[2].lo; k <= r[2].hi; k++)
				for (int j = r[1].lo; j <= r[1].hi; j++)
					for (int i = r[0].lo; i <= r[0].hi; i++) {
						ptrdiff_t n0 = fea_n0(s, i, j, k);
						uint8_t *mk = &m[n0];
						double w = 0;
						if (*mk & FEA_NODE_ABSENT)
							continue;
						for (int p = 0; p < 8; p++)
							w += s->w0[n0 + s->k0.eoff[p]];
						if (pass == 0) {
							hit++;
							wsum += w;
							for (int a = 0; a < 3; a++)
								if (fo->force_n[a] != 0 && (*mk & (1u << a)))
									clash++, clash_axis = a;
							continue;
						}
						double *fu = &s->f_user[3 * user_node(s, i, j, k)];
						for (int a = 0; a < 3; a++)
							fu[a] += fo->force_n[a] * (w / wsum);
						if (fo->force_n[0] != 0 || fo->force_n[1] != 0 ||
						    fo->force_n[2] != 0)
							*mk |= FEA_NODE_FORCE;
					}
		place_name(name, sizeof name, "force", f + 1, fo->at, fo->box_mm);
		if (!hit)
			return ERR_FIELD(e, "loads", "loads: %s holds no material node", name);
		if (clash)
			return ERR_FIELD(e, "loads",
					 "loads: %s pushes along %c on %zu node(s) fixed along %c", name,
					 "xyz"[clash_axis], clash, "xyz"[clash_axis]);
	}

	/* connected parts (nodes joined through present elements) */
	if (nn > (size_t)INT32_MAX)
		return ERR_SET(e, ERR_LIMIT, "grid too large: %zu nodes", nn);
	par = mem_alloc(nn * sizeof *par);
	cid = mem_alloc(nn * sizeof *cid);
	if (!par || !cid) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for the part connectivity");
		goto out;
	}
	for (size_t n = 0; n < nn; n++)
		par[n] = (int32_t)n;
	for (int k = 0; k < NZ; k++)
		for (int j = 0; j < NY; j++)
			for (int i = 0; i < NX; i++) {
				if (!(s->w0[fea_n0(s, i, j, k)] > 0))
					continue;
				int32_t a = (int32_t)fea_n0(s, i, j, k);
				for (int c = 1; c < 8; c++)
					uf_union(par, a,
						 (int32_t)fea_n0(s, i + (c & 1), j + ((c >> 1) & 1),
								 k + ((c >> 2) & 1)));
			}
	for (size_t n = 0; n < nn; n++) {
		cid[n] = -1;
		if (m[n] & FEA_NODE_ABSENT)
			continue;
		int32_t root = uf_find(par, (int32_t)n);
		if ((size_t)root == n)
			cid[n] = (int32_t)nparts++;
	}
	parts = mem_calloc(nparts ? nparts : 1, sizeof *parts);
	if (!parts) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for the part connectivity");
		goto out;
	}
	for (int pass = 0; pass < 2; pass++) {
		for (int k = 0; k <= NZ; k++)
			for (int j = 0; j <= NY; j++)
				for (int i = 0; i <= NX; i++) {
					size_t n = (size_t)fea_n0(s, i, j, k);
					if (m[n] & FEA_NODE_ABSENT)
						continue;
					if (pass == 0)
						cid[n] = cid[uf_find(par, (int32_t)n)];
					struct part *pt = &parts[cid[n]];
					double x[3] = {g->lo_mm.x + i * g->h_mm, g->lo_mm.y + j * g->h_mm,
						       g->lo_mm.z + k * g->h_mm};
					if (pass == 0) {
						pt->nodes++;
						pt->force_nodes += (m[n] & FEA_NODE_FORCE) != 0;
					}
					for (int a = 0; a < 3; a++) {
						if (!(m[n] & (1u << a)))
							continue;
						if (pass == 0) {
							pt->fixed_dofs++;
							for (int b = 0; b < 3; b++)
								pt->c[b] += x[b];
							continue;
						}
						double rel[3], row[6];
						for (int b = 0; b < 3; b++)
							rel[b] = x[b] - pt->c[b];
						rigid_row(rel, a, row);
						for (int p = 0; p < 6; p++)
							for (int q = 0; q < 6; q++)
								pt->g[p * 6 + q] += row[p] * row[q];
					}
				}
		/* centroids after the first pass */
		if (pass == 0)
			for (size_t p = 0; p < nparts; p++)
				if (parts[p].fixed_dofs)
					for (int b = 0; b < 3; b++)
						parts[p].c[b] /= (double)parts[p].fixed_dofs;
	}

	/* classify: held, or an error when force acts on a part that moves */
	s->held_nodes = 0;
	for (size_t p = 0; p < nparts; p++) {
		struct part *pt = &parts[p];
		int fr = free_motions(pt);
		if (fr == 0)
			continue;
		if (pt->force_nodes) {
			if (pt->fixed_dofs == 0) {
				unconstrained_force += pt->force_nodes;
			} else if (!rigid_bad++) {
				rigid_free = fr;
				rigid_nodes = pt->nodes;
			}
			continue;
		}
		pt->fixed_dofs = (size_t)-1; /* mark: hold */
	}
	if (unconstrained_force) {
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "not constrained: %zu nodes in a part with no fixed node carry force",
			     unconstrained_force);
		goto out;
	}
	if (rigid_bad) {
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "not constrained against rigid motion: the fixed nodes of a loaded "
			     "part (%zu nodes) leave %d of 6 rigid motions free (a single fixed "
			     "point or line, or fixed axes that do not hold every direction)",
			     rigid_nodes, rigid_free);
		goto out;
	}
	for (size_t n = 0; n < nn; n++)
		if (!(m[n] & FEA_NODE_ABSENT) && parts[cid[n]].fixed_dofs == (size_t)-1) {
			m[n] |= FEA_NODE_ALL | FEA_NODE_HELD;
			s->held_nodes++;
		}
out:
	mem_free(par);
	mem_free(cid);
	mem_free(parts);
	return rc;
}
