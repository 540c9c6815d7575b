/* run.c - the hollow engine's pipeline (paper 004; docs/hollow.md
 * "Pipeline"): the optimiser's rounds (opt/), then the top-down fill
 * (fill/) of what they left, keeping whichever of optimiser + fill or the
 * fill alone hollows more; for the stability objective, the contact hull
 * and target region both stages steer by, and the centre of mass after.
 */
#include "engine/hollow/run.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/geom/hull.h"
#include "engine/mesh/mesh.h"
#include "engine/slice/slice.h"

void hl_outcome_fini(struct hl_outcome *o)
{
	mesh_free(o->mesh);
	hl_fill_fini(&o->fill);
	memset(o, 0, sizeof *o);
}

static void fill_params(const struct hl_config *c, struct hl_fill_params *p)
{
	memset(p, 0, sizeof *p);
	p->wall_mm = c->opt.wall_mm;
	p->wall_next_mm = c->opt.wall_next_mm;
	p->pixel_mm = c->opt.pixel_mm;
	p->layer_mm = c->print_layer_mm;
	p->alpha_rad = c->opt.alpha_rad;
	p->margin_rad = c->opt.margin_rad;
	p->min_void_mm3 = c->opt.min_void_mm3;
	p->lean = c->fill_lean;
	p->corners = c->fill_corners;
	p->map = c->fill_map;
	p->threads = c->opt.threads;
}

/* Standing fill: at most this many passes of the half-plane's fixed
 * point, stopping when the centre of mass moved less than the step (mm). */
#define HL_STAND_PASSES 4
#define HL_STAND_STEP_MM 0.05

/* (x, y) of the centre of mass of o's part: its mesh (part less the
 * optimised voids) less the fill's void. */
static struct hull_pt com_after(const struct hl_outcome *o)
{
	double vm, cm[3], vf, cf[2];
	struct hull_pt q;

	hl_mesh_mass(o->mesh, &vm, cm);
	hl_fill_mass(&o->fill, &vf, cf);
	q.x = cm[0];
	q.y = cm[1];
	if (vf > 0 && vm - vf > 0) {
		q.x = (vm * cm[0] - vf * cf[0]) / (vm - vf);
		q.y = (vm * cm[1] - vf * cf[1]) / (vm - vf);
	}
	return q;
}

/* The fill alone (step 9's other candidate) on a helper thread, while the
 * job thread fills around the optimised voids: the two are independent
 * (both read the part and the config only).  The helper has a private
 * progress record whose cancel hook is the flag the job thread raises
 * when its own fill stops (progress.h: helpers never touch the job's). */
struct alone_job {
	const struct mesh *part;
	struct hl_fill_params c; /* its own copy: half the threads */
	struct hl_fill fill;
	struct progress prog;
	struct err e;
	atomic_int stop;
	int rc;
};

static int alone_cancelled(void *ctx)
{
	return atomic_load(&((struct alone_job *)ctx)->stop);
}

static void *alone_main(void *arg)
{
	struct alone_job *j = arg;

	j->rc = hl_fill_build(j->part, NULL, &j->c, &j->prog, 0, 1, &j->fill, &j->e);
	return NULL;
}

/* The top-down fill of what the optimiser left (o->mesh holds its voids).
 * Lightweight: everywhere.  Stability (target: the goal region, hull: the
 * contact hull, r: its offset): removing mass at p moves the centre of
 * mass c along c - p, so while c is outside the target the fill keeps to
 * the half-plane behind c, away from the target's closest point q (the
 * raster counterpart of eq. 13-14's gradient); when c already stands, the
 * fill goes everywhere and is redone behind c only if it would tip the
 * part out of the offset hull H_r. */
