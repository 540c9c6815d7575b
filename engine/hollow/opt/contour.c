/* contour.c - the inner solid's cross-sections as simple, resampled loops
 * (paper 004, section 3 step 2; docs/hollow.md "Contours").
 *
 * A slice of the uniformly offset part is a normalised region (outer
 * boundaries CCW, holes CW).  The optimisation needs genus-0 loops with
 * vertices about s apart:
 *  1. opening by s (shrink, then grow, round joins): removes necks and
 *     slivers narrower than 2 s, which a sampling of step s cannot follow
 *     without its chords crossing; the opening lies inside the region, so
 *     walls only get thicker;
 *  2. holes are opened by a slit of width slit_mm running from each
 *     hole's topmost vertex in +y out of the region: every remaining
 *     boundary is then a simple loop (a C instead of an O; the slit is a
 *     thin wall the optimisation treats like any other boundary);
 *  3. each loop is resampled to steps of at most s along its length,
 *     keeping reflex corners (where the solid pokes into the void) so the
 *     chords never cut into the wall.
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/hollow/opt/opt_int.h"

/* Reflex corners sharper than this (turn angle, radians) are kept. */
#define HL_KEEP_TURN_RAD 0.35

int hl_loop_to_path(const struct hl_loop *l, struct path *p)
{
	path_fini(p);
	p->pts = mem_alloc((l->n ? l->n : 1) * sizeof *p->pts);
	if (!p->pts)
		return ERR_NOMEM;
	p->cap = l->n;
	for (size_t i = 0; i < l->n; i++) {
		p->pts[i].x = geom_mm_to_nm(l->xy[2 * i]);
		p->pts[i].y = geom_mm_to_nm(l->xy[2 * i + 1]);
	}
	p->n = l->n;
	return 0;
}

int hl_loop_overlap_mm2(const struct hl_loop *a, const struct hl_loop *b, double *area,
			struct err *e)
{
	struct paths pa, pb, out;
	int rc;

	paths_init(&pa);
	paths_init(&pb);
	paths_init(&out);
	rc = !paths_add(&pa) || !paths_add(&pb) ? ERR_NOMEM : 0;
	if (!rc)
		rc = hl_loop_to_path(a, &pa.v[0]);
	if (!rc)
		rc = hl_loop_to_path(b, &pb.v[0]);
	if (rc) {
		rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
		goto out;
	}
	rc = clip_boolean(CLIP_INTERSECTION, &pa, &pb, CLIP_FILL_NONZERO, &out, e);
	if (!rc)
		*area = paths_area_mm2(&out);
out:
	paths_fini(&pa);
	paths_fini(&pb);
	paths_fini(&out);
	return rc;
}

/* Append point (mm) to a growing xy array. */
static int push_xy(double **xy, size_t *n, size_t *cap, double x, double y)
{
	void *a = *xy;

	if (*n > 0 && fabs((*xy)[2 * *n - 2] - x) < 1e-7 && fabs((*xy)[2 * *n - 1] - y) < 1e-7)
		return 0;
	if (mem_grow(&a, cap, *n + 1, 2 * sizeof **xy))
		return ERR_NOMEM;
	*xy = a;
	(*xy)[2 * *n] = x;
	(*xy)[2 * *n + 1] = y;
	(*n)++;
	return 0;
}

/* Resample the closed CCW path p (nm) to steps of at most s_mm, keeping
 * sharp reflex corners.  Result in *xy (mm, owned), *n points. */
