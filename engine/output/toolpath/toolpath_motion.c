/* toolpath_motion.c - print-time estimate with a trapezoidal velocity
 * profile and jerk-limited junctions, and the layer-time slowdown (see
 * toolpath.h; the model is derived in docs/gcode.md, "time model").
 */
#include "engine/output/toolpath/toolpath.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/printer/printer.h"

#include <math.h>
#include <string.h>

struct tp_move {
	double len, ux, uy, uz; /* mm, unit direction */
	double v;               /* nominal feed, mm/s */
	int extrude;
};

void tp_motion_init(struct tp_motion *m, double accel_mm_s2, double jerk_mm_s)
{
	memset(m, 0, sizeof *m);
	m->accel_mm_s2 = accel_mm_s2;
	m->jerk_mm_s = jerk_mm_s;
}

void tp_motion_fini(struct tp_motion *m)
{
	mem_free(m->moves);
	memset(m, 0, sizeof *m);
}

int tp_motion_move(struct tp_motion *m, double dx, double dy, double dz, double v_mm_s,
		   int extrude, struct err *e)
{
	double len = sqrt(dx * dx + dy * dy + dz * dz);
	void *a = m->moves;

	if (!(len > 1e-9) || !(v_mm_s > 0))
		return 0;
	if (mem_grow(&a, &m->cap, m->n + 1, sizeof *m->moves))
		return ERR_SET(e, ERR_NOMEM, "out of memory estimating print time");
	m->moves = a;
	m->moves[m->n++] = (struct tp_move){len, dx / len, dy / len, dz / len, v_mm_s, extrude};
	return 0;
}

/* Time of one move of length L (mm) entered at v0, left at v1, cruising at
 * most at v, accelerating and braking at a: a trapezoid, or a triangle
 * when L is too short to reach v.  The passes guarantee
 * |v1^2 - v0^2| <= 2 a L, so the triangle's peak is >= max(v0, v1). */
static double trapezoid_s(double L, double v0, double v1, double v, double a)
{
	double d_acc, d_dec, vp;

	if (a <= 0)
		return L / v;
	d_acc = (v * v - v0 * v0) / (2 * a);
	d_dec = (v * v - v1 * v1) / (2 * a);
	if (d_acc + d_dec <= L)
		return (v - v0) / a + (v - v1) / a + (L - d_acc - d_dec) / v;
	vp = sqrt((2 * a * L + v0 * v0 + v1 * v1) / 2);
	return (vp - v0) / a + (vp - v1) / a;
}

void tp_motion_stop(struct tp_motion *m, double extra_s)
{
	size_t n = m->n;
	double a = m->accel_mm_s2, j = m->jerk_mm_s;
	double *vj;

	if (n) {
		/* vj[i]: speed at the start of move i; vj[n]: at the end. */
		vj = mem_alloc((n + 1) * sizeof *vj);
		if (!vj) {
			/* Degrade to cruise-speed time rather than fail the job. */
			for (size_t i = 0; i < n; i++) {
				double t = m->moves[i].len / m->moves[i].v;
				m->time_s += t;
				if (m->moves[i].extrude)
					m->extrude_s += t;
			}
			m->n = 0;
			m->time_s += extra_s;
			return;
		}
		/* From rest a printer may start at the jerk speed. */
		vj[0] = fmin(m->moves[0].v, j);
		vj[n] = fmin(m->moves[n - 1].v, j);
		for (size_t i = 1; i < n; i++) {
			const struct tp_move *p = &m->moves[i - 1], *q = &m->moves[i];
			double du = sqrt((q->ux - p->ux) * (q->ux - p->ux) +
					 (q->uy - p->uy) * (q->uy - p->uy) +
					 (q->uz - p->uz) * (q->uz - p->uz));
			/* |v q - v p| <= jerk at the corner */
			double vmax = du > 1e-12 ? j / du : INFINITY;
			vj[i] = fmin(fmin(p->v, q->v), vmax);
		}
		/* Backward: every move must be able to brake to its exit speed. */
		for (size_t i = n; i-- > 0;)
			vj[i] = fmin(vj[i], sqrt(vj[i + 1] * vj[i + 1] + 2 * a * m->moves[i].len));
		/* Forward: and reach it by accelerating from its entry speed. */
		for (size_t i = 0; i < n; i++)
			vj[i + 1] = fmin(vj[i + 1], sqrt(vj[i] * vj[i] + 2 * a * m->moves[i].len));
		for (size_t i = 0; i < n; i++) {
			const struct tp_move *mv = &m->moves[i];
			double t = trapezoid_s(mv->len, vj[i], vj[i + 1], mv->v, a);
			m->time_s += t;
			if (mv->extrude)
				m->extrude_s += t;
		}
		mem_free(vj);
	}
	m->n = 0;
	m->time_s += extra_s;
}