static int fill_run(const struct mesh *part, const struct hl_fill_params *c,
		    const struct hull_pt *target, size_t ntarget, const struct hull_pt *hull,
		    size_t nhull, double r_mm, struct progress *prog, struct hl_outcome *o,
		    struct err *e)
{
	const struct mesh *solid = o->voids ? o->mesh : NULL;
	struct hl_fill_params fc = *c;
	struct hull_pt q = com_after(o), t;
	int edge, vertex, rc;
	double d;

	fc.keep_set = 0;
	if (ntarget < 3)
		return hl_fill_build(part, solid, &fc, prog, 0.9, 1.0, &o->fill, e);
	d = hull_closest_mm(target, ntarget, q, &t, &edge, &vertex);
	if (!(d > 0)) {
		struct hull_pt *hr = NULL;
		size_t nhr = 0;
		rc = hl_fill_build(part, solid, &fc, prog, 0.9, 0.95, &o->fill, e);
		if (!rc)
			rc = hull_offset_in(hull, nhull, r_mm, &hr, &nhr, e);
		if (rc || (nhr >= 3 && hull_signed_distance_mm(hr, nhr, com_after(o)) > 0)) {
			mem_free(hr);
			return rc;
		}
		mem_free(hr);
		hl_fill_fini(&o->fill);
		/* behind c, away from the target's inscribed centre */
		hull_inradius_mm(target, ntarget, &t);
		d = hypot(t.x - q.x, t.y - q.y);
		if (!(d > 0))
			return 0;
	}
	/* c moves along n as the fill removes mass behind it, and then more
	 * mass lies behind it: the half-plane follows c (a fixed point) */
	fc.keep_set = 1;
	fc.keep[0] = (t.x - q.x) / d;
	fc.keep[1] = (t.y - q.y) / d;
	for (int it = 0; it < HL_STAND_PASSES; it++) {
		double shift;
		fc.keep[2] = fc.keep[0] * q.x + fc.keep[1] * q.y;
		rc = hl_fill_build(part, solid, &fc, prog, 0.95, 1.0, &o->fill, e);
		if (rc)
			return rc;
		t = com_after(o);
		shift = fc.keep[0] * (t.x - q.x) + fc.keep[1] * (t.y - q.y);
		q = t;
		if (!(shift > HL_STAND_STEP_MM) || !(hull_closest_mm(target, ntarget, q, &t, &edge,
								      &vertex) > 0))
			break;
	}
	return 0;
}


/* Stability: the contact hull of the first layer (*hull) and the target
 * region (*target): the hull offset inward by 0.55 of its inscribed
 * radius rho, i.e. H_r (r = rho / 2) shrunk by another 10 % of r, so the
 * optimum (on the target's boundary) lies strictly inside H_r.  With
 * fewer than 3 hull points o->note says so and there is no target.
 * com: the part's centre of mass (mm). */
static int stability_setup(const struct mesh *part, const double com[3],
			   const struct hl_config *c, struct hl_outcome *o, struct hull_pt **hull,
			   size_t *nhull, struct hull_pt **target, size_t *ntarget, struct err *e)
{
	double rho;
	struct hull_pt q;
	int rc = slice_contact_hull(part, c->print_layer_mm, hull, nhull, e);

	if (rc)
		return rc;
	if (*nhull < 3) {
		snprintf(o->note, sizeof o->note, "no contact area found on the first layer");
		return 0;
	}
	q.x = com[0];
	q.y = com[1];
	rho = hull_inradius_mm(*hull, *nhull, NULL);
	o->has_com = 1;
	o->hull_offset_mm = 0.5 * rho;
	o->com_before_mm = hull_signed_distance_mm(*hull, *nhull, q);
	o->stands_before = o->com_before_mm > 0;
	return hull_offset_in(*hull, *nhull, 0.55 * rho, target, ntarget, e);
}

/* The fill stage: the fill around the optimised voids (fill_run) and,
 * lightweight with optimised voids, the fill alone (on a helper thread
 * when there are two threads), keeping whichever hollows more. */