static int resample(const struct path *p, double s_mm, double **out, size_t *nout)
{
	size_t n = p->n, nk = 0, cap = 0, m = 0, first = 0;
	double *x = mem_alloc(2 * n * sizeof *x), *xy = NULL;
	unsigned char *keep = mem_calloc(n, 1);
	int rc = 0;

	if (!x || !keep) {
		rc = ERR_NOMEM;
		goto out;
	}
	for (size_t i = 0; i < n; i++) {
		x[2 * i] = geom_nm_to_mm(p->pts[i].x);
		x[2 * i + 1] = geom_nm_to_mm(p->pts[i].y);
	}
	for (size_t i = 0; i < n; i++) {
		size_t a = (i + n - 1) % n, b = (i + 1) % n;
		double ux = x[2 * i] - x[2 * a], uy = x[2 * i + 1] - x[2 * a + 1];
		double vx = x[2 * b] - x[2 * i], vy = x[2 * b + 1] - x[2 * i + 1];
		double cr = ux * vy - uy * vx, dt = ux * vx + uy * vy;
		/* turn angle; negative cross = clockwise turn = reflex for CCW */
		if (cr < 0 && fabs(atan2(cr, dt)) > HL_KEEP_TURN_RAD) {
			keep[i] = 1;
			if (!nk++)
				first = i;
		}
	}
	/* walk the loop from a kept corner (or vertex 0), one chain per kept
	 * corner, each chain resampled uniformly */
	for (size_t done = 0, i = first; done < n;) {
		size_t j = i, steps = 0;
		double len = 0;
		do {
			size_t b = (j + 1) % n;
			len += hypot(x[2 * b] - x[2 * j], x[2 * b + 1] - x[2 * j + 1]);
			j = b;
			steps++;
		} while (!keep[j] && j != first);
		{
			int k = (int)ceil(len / s_mm - 1e-9);
			size_t c = i;
			double pos = 0, seg, t;
			if (k < 1)
				k = 1;
			/* emit k points: at arc lengths 0, len/k, ... */
			for (int q = 0; q < k; q++) {
				double target = len * q / k;
				for (;;) {
					size_t b = (c + 1) % n;
					seg = hypot(x[2 * b] - x[2 * c], x[2 * b + 1] - x[2 * c + 1]);
					if (pos + seg >= target || b == j)
						break;
					pos += seg;
					c = b;
				}
				{
					size_t b = (c + 1) % n;
					t = seg > 0 ? (target - pos) / seg : 0;
					t = t < 0 ? 0 : t > 1 ? 1 : t;
					if (push_xy(&xy, &m, &cap, x[2 * c] + t * (x[2 * b] - x[2 * c]),
						    x[2 * c + 1] + t * (x[2 * b + 1] - x[2 * c + 1]))) {
						rc = ERR_NOMEM;
						goto out;
					}
				}
			}
		}
		done += steps;
		i = j;
	}
	/* drop a closing duplicate */
	if (m > 1 && fabs(xy[0] - xy[2 * m - 2]) < 1e-7 && fabs(xy[1] - xy[2 * m - 1]) < 1e-7)
		m--;
	*out = xy;
	*nout = m;
	xy = NULL;
out:
	mem_free(x);
	mem_free(keep);
	mem_free(xy);
	return rc;
}

static double xy_area(const double *xy, size_t n)
{
	double a = 0;

	for (size_t i = 0; i < n; i++) {
		size_t j = (i + 1) % n;
		a += xy[2 * i] * xy[2 * j + 1] - xy[2 * j] * xy[2 * i + 1];
	}
	return 0.5 * a;
}

int hl_contours_from_region(const struct paths *region, int slice, double z_mm,
			    const struct hl_contour_params *p, struct hl_slice *out,
			    struct err *e)
{
	struct paths a, b, slits;
	double r_nm = p->spacing_mm * GEOM_NM_PER_MM;
	int rc;

