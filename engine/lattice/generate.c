/* generate.c - paper 000 section 5 end to end for a mesh (generate.h).
 *
 * The part is seen through its BVH: generalised winding number for
 * inside tests, closest point for distances (mesh.h).  Stages and their
 * share of the progress: raw baseline 10%, SO lattice 15%, PO 15%,
 * matching 50%, measurement 10%.
 */
#include "engine/lattice/generate.h"
#include "engine/lattice/gen.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/mesh/mesh.h"

#include <math.h>
#include <string.h>

static int dom_inside(void *ctx, struct vec3 p)
{
	return mesh_bvh_inside(ctx, p);
}

static double dom_distance(void *ctx, struct vec3 p)
{
	return mesh_bvh_closest(ctx, p, NULL, NULL);
}

static int step(const struct lattice_gen_opts *o, double f, struct err *e)
{
	return o->progress ? progress_update(o->progress, f, e) : 0;
}

int lattice_generate(const struct mesh *m, const struct lattice_gen_opts *o,
		     struct lattice **out, struct lattice_gen_report *rep, struct err *e)
{
	struct mesh_bvh *bvh = NULL;
	struct lattice_domain d;
	struct lattice_tetmesh t = {0};
	struct lattice_build_stats bs;
	struct lattice_support_metrics sm;
	struct lattice *q = NULL;
	double r0 = 2 * o->min_radius_mm, t0;
	int rc;

	memset(rep, 0, sizeof *rep);
	if ((rc = mesh_bvh_new(m, &bvh, e)) != 0)
		return rc;
	memset(&d, 0, sizeof d);
	d.box = box3_empty();
	for (size_t i = 0; i < 3 * m->nt; i++)
		box3_add(&d.box, m->v[m->tri[i]]);
	d.inside = dom_inside;
	d.distance = dom_distance;
	d.ctx = bvh;
	d.surface = m;
	d.threads = o->threads < 1 ? 1 : o->threads;

	/* Table 3 baseline: the plain tetrahedral lattice (k = 1, no PO) */
	if (o->raw_baseline && o->so_k != 1) {
		struct lattice_build_opts bo = {1.0, r0, o->density, o->seed, o->max_nodes, NULL};
		t0 = progress_now_s();
		if ((rc = lattice_build_tetmesh(&d, &bo, &t, &bs, e)) != 0)
			goto out;
		lattice_support_measure(&t, o->alpha_rad, &sm);
		rep->gamma_raw = sm.gamma;
		rep->psi_raw = sm.psi;
		rep->raw_nodes = t.np;
		{
			uint32_t *ed = NULL;
			size_t ne = 0;
			if ((rc = lattice_tetmesh_edges(&t, &ed, &ne, e)) != 0)
				goto out;
			mem_free(ed);
			rep->raw_struts = ne;
		}
		lattice_tetmesh_fini(&t);
		rep->s_raw = progress_now_s() - t0;
	}
	if ((rc = step(o, 0.1, e)) != 0)
		goto out;

	/* SO: build in the space compressed by 1/k */
	{
		struct lattice_build_opts bo = {o->so_k, r0, o->density, o->seed + 1, o->max_nodes,
						NULL};
		if ((rc = lattice_build_tetmesh(&d, &bo, &t, &bs, e)) != 0)
			goto out;
		rep->surface_nodes = bs.surface_nodes;
		rep->interior_nodes = bs.interior_nodes;
		rep->tets = t.nt;
		rep->s_sample = bs.seconds_sample + bs.seconds_restrict;
		rep->s_tetgen = bs.seconds_tetgen;
		lattice_support_measure(&t, o->alpha_rad, &sm);
		rep->gamma_so = rep->gamma_so_po = sm.gamma;
		rep->psi_so = rep->psi_so_po = sm.psi;
		if (o->so_k == 1 || !o->raw_baseline) {
			rep->gamma_raw = o->so_k == 1 ? sm.gamma : NAN;
			rep->psi_raw = o->so_k == 1 ? sm.psi : NAN;
		}
	}
	if ((rc = step(o, 0.25, e)) != 0)
		goto out;

	/* PO */
	if (o->po) {
		struct lattice_po_opts po = {o->alpha_rad, o->po_rounds, o->seed + 2, NULL};
		struct lattice_po_stats ps;
		t0 = progress_now_s();
		if ((rc = lattice_po_optimize(&t, &po, &ps, e)) != 0)
			goto out;
		lattice_support_measure(&t, o->alpha_rad, &sm);
		rep->gamma_so_po = sm.gamma;
		rep->psi_so_po = sm.psi;
		rep->po_rounds = ps.rounds;
		rep->po_moves = ps.moves;
		rep->s_po = progress_now_s() - t0;
	}
	if ((rc = step(o, 0.4, e)) != 0)
		goto out;

	/* density matching, or uniform struts of the initial radius */
	rep->voxel_mm = o->voxel_mm > 0 ? o->voxel_mm
			 : 1.5 * lattice_spacing_for_density(
					 0.5 * (o->density->lo + o->density->hi), r0);
	t0 = progress_now_s();
	if (o->match) {
		struct lattice_match_opts mo = {o->density,     o->min_radius_mm, r0,
						o->support_factor, rep->voxel_mm, o->max_subdiv,
						o->mc_samples,  o->match_passes,  o->threads,
						o->seed + 3,    NULL};
		struct lattice_match_stats ms;
		if ((rc = lattice_match_density(&t, &d, &mo, &q, &ms, e)) != 0)
			goto out;
		rep->subdivided_tets = ms.subdivided_tets;
		rep->voxels = ms.voxels;
	} else {
		uint32_t *ed = NULL;
		size_t ne = 0;
		q = lattice_new();
		if (!q || (rc = lattice_tetmesh_edges(&t, &ed, &ne, e)) != 0 ||
		    (rc = lattice_reserve(q, t.np, ne)) != 0) {
			mem_free(ed);
			rc = rc ? rc : ERR_SET(e, ERR_NOMEM, "out of memory");
			goto out;
		}
		for (size_t i = 0; i < t.np; i++)
			lattice_add_node(q, t.p[i]);
		for (size_t i = 0; i < ne; i++)
			lattice_add_edge(q, ed[2 * i], ed[2 * i + 1], r0);
		mem_free(ed);
		q->support_mm = o->support_factor * r0;
	}
	rep->s_match = progress_now_s() - t0;
	lattice_support_measure_lattice(q, o->alpha_rad, &sm);
	rep->gamma_final = sm.gamma;
	rep->psi_final = sm.psi;
	if ((rc = step(o, 0.9, e)) != 0)
		goto out;

	/* independent measurement of the realised density */
	t0 = progress_now_s();
	{
		size_t nv;
		if ((rc = lattice_measure_density(q, &d, o->density, rep->voxel_mm, d.threads,
						  &rep->density_error_mean,
						  &rep->density_error_max, &nv, e)) != 0)
			goto out;
		rep->voxels = nv;
	}
	rep->s_measure = progress_now_s() - t0;
	if ((rc = step(o, 1.0, e)) != 0)
		goto out;
	*out = q;
	q = NULL;
out:
	lattice_free(q);
	lattice_tetmesh_fini(&t);
	mesh_bvh_free(bvh);
	return rc;
}