static int fill_stage(const struct mesh *part, const struct hl_config *c,
		      const struct hull_pt *target, size_t ntarget, const struct hull_pt *hull,
		      size_t nhull, struct progress *prog, struct hl_outcome *res, struct err *e)
{
	struct hl_fill_params fp;
	double t0 = progress_now_s();
	int both = res->voids_optimised > 0 && c->opt.objective == HL_OBJ_LIGHTWEIGHT;
	struct alone_job *aj = NULL;
	struct hl_fill alone;
	pthread_t th;
	int rc, have_alone = 0;

	fill_params(c, &fp);
	if (both && c->opt.threads >= 2 && (aj = mem_calloc(1, sizeof *aj)) != NULL) {
		struct progress_hooks hk = {NULL, alone_cancelled, aj};
		aj->part = part;
		aj->c = fp;
		aj->c.threads = c->opt.threads / 2; /* two fills side by side share them */
		err_clear(&aj->e);
		atomic_init(&aj->stop, 0);
		progress_init(&aj->prog, &hk);
		if (pthread_create(&th, NULL, alone_main, aj) != 0) {
			mem_free(aj); /* no thread: the fill alone runs after, here */
			aj = NULL;
		} else {
			fp.threads = aj->c.threads; /* the other half */
		}
	}
	rc = fill_run(part, &fp, target, ntarget, hull, nhull, res->hull_offset_mm, prog, res, e);
	memset(&alone, 0, sizeof alone);
	if (aj) {
		if (rc)
			atomic_store(&aj->stop, 1);
		pthread_join(th, NULL);
		if (!rc && aj->rc) {
			*e = aj->e;
			rc = aj->rc;
		}
		alone = aj->fill;
		have_alone = 1;
		mem_free(aj);
	}
	if (rc) {
		hl_fill_fini(&alone);
		return rc;
	}
	res->voids += res->fill.voids;
	res->void_volume_mm3 += res->fill.volume_mm3;
	/* lightweight: the fill keeps wall_next_mm from the optimised voids,
	 * and where they are smaller than what the fill alone would carve
	 * there the pair hollows less; keep the larger */
	if (both) {
		if (!have_alone) {
			rc = hl_fill_build(part, NULL, &fp, prog, 0.95, 1.0, &alone, e);
			if (rc)
				return rc;
		}
		res->fill_alone_mm3 = alone.volume_mm3;
		res->opt_fill_mm3 = res->void_volume_mm3;
		if (alone.volume_mm3 > res->void_volume_mm3) {
			struct mesh *pm = mesh_clone(part);
			if (!pm) {
				hl_fill_fini(&alone);
				return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			}
			mesh_free(res->mesh);
			res->mesh = pm;
			hl_fill_fini(&res->fill);
			res->fill = alone;
			memset(&alone, 0, sizeof alone);
			res->voids_dropped_for_fill = res->voids_optimised;
			res->rounds = 0; /* no optimised round is in the output */
			res->voids = res->fill.voids;
			res->voids_optimised = res->voids_fallback = 0;
			res->void_volume_mm3 = res->fill.volume_mm3;
		}
	}
	hl_fill_fini(&alone);
	res->s_fill = progress_now_s() - t0;
	return 0;
}

