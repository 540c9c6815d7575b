/* gcode_format.c - a planned layer as G-code text: moves, feature tags,
 * extrusion amounts (see gcode_int.h; flow maths in docs/gcode.md).
 *
 * The hot path of the writer: numbers are formatted by hand from
 * integers (coordinates in um, E in 1e-5 mm) rather than with printf,
 * and lines are written straight into the layer's buffer.  Extrusion
 * lengths are measured between the printed (rounded) coordinates, so a
 * reader recomputing E from the text finds exactly what we meant.
 */
#include "engine/output/gcode/gcode_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

size_t gc_fmt_fixed(char *dst, int64_t v, int dec)
{
	char tmp[24];
	size_t n = 0, k = 0;
	uint64_t u;
	int neg = v < 0, d = 0;

	u = neg ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
	/* digits, least significant first */
	do {
		tmp[n++] = (char)('0' + u % 10);
		u /= 10;
		d++;
	} while (u || d <= dec);
	/* trailing zeros of the fraction */
	{
		size_t z = 0;
		while ((int)z < dec && tmp[z] == '0')
			z++;
		if (neg)
			dst[k++] = '-';
		for (size_t i = n; i-- > (size_t)dec;)
			dst[k++] = tmp[i];
		if ((int)z < dec) {
			dst[k++] = '.';
			for (size_t i = (size_t)dec; i-- > z;)
				dst[k++] = tmp[i];
		}
	}
	return k;
}

size_t gc_fmt_mm(char *dst, double mm)
{
	return gc_fmt_fixed(dst, (int64_t)llround(mm * 1000.0), 3);
}

void gc_layer_out_init(struct gc_layer_out *o)
{
	memset(o, 0, sizeof *o);
	buf_init(&o->text);
}

void gc_layer_out_fini(struct gc_layer_out *o)
{
	buf_fini(&o->text);
	memset(o, 0, sizeof *o);
}

/* Make room for n more bytes; returns the write position or NULL. */
static char *room(struct buf *b, size_t n)
{
	void *d = b->data;

	if (mem_grow(&d, &b->cap, b->len + n, 1))
		return NULL;
	b->data = d;
	return (char *)b->data + b->len;
}

static char *put_str(char *p, const char *s)
{
	size_t n = strlen(s);

	memcpy(p, s, n);
	return p + n;
}

static int64_t um_of(int64_t nm)
{
	return nm >= 0 ? (nm + 500) / 1000 : -((-nm + 500) / 1000);
}

struct fmt {
	const struct gc_params *g;
	struct gc_layer_out *o;
	int64_t x_um, y_um; /* printed position */
	int64_t f;          /* modal feed, mm/min; -1 unknown */
	int role;
	int64_t width_um;
	int64_t feed;       /* feed of the current feature */
	double e_per_mm_um; /* filament mm per mm of path, current width */
	double h_mm;
	double e_exact;     /* exact filament so far, units */
	int64_t e_done;     /* printed so far, units */
};

/* E per mm for the width as printed in ;WIDTH: (1 um), so readers can
 * reproduce it exactly. */
static void set_width(struct fmt *s, int64_t width_nm)
{
	double w;

	s->width_um = um_of(width_nm);
	w = (double)s->width_um / 1000.0;
	s->e_per_mm_um = tp_bead_area_mm2(w, s->h_mm) / s->g->filament_area_mm2 *
			 (double)GC_E_PER_MM;
}

int gc_format_layer(const struct gc_params *g, const struct tp_plan *p, double z_mm, double h_mm,
		    struct gc_layer_out *o, struct err *e)
{
	const struct fdm_printer *f = g->f;
	struct tp_cursor cu;
	struct tp_ev ev;
	struct fmt s;
	struct pt2 start;
	int64_t rf = (int64_t)llround(f->retract_speed_mm_s * 60);
	int64_t zf = (int64_t)llround(f->z_speed_mm_s * 60);
	int64_t tf = (int64_t)llround(f->travel_speed_mm_s * 60);
	int64_t r_units = (int64_t)llround(f->retract_mm * GC_E_PER_MM);
	int64_t z_um = (int64_t)llround(z_mm * 1000), hop_um = (int64_t)llround(f->z_hop_mm * 1000);