	paths_init(&a);
	paths_init(&b);
	paths_init(&slits);
	/* 1. opening */
	rc = clip_offset(region, -r_nm, CLIP_JOIN_ROUND, 2, 0.05 * r_nm, &a, e);
	if (!rc)
		rc = clip_offset(&a, r_nm, CLIP_JOIN_ROUND, 2, 0.05 * r_nm, &b, e);
	if (rc)
		goto out;
	/* 2. slits out of every hole */
	{
		struct pt2 lo, hi;
		int64_t w = geom_mm_to_nm(0.5 * p->slit_mm);
		if (paths_bbox(&b, &lo, &hi)) {
			for (size_t i = 0; i < b.n; i++) {
				const struct path *q = &b.v[i];
				size_t top = 0;
				if (path_area2_nm2(q) >= 0 || q->n < 3)
					continue;
				for (size_t k = 1; k < q->n; k++)
					if (q->pts[k].y > q->pts[top].y)
						top = k;
				struct pt2 r[4] = {{q->pts[top].x - w, q->pts[top].y - w},
						   {q->pts[top].x + w, q->pts[top].y - w},
						   {q->pts[top].x + w, hi.y + 4 * w + 1000},
						   {q->pts[top].x - w, hi.y + 4 * w + 1000}};
				if (paths_add_pts(&slits, r, 4)) {
					rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
					goto out;
				}
			}
		}
		if (slits.n) {
			rc = clip_boolean(CLIP_DIFFERENCE, &b, &slits, CLIP_FILL_NONZERO, &a, e);
			if (rc)
				goto out;
			paths_fini(&b);
			b = a;
			paths_init(&a);
		}
	}
	/* 3. resample every outer loop */
	for (size_t i = 0; i < b.n; i++) {
		struct hl_loop L;
		void *arr;
		if (path_area2_nm2(&b.v[i]) <= 0 || b.v[i].n < 3)
			continue; /* a hole left over (should not happen) or a sliver */
		memset(&L, 0, sizeof L);
		if (resample(&b.v[i], p->spacing_mm, &L.xy, &L.n)) {
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			goto out;
		}
		L.area_mm2 = L.n >= 3 ? xy_area(L.xy, L.n) : 0;
		if (L.n < 6 || L.area_mm2 < p->min_area_mm2) {
			hl_loop_fini(&L);
			continue;
		}
		L.slice = slice;
		L.z_mm = z_mm;
		arr = out->loop;
		if (mem_grow(&arr, &out->cap, out->n + 1, sizeof *out->loop)) {
			hl_loop_fini(&L);
			rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
			goto out;
		}
		out->loop = arr;
		hl_loop_move(&out->loop[out->n++], &L);
	}
out:
	paths_fini(&a);
	paths_fini(&b);
	paths_fini(&slits);
	return rc;
}

/* The moved vertex, 0.5 v + 0.25 (p + q), lies in the triangle p v q,
 * which lies inside the loop at a convex v unless another stretch of the
 * boundary enters it.  Its sides are <= s; step 1's opening makes the
 * region a union of discs of radius s, so its boundary never comes within
 * s of itself across the region, and across the solid the offset keeps
 * stretches 2 t apart; only a slit narrower than s (wall_next_mm < s) could
 * bring a stretch that close.  Where that happens, the strips' clearance
 * test (rounds.c `blocked`) still refuses every triangle nearer than t / 2
 * to the solid's surface. */
int hl_loop_smooth(struct hl_loop *l, int passes, struct err *e)
{
	size_t n = l->n;
	double *old;

	if (passes <= 0 || n < 4)
		return 0;
	old = mem_alloc(2 * n * sizeof *old);
	if (!old)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory smoothing a loop");
	for (int it = 0; it < passes; it++) {
		memcpy(old, l->xy, 2 * n * sizeof *old);
		for (size_t i = 0; i < n; i++) {
			const double *p = old + 2 * ((i + n - 1) % n), *v = old + 2 * i,
				     *q = old + 2 * ((i + 1) % n);
			/* counter-clockwise loop: a left turn at v is convex */
			double turn = (v[0] - p[0]) * (q[1] - v[1]) - (v[1] - p[1]) * (q[0] - v[0]);
			double x = 0.5 * v[0] + 0.25 * (p[0] + q[0]), y = 0.5 * v[1] + 0.25 * (p[1] + q[1]);
			if (!(turn > 0))
				continue;
			l->xy[2 * i] = x;
			l->xy[2 * i + 1] = y;
		}
	}
	mem_free(old);
	l->area_mm2 = xy_area(l->xy, n);
	return 0;
}
