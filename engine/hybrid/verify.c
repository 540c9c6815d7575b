/* verify.c - component verification (paper 003 section 4.2): the mean
 * stress of every part under the paper's 1000 N loads decides whether a
 * column-shaped part really works as a column (VCol) or not (NCol).
 *
 * The solid part is voxelised (engine/fea, exact slice coverage), fixed on
 * the plate and loaded on its top, once straight down and once from the
 * top right at 45 degrees between x and z (the paper's Fig. 2).  For each
 * part the volume-weighted mean of sigma_xx, sigma_yy, sigma_zz over the
 * elements whose centre the labeler assigns it is compared: a Col part is
 * VCol when, under both loads, the largest |mean| is at least `dominance`
 * times the second and at least floor_frac of the largest over all Col
 * parts.  Signed means: bending stresses of opposite sign cancel, so a
 * leg's axial compression dominates while a bent part shows no dominant
 * direction.
 */
#include "engine/hybrid/hybrid.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/fea/fea.h"
#include "engine/mesh/mesh.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Largest and second largest of |v[0..2]|; index of the largest. */
static int dominant(const double v[3], double *first, double *second)
{
	double a[3] = {fabs(v[0]), fabs(v[1]), fabs(v[2])};
	int i = a[0] >= a[1] ? (a[0] >= a[2] ? 0 : 2) : (a[1] >= a[2] ? 1 : 2);

	*first = a[i];
	*second = fmax(a[(i + 1) % 3], a[(i + 2) % 3]);
	return i;
}

static int solve_case(const struct fea_grid *g, const char *text, const struct hy_verify_opts *o,
		      const uint8_t *owner, size_t nparts, struct hy_stress *st, int which,
		      struct err *e)
{
	struct fea_material mat = {o->E_mpa, o->nu};
	struct fea_loads l;
	struct fea_opts fo;
	struct fea_solver *s = NULL;
	struct fea_result r;
	size_t ne = (size_t)g->nx * g->ny * g->nz;
	uint8_t *mask = NULL;
	int rc;

	if ((rc = fea_loads_parse(text, mat, &l, e)) != 0)
		return rc;
	fea_opts_default(&fo);
	fo.threads = o->threads;
	rc = fea_solver_new(g, &l, &fo, &s, e);
	fea_loads_fini(&l);
	if (rc == 0)
		rc = fea_solve(s, &r, e);
	if (rc == 0 && !(mask = mem_alloc(ne))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu element flags", ne);
	}
	for (size_t p = 0; rc == 0 && p < nparts; p++) {
		double mean6[6];
		size_t cnt = 0;
		for (size_t i = 0; i < ne; i++) {
			mask[i] = owner[i] == p + 1;
			cnt += mask[i];
		}
		st[p].elements = cnt;
		if (!cnt) {
			memset(st[p].mean_mpa[which], 0, sizeof st[p].mean_mpa[which]);
			st[p].ratio[which] = 0;
			continue;
		}
		fea_element_stress(s, NULL, mask, mean6);
		for (int a = 0; a < 3; a++)
			st[p].mean_mpa[which][a] = mean6[a];
		{
			double f, sec;
			dominant(st[p].mean_mpa[which], &f, &sec);
			st[p].ratio[which] = sec > 0 ? f / sec : INFINITY;
		}
	}
	mem_free(mask);
	fea_solver_free(s);
	return rc;
}

int hy_verify(const struct mesh *m, const struct hy_labeler *l, struct hy_parts *ps,
	      const struct hy_verify_opts *o, struct hy_stress *st, double *seconds,
	      struct err *e)
{
	struct fea_grid g;
	uint8_t *owner = NULL;
	double t0 = progress_now_s(), smax = 0;
	char text[2][256];
	size_t ne;
	int rc;

	memset(&g, 0, sizeof g);
	memset(st, 0, ps->n * sizeof *st);
	if (ps->n > 254)
		return ERR_SET(e, ERR_LIMIT, "hybrid: %zu parts to verify (at most 254)", ps->n);
	if ((rc = fea_voxelize_mesh(m, o->fea_voxel_mm, 2, o->max_elements, o->threads, &g, e)) != 0)
		return rc;
	ne = (size_t)g.nx * g.ny * g.nz;
	if (!(owner = mem_calloc(ne, 1))) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu element owners", ne);
		goto out;
	}
	/* the owner of each present element: the part at its centre */
	for (int k = 0; k < g.nz; k++)
		for (int j = 0; j < g.ny; j++)
			for (int i = 0; i < g.nx; i++) {
				size_t id = ((size_t)k * g.ny + j) * g.nx + i;
				struct vec3 c = v3(g.lo_mm.x + (i + 0.5) * g.h_mm,
						   g.lo_mm.y + (j + 0.5) * g.h_mm,
						   g.lo_mm.z + (k + 0.5) * g.h_mm);
				int p;
				if (!(g.rho[id] > 0))
					continue;
				p = hy_label_at(l, c);
				owner[id] = p >= 0 ? (uint8_t)(p + 1) : 0;
			}
	{
		/* the part stands on what reaches within contact_mm of the plate
		 * (feet modelled a little apart stand together), ends free */
		struct vec3 sz = box3_size((struct box3){g.part_lo_mm, g.part_hi_mm});
		double t = fmax(o->contact_mm, g.h_mm / 2);
		char fix[96];
		snprintf(fix, sizeof fix, "fixed box=-1,-1,-1,%.6f,%.6f,%.6f axes=xyz", sz.x + 1,
			 sz.y + 1, t);
		snprintf(text[0], sizeof text[0], "%s; force top n=0,0,%.17g", fix, -o->load_n);
		snprintf(text[1], sizeof text[1], "%s; force top n=%.17g,0,%.17g", fix,
			 -o->load_n / sqrt(2), -o->load_n / sqrt(2));
	}
	for (int c = 0; c < 2 && rc == 0; c++)
		rc = solve_case(&g, text[c], o, owner, ps->n, st, c, e);
	if (rc)
		goto out;
	for (size_t p = 0; p < ps->n; p++) {
		double f, sec;
		if (ps->p[p].cls == HY_NCOL)
			continue;
		for (int c = 0; c < 2; c++) {
			dominant(st[p].mean_mpa[c], &f, &sec);
			smax = fmax(smax, f);
		}
	}
	for (size_t p = 0; p < ps->n; p++) {
		int ok = ps->p[p].cls != HY_NCOL && st[p].elements > 0;
		for (int c = 0; ok && c < 2; c++) {
			double f, sec;
			dominant(st[p].mean_mpa[c], &f, &sec);
			ok = st[p].ratio[c] >= o->dominance && f >= o->floor_frac * smax;
		}
		if (ps->p[p].cls != HY_NCOL)
			ps->p[p].cls = ok ? HY_VCOL : HY_NCOL;
	}
out:
	*seconds = progress_now_s() - t0;
	mem_free(owner);
	fea_grid_fini(&g);
	return rc;
}