	if (!tp_plan_start(p, &start))
		return 0;
	memset(&s, 0, sizeof s);
	s.g = g;
	s.o = o;
	s.f = -1;
	s.role = -1;
	s.width_um = -1;
	s.h_mm = h_mm;
	s.x_um = um_of(start.x);
	s.y_um = um_of(start.y);
	o->first = start;
	o->has_moves = 1;
	tp_plan_end(p, &o->last);
	tp_cursor_init(&cu, p, g->hop);
	while (tp_cursor_next(&cu, &ev)) {
		char *q = room(&o->text, 160), *q0 = q;
		if (!q)
			return ERR_SET(e, ERR_NOMEM, "out of memory formatting G-code");
		switch (ev.kind) {
		case TP_EV_RETRACT:
		case TP_EV_UNRETRACT:
			if (r_units <= 0)
				break;
			q = put_str(q, "G1 E");
			q += gc_fmt_fixed(q, ev.kind == TP_EV_RETRACT ? -r_units : r_units, 5);
			q = put_str(q, " F");
			q += gc_fmt_fixed(q, rf, 0);
			*q++ = '\n';
			s.f = rf;
			if (ev.kind == TP_EV_RETRACT)
				o->retractions++;
			break;
		case TP_EV_HOP_UP:
		case TP_EV_HOP_DOWN:
			q = put_str(q, "G1 Z");
			q += gc_fmt_fixed(q, ev.kind == TP_EV_HOP_UP ? z_um + hop_um : z_um, 3);
			q = put_str(q, " F");
			q += gc_fmt_fixed(q, zf, 0);
			*q++ = '\n';
			s.f = zf;
			break;
		case TP_EV_TRAVEL: {
			int64_t xu = um_of(ev.to.x), yu = um_of(ev.to.y);
			if (xu == s.x_um && yu == s.y_um)
				break;
			o->travel_mm += hypot((double)(xu - s.x_um), (double)(yu - s.y_um)) / 1000.0;
			q = put_str(q, "G0 X");
			q += gc_fmt_fixed(q, xu, 3);
			q = put_str(q, " Y");
			q += gc_fmt_fixed(q, yu, 3);
			if (s.f != tf) {
				q = put_str(q, " F");
				q += gc_fmt_fixed(q, tf, 0);
				s.f = tf;
			}
			*q++ = '\n';
			s.x_um = xu;
			s.y_um = yu;
			break;
		}
		case TP_EV_FEATURE:
			if ((int)ev.role != s.role) {
				q = put_str(q, ";TYPE:");
				q = put_str(q, tp_role_name(ev.role));
				*q++ = '\n';
				s.role = (int)ev.role;
			}
			s.feed = (int64_t)llround(ev.speed_mm_s * 60);
			if (s.feed < 1)
				s.feed = 1;
			break;
		case TP_EV_EXTRUDE: {
			int64_t xu = um_of(ev.to.x), yu = um_of(ev.to.y), de;
			double len_mm;
			if (xu == s.x_um && yu == s.y_um)
				break;
			if (um_of(ev.width_nm) != s.width_um) {
				set_width(&s, ev.width_nm);
				q = put_str(q, ";WIDTH:");
				q += gc_fmt_fixed(q, s.width_um, 3);
				*q++ = '\n';
			}
			len_mm = hypot((double)(xu - s.x_um), (double)(yu - s.y_um)) / 1000.0;
			s.e_exact += len_mm * s.e_per_mm_um;
			de = (int64_t)llround(s.e_exact) - s.e_done;
			if (de <= 0) {
				/* Shorter than the E resolution: merged into the next
				 * segment (the nozzle stays, its length carries over). */
				s.e_exact -= len_mm * s.e_per_mm_um;
				break;
			}
			s.e_done += de;
			o->e_units[s.role] += de;
			o->extrude_mm += len_mm;
			if (!o->has_extrusion) {
				o->lo_x_um = o->hi_x_um = s.x_um;
				o->lo_y_um = o->hi_y_um = s.y_um;
				o->has_extrusion = 1;
			}
#define GROW(lo, hi, v) do { if ((v) < (lo)) (lo) = (v); if ((v) > (hi)) (hi) = (v); } while (0)
			GROW(o->lo_x_um, o->hi_x_um, s.x_um);
			GROW(o->lo_y_um, o->hi_y_um, s.y_um);
			GROW(o->lo_x_um, o->hi_x_um, xu);
			GROW(o->lo_y_um, o->hi_y_um, yu);
#undef GROW
			q = put_str(q, "G1 X");
			q += gc_fmt_fixed(q, xu, 3);
			q = put_str(q, " Y");
			q += gc_fmt_fixed(q, yu, 3);
			q = put_str(q, " E");
			q += gc_fmt_fixed(q, de, 5);
			if (s.f != s.feed) {
				q = put_str(q, " F");
				q += gc_fmt_fixed(q, s.feed, 0);
				s.f = s.feed;
			}
			*q++ = '\n';
			s.x_um = xu;
			s.y_um = yu;
			break;
		}
		}
		o->text.len += (size_t)(q - q0);
	}
	return 0;
}