/* o->note when nothing was hollowed: why. */
static void empty_note(const struct hl_config *c, struct hl_outcome *o)
{
	if (o->voids || o->note[0])
		return;
	if (c->fill_map_set && c->opt.rounds == 0) {
		/* the pixel fill alone: its pixels are whole squares, so with
		 * a reach under one pixel no solid pixel may hang over a void */
		const struct raster_map *fm = &c->fill_map;
		double pitch = 1 / sqrt(fabs(fm->a[0][0] * fm->a[1][1] - fm->a[0][1] * fm->a[1][0]));
		double reach = c->print_layer_mm * tan(c->opt.alpha_rad);
		if (reach < pitch) {
			snprintf(o->note, sizeof o->note,
				 "no support-free void: at this alpha a layer may overhang %.3f mm, less "
				 "than the %.3f mm pixel, and the pixel fill cannot hang a pixel over a "
				 "void; the optimiser's voids (rounds > 0, in a layer output: a mesh steps "
				 "them by whole pixels too) or a larger alpha can hollow it",
				 reach, pitch);
			return;
		}
	}
	if (o->opt.budget_spent && !c->fill) {
		snprintf(o->note, sizeof o->note,
			 "the optimiser's time (optimise_s %g s) ran out before it kept a void; a "
			 "larger optimise_s or fill=true can hollow it; the part is returned unchanged",
			 c->opt.optimise_s);
		return;
	}
	if (o->opt.work_spent && !c->fill) {
		snprintf(o->note, sizeof o->note,
			 "the optimiser's work budget (optimise_work %g reference s) was "
			 "spent before it kept a void; a larger optimise_work or fill=true can hollow "
			 "it; the part is returned unchanged",
			 c->opt.optimise_work);
		return;
	}
	if (o->opt.loops > 0 && !c->fill) {
		/* the interior is there: the optimiser's voids were dropped */
		snprintf(o->note, sizeof o->note,
			 "the optimiser kept no void: %zu loops inside the wall, no support-free "
			 "void >= min_void_mm3 %g between them (%zu smaller, %zu failed, %zu too "
			 "close, %zu runs of loops no support-free strip could join); fill=true "
			 "hollows the interior; the part is returned unchanged",
			 o->opt.loops, c->opt.min_void_mm3, o->opt.groups_small,
			 o->opt.groups_failed, o->opt.voids_too_close, o->opt.groups_unbuilt);
		return;
	}
	snprintf(o->note, sizeof o->note,
		 "too thin to hollow: no support-free void of at least %g mm3 fits inside a "
		 "%g mm wall; the part is returned unchanged",
		 c->opt.min_void_mm3, c->opt.wall_mm);
}

int hl_run(const struct mesh *part, const struct hl_config *c, struct progress *prog,
	   struct hl_outcome *o, struct err *e)
{
	struct hl_outcome res;
	struct hl_opt_params op;
	struct hull_pt *hull = NULL, *target = NULL;
	size_t nhull = 0, ntarget = 0;
	double com[3];
	int rc = 0;

	memset(&res, 0, sizeof res);
	hl_mesh_mass(part, &res.part_volume_mm3, com);
	if (c->opt.objective == HL_OBJ_STABILITY) {
		rc = stability_setup(part, com, c, &res, &hull, &nhull, &target, &ntarget, e);
		if (rc)
			goto out;
	}
	op = c->opt;
	op.target = target;
	op.ntarget = ntarget;
	rc = hl_opt_run(part, &op, prog, &res.mesh, &res.opt, e);
	if (rc)
		goto out;
	res.rounds = res.opt.rounds;
	res.voids = res.voids_optimised = res.opt.voids;
	res.voids_fallback = res.opt.voids_fallback;
	res.void_volume_mm3 = res.opt.volume_mm3;
	if (c->fill && c->fill_map_set && (c->opt.objective == HL_OBJ_LIGHTWEIGHT || ntarget >= 3)) {
		rc = fill_stage(part, c, target, ntarget, hull, nhull, prog, &res, e);
		if (rc)
			goto out;
	}
	empty_note(c, &res);
	if (res.has_com) {
		struct hull_pt q = com_after(&res), *hr = NULL;
		size_t nhr = 0;
		res.com_after_mm = hull_signed_distance_mm(hull, nhull, q);
		rc = hull_offset_in(hull, nhull, res.hull_offset_mm, &hr, &nhr, e);
		if (rc)
			goto out;
		res.com_inside = nhr >= 3 && hull_signed_distance_mm(hr, nhr, q) > 0;
		mem_free(hr);
	}
	*o = res;
	memset(&res, 0, sizeof res);
out:
	hl_outcome_fini(&res);
	mem_free(hull);
	mem_free(target);
	return rc;
}