static int plan_time(const struct tp_plan *p, const struct fdm_printer *f, double *total_s,
		     double *extrude_s, struct err *e)
{
	struct tp_motion m;
	struct tp_cursor cu;
	struct tp_ev ev;
	struct pt2 at;
	double speed = f->print_speed_mm_s, retract_s = 0;
	int rc = 0;

	*total_s = *extrude_s = 0;
	if (!tp_plan_start(p, &at))
		return 0;
	if (f->retract_mm > 0)
		retract_s = f->retract_mm / f->retract_speed_mm_s;
	tp_motion_init(&m, f->accel_mm_s2, f->jerk_mm_s);
	tp_cursor_init(&cu, p, f->z_hop_mm > 0);
	while (!rc && tp_cursor_next(&cu, &ev)) {
		switch (ev.kind) {
		case TP_EV_RETRACT:
		case TP_EV_UNRETRACT:
			tp_motion_stop(&m, retract_s);
			break;
		case TP_EV_HOP_UP:
		case TP_EV_HOP_DOWN:
			rc = tp_motion_move(&m, 0, 0, ev.kind == TP_EV_HOP_UP ? f->z_hop_mm : -f->z_hop_mm,
					    f->z_speed_mm_s, 0, e);
			break;
		case TP_EV_TRAVEL:
		case TP_EV_EXTRUDE:
			rc = tp_motion_move(&m, geom_nm_to_mm(ev.to.x - at.x),
					    geom_nm_to_mm(ev.to.y - at.y), 0,
					    ev.kind == TP_EV_TRAVEL ? f->travel_speed_mm_s : speed,
					    ev.kind == TP_EV_EXTRUDE, e);
			at = ev.to;
			break;
		case TP_EV_FEATURE:
			speed = ev.speed_mm_s;
			break;
		}
	}
	tp_motion_stop(&m, 0);
	*total_s = m.time_s;
	*extrude_s = m.extrude_s;
	tp_motion_fini(&m);
	return rc;
}

int tp_plan_time(const struct tp_plan *p, const struct fdm_printer *f, double *total_s,
		 double *extrude_s, struct err *e)
{
	return plan_time(p, f, total_s, extrude_s, e);
}

int tp_plan_slowdown(struct tp_plan *p, const struct fdm_printer *f, double *time_s,
		     struct err *e)
{
	double t, te;
	int rc;

	p->speed_factor = 1.0;
	p->min_speed_mm_s = 0;
	rc = plan_time(p, f, &t, &te, e);
	if (rc)
		return rc;
	/* Stretch the extruding part by the missing time: speeds scale by
	 * te / (te + missing).  Acceleration makes time less than inversely
	 * proportional to speed, so correct the factor a few times; the floor
	 * may keep a small layer short of the target. */
	for (int it = 0; it < 4 && f->min_layer_time_s > 0 && te > 0 &&
			 t < 0.99 * f->min_layer_time_s;
	     it++) {
		double factor = p->speed_factor * te / (te + (f->min_layer_time_s - t));
		if (p->min_speed_mm_s > 0 && factor >= p->speed_factor * 0.999)
			break;
		p->speed_factor = factor;
		p->min_speed_mm_s = f->min_print_speed_mm_s;
		rc = plan_time(p, f, &t, &te, e);
		if (rc)
			return rc;
	}
	*time_s = t;
	return 0;
}
