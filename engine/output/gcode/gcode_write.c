/* gcode_write.c - the G-code writer (gcode_writer_ops, Marlin flavour):
 * layer window and parallel planning, start/end code, Cura-style header,
 * PrusaSlicer-style footer, thumbnails and metrics.  Design, header
 * strategy and guarantees: docs/gcode.md.
 *
 * Layers arrive in order.  Layer k is planned once layer k + top_layers
 * has arrived (its skins need the regions above it), on pipeline threads
 * that read only regions already received; planned layers are formatted
 * on the same threads and appended to the spool in order.  At close the
 * totals are known, and the file is streamed to the sink: header,
 * thumbnails, start code, the spooled body (with M73 progress), end code,
 * footer.
 */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/core/pipeline.h"
#include "engine/core/sink.h"
#include "engine/engine.h"
#include "engine/geom/raster.h"
#include "engine/output/gcode/gcode_int.h"
#include "engine/output/image/image.h"
#include "engine/output/writer.h"

#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

/* Body bytes kept in memory before the spool moves to a file. */
#define SPOOL_MEM_BYTES (1u << 20)

/* A received layer region, shared by the plans that need it; reference
 * counts change only on the writer's (submitting) thread.  Its exposures
 * (the parts the layers above and below do not cover) are computed once,
 * by whichever plan needs them first, under the region's lock. */
struct gc_region {
	struct paths region;
	enum layer_fill fill;
	int refs;
	pthread_mutex_t mu;
	int top_done, bottom_done;
	struct paths top, bottom;
};

struct gc_writer;

struct gc_item {
	struct gc_writer *w;
	int index;
	int known;             /* layers received when it was queued */
	double z_mm, h_mm;
	struct gc_region *self;
	struct gc_region **nb; /* below[0..nbelow) then above[0..nabove) */
	int nbelow, nabove;
	struct gc_layer_out out;
	double time_s;
	int thin_regions, thin_dropped;
	double thin_dropped_mm2;
};

struct gc_writer {
	struct out_info info;
	struct fdm_printer f;
	struct tp_config cfg;
	struct gc_params gp;
	struct sink *sink;
	struct pipeline *pl;
	struct gc_region **win;
	int win_n;
	int received, submitted, emitted;
	int written; /* layers in the spool: up to the last one with moves */
	double z_shift_mm; /* first_layer_mm - layer_mm */
	struct pt2 start_ref;
	struct gc_spool spool;
	char job_name[128], engine_name[64], printer_name[32];
	struct prime {
		int on;
		double x0, y0, x1, y1; /* mm */
		double ox, oy;         /* offset of the return stroke, mm */
	} prime;
	int failed;
	struct err fail_err;
	/* Running state of the emitted body (writer thread only). */
	double elapsed_s;
	struct pt2 pos;
	int have_pos, primed;
	double first_z_mm, last_z_mm;
	int64_t e_units[TP_ROLE_COUNT];
	double extrude_mm, travel_mm;
	long retractions;
	int64_t lo_x_um, lo_y_um, hi_x_um, hi_y_um;
	int has_extrusion;
	int thin_regions, thin_dropped;
	double thin_dropped_mm2;
};

static void region_unref(struct gc_region *r)
{
	if (r && --r->refs == 0) {
		paths_fini(&r->region);
		paths_fini(&r->top);
		paths_fini(&r->bottom);
		pthread_mutex_destroy(&r->mu);
		mem_free(r);
	}
}

/* Region of layer j as seen from item it (j within its window), or NULL
 * when no such layer exists. */
static struct gc_region *item_region(const struct gc_item *it, int j)
{
	if (j == it->index)
		return it->self;
	if (j < it->index)
		return it->index - j <= it->nbelow ? it->nb[it->index - j - 1] : NULL;
	return j - it->index <= it->nabove ? it->nb[it->nbelow + j - it->index - 1] : NULL;
}

/* r's exposure towards other (NULL: none there), computed once. */
static int exposure(struct gc_region *r, int *done, struct paths *out, const struct gc_region *other,
		    struct err *e)
{
	int rc = 0;

	pthread_mutex_lock(&r->mu);
	if (!*done) {
		rc = tp_exposure(&r->region, other ? &other->region : NULL, out, e);
		*done = rc == 0;
	}
	pthread_mutex_unlock(&r->mu);
	return rc;
}

static void item_free(struct gc_item *it)
{
	if (!it)
		return;
	region_unref(it->self);
	for (int i = 0; it->nb && i < it->nbelow + it->nabove; i++)
		region_unref(it->nb[i]);
	mem_free(it->nb);
	gc_layer_out_fini(&it->out);
	mem_free(it);
}

/* ---- small text helpers ------------------------------------------------- */

/* "%s" of a mm value at 1 um, into a small rotating buffer. */
static const char *mm(double v)
{
	static _Thread_local char b[8][32];
	static _Thread_local int k;
	char *p = b[k++ & 7];

	p[gc_fmt_mm(p, v)] = '\0';
	return p;
}

/* Copy s with control characters and ';' replaced (comment-safe). */
static void safe_copy(char *dst, size_t cap, const char *s)
{
	size_t n = 0;

	for (; s && *s && n + 1 < cap; s++)
		dst[n++] = ((unsigned char)*s < 0x20 || *s == 0x7f) ? '_' : *s;
	dst[n] = '\0';
}

/* PrusaSlicer's duration text: "1d 2h 3m 4s", leading zero units left out. */
static void duration(char *dst, size_t cap, double s)
{
	long t = (long)llround(s), d = t / 86400, h = t / 3600 % 24, m = t / 60 % 60;
	long sec = t % 60;

	if (d)
		snprintf(dst, cap, "%ldd %ldh %ldm %lds", d, h, m, sec);
	else if (h)
		snprintf(dst, cap, "%ldh %ldm %lds", h, m, sec);
	else if (m)
		snprintf(dst, cap, "%ldm %lds", m, sec);
	else
		snprintf(dst, cap, "%lds", sec);
}

/* ---- pipeline callbacks ------------------------------------------------ */

static int work(void *ctx, void *item, struct err *e)
{
	struct gc_writer *w = ctx;
	struct gc_item *it = item;
	const struct paths *top[TP_WINDOW_MAX], *bottom[TP_WINDOW_MAX];
	struct tp_layer_in in;
	struct tp_plan plan;
	int rc = 0;

	memset(&in, 0, sizeof in);
	in.index = it->index;
	in.count = w->info.layer_count;
	in.height_mm = it->h_mm;
	in.fill = it->self->fill;
	in.region = &it->self->region;
	/* Exposures of layers index .. index + T - 1 upwards and index ..
	 * index - B + 1 downwards, stopping at the part's ends. */
	for (int j = 0; !rc && j < w->f.top_layers && it->index + j < it->known; j++) {
		struct gc_region *r = item_region(it, it->index + j);
		rc = exposure(r, &r->top_done, &r->top,
			      it->index + j + 1 < it->known ? item_region(it, it->index + j + 1)
							    : NULL,
			      e);
		top[in.ntop++] = &r->top;
	}
	for (int j = 0; !rc && j < w->f.bottom_layers && it->index - j >= 0; j++) {
		struct gc_region *r = item_region(it, it->index - j);
		rc = exposure(r, &r->bottom_done, &r->bottom,
			      it->index - j - 1 >= 0 ? item_region(it, it->index - j - 1) : NULL, e);
		bottom[in.nbottom++] = &r->bottom;
	}
	in.top = top;
	in.bottom = bottom;
	in.start = w->start_ref;
	tp_plan_init(&plan);
	if (!rc)
		rc = tp_plan_layer(&w->cfg, &in, &plan, e);
	if (!rc)
		rc = tp_plan_slowdown(&plan, &w->f, &it->time_s, e);
	if (!rc)
		rc = gc_format_layer(&w->gp, &plan, it->z_mm, it->h_mm, &it->out, e);
	it->thin_regions = plan.thin_regions;
	it->thin_dropped = plan.thin_dropped;
	it->thin_dropped_mm2 = plan.thin_dropped_mm2;
	tp_plan_fini(&plan);
	if (rc)
		err_prefix(e, "layer %d", it->index);
	return rc;
}

/* Retract, move to the new layer's height and first point, prime: the
 * layer change (Z moves only while travelling).  Adds its time. */
static int layer_change(struct gc_writer *w, const struct gc_item *it, struct sink *b,
			struct err *e)
{
	const struct fdm_printer *f = &w->f;
	struct tp_motion m;
	double retract_s = f->retract_mm > 0 ? f->retract_mm / f->retract_speed_mm_s : 0;
	double hop = f->z_hop_mm > 0 ? f->z_hop_mm : 0, z = it->z_mm;
	struct pt2 to = it->out.first;
	int rc = 0;

	tp_motion_init(&m, f->accel_mm_s2, f->jerk_mm_s);
	if (w->primed && f->retract_mm > 0) {
		rc = sink_printf(b, e, "G1 E-%s F%.0f\n", mm(f->retract_mm), f->retract_speed_mm_s * 60);
		tp_motion_stop(&m, retract_s);
		w->retractions++;
	}
	if (!rc)
		rc = sink_printf(b, e, "G1 Z%s F%.0f\n", mm(z + hop), f->z_speed_mm_s * 60);
	if (!rc)
		rc = tp_motion_move(&m, 0, 0, z + hop - w->last_z_mm, f->z_speed_mm_s, 0, e);
	if (!rc) {
		struct pt2 from = w->have_pos ? w->pos : to;
		double dx = geom_nm_to_mm(to.x - from.x), dy = geom_nm_to_mm(to.y - from.y);
		rc = sink_printf(b, e, "G0 X%s Y%s F%.0f\n", mm(geom_nm_to_mm(to.x)),
			     mm(geom_nm_to_mm(to.y)), f->travel_speed_mm_s * 60);
		w->travel_mm += sqrt(dx * dx + dy * dy);
		if (!rc)
			rc = tp_motion_move(&m, dx, dy, 0, f->travel_speed_mm_s, 0, e);
	}
	if (!rc && hop > 0) {
		rc = sink_printf(b, e, "G1 Z%s F%.0f\n", mm(z), f->z_speed_mm_s * 60);
		if (!rc)
			rc = tp_motion_move(&m, 0, 0, -hop, f->z_speed_mm_s, 0, e);
	}
	if (!rc && f->retract_mm > 0) {
		rc = sink_printf(b, e, "G1 E%s F%.0f\n", mm(f->retract_mm), f->retract_speed_mm_s * 60);
		tp_motion_stop(&m, retract_s);
	}
	tp_motion_stop(&m, 0);
	w->elapsed_s += m.time_s;
	tp_motion_fini(&m);
	return rc;
}

/* Spool layer j's tags, its progress mark and the per-layer commands
 * that precede its moves (Klipper's layer counter, the fan from layer 1)
 * into b (reset first), then b itself. */
static int layer_head(struct gc_writer *w, int j, struct buf *b, struct err *e)
{
	double h = j == 0 ? w->f.first_layer_mm : w->info.layer_mm;
	double z = (j + 1) * w->info.layer_mm + w->z_shift_mm;
	struct sink bs;
	int rc;

	buf_reset(b);
	sink_init_buf(&bs, b);
	/* PrusaSlicer's before_layer_gcode (";BEFORE_LAYER_CHANGE", then
	 * ";[layer_z]"): Moonraker takes the largest such z as object_height. */
	rc = sink_printf(&bs, e, ";BEFORE_LAYER_CHANGE\n;%s\n;LAYER_CHANGE\n;Z:%s\n;HEIGHT:%s\n"
			     ";LAYER:%d\n",
		     mm(z), mm(z), mm(h), j);
	if (!rc)
		rc = gc_spool_text(&w->spool, b->data, b->len, e);
	if (!rc)
		rc = gc_spool_mark(&w->spool, w->elapsed_s, e);
	buf_reset(b);
	if (!rc && w->f.klipper)
		rc = sink_printf(&bs, e, "SET_PRINT_STATS_INFO CURRENT_LAYER=%d\n", j + 1);
	if (!rc && j == 1 && w->f.fan_pct > 0)
		rc = sink_printf(&bs, e, "M106 S%.0f\n", 255.0 * w->f.fan_pct / 100.0);
	return rc;
}

/* Layers without moves (nothing printable: a lattice above its last
 * strut, tips thinner than a bead) are held back and written only when a
 * later layer prints, so the file ends with the last layer that carries
 * material and its layer count says so.  Nothing of a held-back layer
 * depends on more than its index: no state is kept per layer. */
static int emit(void *ctx, void *item, struct err *e)
{
	struct gc_writer *w = ctx;
	struct gc_item *it = item;
	struct gc_layer_out *o = &it->out;
	struct buf b;
	struct sink bs;
	int rc = 0;

	buf_init(&b);
	sink_init_buf(&bs, &b);
	if (o->has_moves) {
		for (; !rc && w->written < it->index; w->written++) {
			rc = layer_head(w, w->written, &b, e);
			if (!rc)
				rc = gc_spool_text(&w->spool, b.data, b.len, e);
		}
		if (!rc)
			rc = layer_head(w, it->index, &b, e);
		if (!rc)
			rc = layer_change(w, it, &bs, e);
		if (!rc)
			rc = gc_spool_text(&w->spool, b.data, b.len, e);
		if (!rc)
			rc = gc_spool_text(&w->spool, o->text.data, o->text.len, e);
		if (!rc)
			w->written = it->index + 1;
	}
	if (!rc && w->sink->limit && w->spool.bytes > w->sink->limit)
		rc = ERR_SET(e, ERR_LIMIT, "G-code exceeds the output limit of %llu bytes",
			     (unsigned long long)w->sink->limit);
	if (!rc && o->has_extrusion) {
		int64_t bx = (int64_t)llround(w->f.bed_x_mm * 1000);
		int64_t by = (int64_t)llround(w->f.bed_y_mm * 1000);
		if (o->lo_x_um < 0 || o->lo_y_um < 0 || o->hi_x_um > bx || o->hi_y_um > by)
			rc = ERR_SET(e, ERR_FIT,
				     "layer %d extrudes outside the %g x %g mm bed (x %.3f..%.3f, "
				     "y %.3f..%.3f mm)",
				     it->index, w->f.bed_x_mm, w->f.bed_y_mm,
				     (double)o->lo_x_um / 1000, (double)o->hi_x_um / 1000,
				     (double)o->lo_y_um / 1000, (double)o->hi_y_um / 1000);
	}
	if (!rc && o->has_moves) {
		w->elapsed_s += it->time_s;
		w->pos = o->last;
		w->have_pos = w->primed = 1;
		w->last_z_mm = it->z_mm;
		for (int r = 0; r < TP_ROLE_COUNT; r++)
			w->e_units[r] += o->e_units[r];
		w->extrude_mm += o->extrude_mm;
		w->travel_mm += o->travel_mm;
		w->retractions += o->retractions;
	}
	if (!rc && o->has_extrusion) {
		if (!w->has_extrusion) {
			w->lo_x_um = o->lo_x_um;
			w->lo_y_um = o->lo_y_um;
			w->hi_x_um = o->hi_x_um;
			w->hi_y_um = o->hi_y_um;
			w->first_z_mm = it->z_mm;
			w->has_extrusion = 1;
		}
		if (o->lo_x_um < w->lo_x_um) w->lo_x_um = o->lo_x_um;
		if (o->lo_y_um < w->lo_y_um) w->lo_y_um = o->lo_y_um;
		if (o->hi_x_um > w->hi_x_um) w->hi_x_um = o->hi_x_um;
		if (o->hi_y_um > w->hi_y_um) w->hi_y_um = o->hi_y_um;
	}
	if (!rc) {
		w->thin_regions += it->thin_regions;
		w->thin_dropped += it->thin_dropped;
		w->thin_dropped_mm2 += it->thin_dropped_mm2;
		w->emitted++;
	}
	buf_fini(&b);
	item_free(it);
	return rc;
}

static void drop(void *ctx, void *item)
{
	(void)ctx;
	item_free(item);
}

static const struct pipeline_ops gc_pipeline_ops = {work, emit, drop};

/* ---- writer ops ---------------------------------------------------------- */

static void gc_free(void *state)
{
	struct gc_writer *w = state;

	if (!w)
		return;
	pipeline_free(w->pl);
	for (int i = 0; w->win && i < w->win_n; i++)
		region_unref(w->win[i]);
	mem_free(w->win);
	gc_spool_fini(&w->spool);
	mem_free(w);
}

/* A prime line along the front (or left) edge of the bed, clear of the
 * part and its skirt by 3 mm; none when the part reaches both edges.  The
 * body starts where it leaves the nozzle. */
static void prime_setup(struct gc_writer *w)
{
	const struct fdm_printer *f = &w->f;
	double clear = f->skirt_distance_mm + (f->skirt_loops + 1) * f->line_width_mm + 3;
	double lo_x = w->info.part_bbox.lo.x - clear, lo_y = w->info.part_bbox.lo.y - clear;
	double sp = geom_nm_to_mm(tp_spacing_nm(w->cfg.width_nm, f->first_layer_mm));
	double lx = f->bed_x_mm - 20 < 100 ? f->bed_x_mm - 20 : 100;
	double ly = f->bed_y_mm - 20 < 100 ? f->bed_y_mm - 20 : 100;
	struct prime *p = &w->prime;

	memset(p, 0, sizeof *p);
	if (lx >= 20 && lo_y > 3 + sp + f->line_width_mm)
		*p = (struct prime){1, 10, 3, 10 + lx, 3, 0, sp};
	else if (ly >= 20 && lo_x > 3 + sp + f->line_width_mm)
		*p = (struct prime){1, 3, 10, 3, 10 + ly, sp, 0};
	if (p->on) {
		w->pos = (struct pt2){geom_mm_to_nm(p->x0 + p->ox), geom_mm_to_nm(p->y0 + p->oy)};
		w->have_pos = w->primed = 1;
		w->last_z_mm = f->first_layer_mm;
	}
}

static int gc_open(const struct out_info *info, struct sink *s, void **state, struct err *e)
{
	struct gc_writer *w;
	int threads, rc;

	if (!info->printer || info->printer->kind != PRINTER_FDM)
		return ERR_FIELD(e, "printer", "G-code needs an FDM printer profile, not '%s'",
				 info->printer ? info->printer->name : "");
	w = mem_calloc(1, sizeof *w);
	if (!w)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the G-code writer");
	w->info = *info;
	w->f = info->printer->fdm;
	safe_copy(w->printer_name, sizeof w->printer_name, info->printer->name);
	w->info.printer = NULL; /* use w->f */
	w->info.job_name = w->info.engine_name = NULL;
	safe_copy(w->job_name, sizeof w->job_name, info->job_name ? info->job_name : "part");
	safe_copy(w->engine_name, sizeof w->engine_name,
		  info->engine_name ? info->engine_name : "");
	w->sink = s;
	gc_spool_init(&w->spool, info->scratch_dir, SPOOL_MEM_BYTES);
	rc = tp_config_init(&w->cfg, &w->f, info->layer_mm, e);
	if (rc)
		goto fail;
	w->gp.f = &w->f;
	w->gp.filament_area_mm2 = M_PI * 0.25 * w->f.filament_mm * w->f.filament_mm;
	w->gp.hop = w->f.z_hop_mm > 0;
	w->z_shift_mm = w->f.first_layer_mm - info->layer_mm;
	w->start_ref = (struct pt2){geom_mm_to_nm(info->part_bbox.lo.x),
				    geom_mm_to_nm(info->part_bbox.lo.y)};
	prime_setup(w);
	w->win_n = w->f.top_layers + w->f.bottom_layers + 1;
	w->win = mem_calloc((size_t)w->win_n, sizeof *w->win);
	if (!w->win) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory opening the G-code writer");
		goto fail;
	}
	threads = info->threads > 1 ? info->threads : 0;
	rc = pipeline_new(&gc_pipeline_ops, w, threads, threads ? 2 * threads + 2 : 1, &w->pl, e);
	if (rc)
		goto fail;
	*state = w;
	return 0;
fail:
	gc_free(w);
	return rc;
}

/* Queue the plan of layer j with the neighbours received so far. */
static int submit(struct gc_writer *w, int j, struct err *e)
{
	struct gc_item *it = mem_calloc(1, sizeof *it);
	int B = w->f.bottom_layers, T = w->f.top_layers, n;

	if (!it)
		return ERR_SET(e, ERR_NOMEM, "out of memory queueing layer %d", j);
	it->w = w;
	it->index = j;
	gc_layer_out_init(&it->out);
	it->nbelow = j < B ? j : B;
	it->nabove = w->received - 1 - j < T ? w->received - 1 - j : T;
	n = it->nbelow + it->nabove;
	it->known = w->received;
	it->nb = mem_calloc((size_t)(n ? n : 1), sizeof *it->nb);
	if (!it->nb) {
		it->nbelow = it->nabove = 0;
		item_free(it);
		return ERR_SET(e, ERR_NOMEM, "out of memory queueing layer %d", j);
	}
	it->self = w->win[j % w->win_n];
	it->self->refs++;
	for (int i = 0; i < it->nbelow; i++)
		it->nb[i] = w->win[(j - 1 - i) % w->win_n];
	for (int i = 0; i < it->nabove; i++)
		it->nb[it->nbelow + i] = w->win[(j + 1 + i) % w->win_n];
	for (int i = 0; i < n; i++)
		it->nb[i]->refs++;
	it->h_mm = j == 0 ? w->f.first_layer_mm : w->info.layer_mm;
	it->z_mm = (j + 1) * w->info.layer_mm + w->z_shift_mm;
	w->submitted = j + 1;
	return pipeline_submit(w->pl, it, e);
}

static int fail(struct gc_writer *w, int rc, const struct err *e)
{
	if (!w->failed && rc) {
		w->failed = rc;
		if (e)
			w->fail_err = *e;
	}
	return rc;
}

static int gc_layer(void *state, struct layer *ly, struct err *e)
{
	struct gc_writer *w = state;
	struct gc_region *r;
	int slot, rc;

	if (w->failed) {
		if (e)
			*e = w->fail_err;
		return w->failed;
	}
	if (ly->index != w->received)
		return fail(w, ERR_SET(e, ERR_INTERNAL, "G-code writer got layer %d, expected %d",
				       ly->index, w->received),
			    e);
	if (ly->raster) {
		raster_free(ly->raster);
		ly->raster = NULL;
	}
	r = mem_calloc(1, sizeof *r);
	if (!r)
		return fail(w, ERR_SET(e, ERR_NOMEM, "out of memory taking layer %d", ly->index), e);
	r->region = ly->region;
	paths_init(&ly->region);
	paths_init(&r->top);
	paths_init(&r->bottom);
	pthread_mutex_init(&r->mu, NULL);
	r->fill = ly->fill;
	r->refs = 1;
	rc = tp_region_clean(&w->cfg, &r->region, e);
	if (rc) {
		region_unref(r);
		return fail(w, rc, e);
	}
	slot = ly->index % w->win_n;
	region_unref(w->win[slot]);
	w->win[slot] = r;
	w->received++;
	if (w->received - 1 - w->f.top_layers >= 0) {
		rc = submit(w, w->received - 1 - w->f.top_layers, e);
		if (rc)
			return fail(w, rc, e);
	}
	return 0;
}

/* ---- start, end, header, footer ------------------------------------------ */


static int start_code(struct gc_writer *w, struct sink *b, int64_t *prime_units, double *time_s,
		      struct err *e)
{
	const struct fdm_printer *f = &w->f;
	const struct prime p = w->prime;
	double h = f->first_layer_mm;
	int rc;

	*prime_units = 0;
	*time_s = 0;
	rc = sink_printf(b, e, "M107\n");
	if (!rc && f->bed_c > 0)
		rc = sink_printf(b, e, "M140 S%.0f ; bed\n", f->bed_c);
	if (!rc)
		rc = sink_printf(b, e, "M104 S%.0f ; nozzle\n", f->nozzle_c);
	if (!rc && f->bed_c > 0)
		rc = sink_printf(b, e, "M190 S%.0f ; wait for the bed\n", f->bed_c);
	if (!rc)
		rc = sink_printf(b, e, "M109 S%.0f ; wait for the nozzle\n", f->nozzle_c);
	if (!rc && f->klipper)
		rc = sink_printf(b, e, "SET_PRINT_STATS_INFO TOTAL_LAYER=%d\n", w->written);
	if (!rc)
		rc = sink_printf(b, e,
			     "G28 ; home\nG90 ; absolute XYZ\nM83 ; relative E\nG92 E0\n");
	if (!rc && p.on) {
		/* Two strokes of the first-layer bead (Slic3r flow), out and back
		 * one spacing over. */
		double area = tp_bead_area_mm2(f->line_width_mm, h);
		double len = hypot(p.x1 - p.x0, p.y1 - p.y0);
		double ox = p.ox, oy = p.oy;
		int64_t units = (int64_t)llround(len * area / w->gp.filament_area_mm2 * GC_E_PER_MM);
		char eb[32];
		struct tp_motion m;
		eb[gc_fmt_fixed(eb, units, 5)] = '\0';
		rc = sink_printf(b, e, ";prime line\nG1 Z2 F%.0f\nG0 X%s Y%s F%.0f\nG1 Z%s F%.0f\n",
			     f->z_speed_mm_s * 60, mm(p.x0), mm(p.y0), f->travel_speed_mm_s * 60,
			     mm(h), f->z_speed_mm_s * 60);
		if (!rc)
			rc = sink_printf(b, e, "G1 X%s Y%s E%s F%.0f\n", mm(p.x1), mm(p.y1), eb,
				     f->first_layer_speed_mm_s * 60);
		if (!rc)
			rc = sink_printf(b, e, "G1 X%s Y%s F%.0f\nG1 X%s Y%s E%s F%.0f\n",
				     mm(p.x1 + ox), mm(p.y1 + oy), f->first_layer_speed_mm_s * 60,
				     mm(p.x0 + ox), mm(p.y0 + oy), eb,
				     f->first_layer_speed_mm_s * 60);
		*prime_units = 2 * units;
		tp_motion_init(&m, f->accel_mm_s2, f->jerk_mm_s);
		if (!rc)
			rc = tp_motion_move(&m, p.x1 - p.x0, p.y1 - p.y0, 0, f->first_layer_speed_mm_s,
					    1, e);
		if (!rc)
			rc = tp_motion_move(&m, ox, oy, 0, f->first_layer_speed_mm_s, 0, e);
		if (!rc)
			rc = tp_motion_move(&m, p.x0 - p.x1, p.y0 - p.y1, 0,
					    f->first_layer_speed_mm_s, 1, e);
		tp_motion_stop(&m, 0);
		*time_s = m.time_s;
		tp_motion_fini(&m);
	}
	return rc;
}

static int end_code(struct gc_writer *w, struct sink *b, double *time_s, struct err *e)
{
	const struct fdm_printer *f = &w->f;
	double z = w->last_z_mm + 10 < f->max_z_mm ? w->last_z_mm + 10 : f->max_z_mm;
	int rc = 0;

	*time_s = 0;
	rc = sink_printf(b, e, ";end\n");
	if (!rc && w->primed && f->retract_mm > 0) {
		rc = sink_printf(b, e, "G1 E-%s F%.0f\n", mm(f->retract_mm), f->retract_speed_mm_s * 60);
		*time_s += f->retract_mm / f->retract_speed_mm_s;
		w->retractions++;
	}
	if (!rc && z > w->last_z_mm) {
		rc = sink_printf(b, e, "G1 Z%s F%.0f ; lift\n", mm(z), f->z_speed_mm_s * 60);
		*time_s += (z - w->last_z_mm) / f->z_speed_mm_s;
	}
	if (!rc) {
		double dx = w->have_pos ? geom_nm_to_mm(w->pos.x) : 0;
		double dy = w->have_pos ? f->bed_y_mm - geom_nm_to_mm(w->pos.y) : 0;
		rc = sink_printf(b, e, "G0 X0 Y%s F%.0f ; present the part\n", mm(f->bed_y_mm),
			     f->travel_speed_mm_s * 60);
		w->travel_mm += hypot(dx, dy);
		*time_s += hypot(dx, dy) / f->travel_speed_mm_s;
	}
	if (!rc)
		rc = sink_printf(b, e, "M107 ; fan off\nM104 S0 ; nozzle off\nM140 S0 ; bed off\n"
				   "M84 ; motors off\nM73 P100 R0\n");
	return rc;
}

static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/* "; thumbnail begin WxH LEN" + base64 in 78-character comment lines. */
static int thumbnail_block(const struct buf *png, int wpx, int hpx, struct sink *out,
			   struct err *e)
{
	size_t n = png->len, len = 4 * ((n + 2) / 3), col = 0;
	int rc = sink_printf(out, e, ";\n; thumbnail begin %dx%d %zu\n", wpx, hpx, len);

	for (size_t i = 0; !rc && i < n; i += 3) {
		unsigned v = (unsigned)png->data[i] << 16;
		char q[4];
		if (i + 1 < n)
			v |= (unsigned)png->data[i + 1] << 8;
		if (i + 2 < n)
			v |= png->data[i + 2];
		q[0] = b64[v >> 18 & 63];
		q[1] = b64[v >> 12 & 63];
		q[2] = i + 1 < n ? b64[v >> 6 & 63] : '=';
		q[3] = i + 2 < n ? b64[v & 63] : '=';
		if (col == 0)
			rc = sink_write(out, "; ", 2, e);
		if (!rc)
			rc = sink_write(out, q, 4, e);
		col += 4;
		if (!rc && (col >= 76 || i + 3 >= n)) {
			rc = sink_write(out, "\n", 1, e);
			col = 0;
		}
	}
	return rc ? rc : sink_printf(out, e, "; thumbnail end\n;\n");
}

/* Thumbnails for host UIs (Moonraker/Mainsail read 32x32 and 300x300).
 * Rendering problems other than memory leave the thumbnail out. */
static int thumbnails(const struct gc_writer *w, struct sink *out, int *count, struct err *e)
{
	static const int sizes[][2] = {{32, 32}, {300, 300}};
	struct buf png;
	int rc = 0;

	*count = 0;
	if (!w->info.mesh)
		return 0;
	buf_init(&png);
	for (size_t i = 0; !rc && i < sizeof sizes / sizeof sizes[0]; i++) {
		struct err te;
		err_clear(&te);
		buf_reset(&png);
		rc = thumbnail_png_from_mesh(w->info.mesh, sizes[i][0], sizes[i][1], &png, &te);
		if (rc == ERR_NOMEM) {
			if (e)
				*e = te;
			break;
		}
		if (rc) {
			rc = 0;
			continue;
		}
		rc = thumbnail_block(&png, sizes[i][0], sizes[i][1], out, e);
		if (!rc)
			++*count;
	}
	buf_fini(&png);
	return rc;
}

static int header(struct gc_writer *w, struct sink *b, double total_s, double filament_mm,
		  struct err *e)
{
	struct tm tm;
	time_t t = w->info.created;
	char when[64];
	int rc;

	gmtime_r(&t, &tm);
	strftime(when, sizeof when, "%Y-%m-%d at %H:%M:%S UTC", &tm);
	rc = sink_printf(b, e, "; generated by infilld %s on %s\n", INFILLD_VERSION, when);
	if (!rc)
		rc = sink_printf(b, e, ";FLAVOR:Marlin\n;TIME:%.0f\n;Filament used: %.5fm\n"
				   ";Layer height: %s\n",
			     total_s, filament_mm / 1000.0, mm(w->info.layer_mm));
	if (!rc)
		rc = sink_printf(b, e, ";MINX:%s\n;MINY:%s\n;MINZ:%s\n;MAXX:%s\n;MAXY:%s\n;MAXZ:%s\n",
			     mm((double)w->lo_x_um / 1000), mm((double)w->lo_y_um / 1000),
			     mm(w->first_z_mm), mm((double)w->hi_x_um / 1000),
			     mm((double)w->hi_y_um / 1000), mm(w->last_z_mm));
	if (!rc)
		rc = sink_printf(b, e, ";LAYER_COUNT:%d\n;TARGET_MACHINE.NAME:%s\n", w->written,
			     w->printer_name);
	if (!rc)
		rc = sink_printf(b, e, "; job = %s\n; engine = %s\n", w->job_name,
			     w->engine_name[0] ? w->engine_name : "solid");
	return rc;
}

static int footer(struct gc_writer *w, struct sink *b, double total_s, double filament_mm,
		  struct err *e)
{
	const struct fdm_printer *f = &w->f;
	double cm3 = filament_mm * w->gp.filament_area_mm2 / 1000.0;
	char dur[64];
	int rc;

	duration(dur, sizeof dur, total_s);
	rc = sink_printf(b, e,
		     "; filament used [mm] = %.2f\n; filament used [cm3] = %.2f\n"
		     "; filament used [g] = %.2f\n; total filament used [g] = %.2f\n",
		     filament_mm, cm3, cm3 * f->filament_density_g_cm3,
		     cm3 * f->filament_density_g_cm3);
	if (!rc)
		rc = sink_printf(b, e,
			     "; estimated printing time (normal mode) = %s\n"
			     "; total layers count = %d\n",
			     dur, w->written);
	if (!rc)
		rc = sink_printf(b, e,
			     "; layer_height = %s\n; first_layer_height = %s\n"
			     "; nozzle_diameter = %s\n; filament_diameter = %s\n"
			     "; filament_type = %s\n; filament_density = %g\n",
			     mm(w->info.layer_mm), mm(f->first_layer_mm), mm(f->nozzle_mm),
			     mm(f->filament_mm), f->filament_type, f->filament_density_g_cm3);
	if (!rc)
		rc = sink_printf(b, e,
			     "; extrusion_width = %s\n; perimeters = %d\n; fill_density = %g%%\n"
			     "; top_solid_layers = %d\n; bottom_solid_layers = %d\n"
			     "; temperature = %.0f\n; bed_temperature = %.0f\n"
			     "; first_layer_temperature = %.0f\n; first_layer_bed_temperature = %.0f\n"
			     "; chamber_temperature = 0\n",
			     mm(f->line_width_mm), f->perimeters, f->infill_pct, f->top_layers,
			     f->bottom_layers, f->nozzle_c, f->bed_c, f->nozzle_c, f->bed_c);
	/* One extruder, one filament: PrusaSlicer's multi-material keys with
	 * their single-extruder values; the colour is the thumbnails'. */
	if (!rc)
		rc = sink_printf(b, e,
			     "; filament_settings_id = \"Generic %s\"\n; filament_colour = %s\n"
			     "; extruder_colour = \"\"\n; single_extruder_multi_material = 0\n"
			     "; total toolchanges = 0\n; printer_model = %s\n"
			     "; printer_variant = %s\n",
			     f->filament_type, THUMBNAIL_COLOUR_HEX, w->printer_name, mm(f->nozzle_mm));
	return rc;
}

static int put_buf(struct sink *s, const struct buf *b, struct err *e)
{
	return sink_write(s, b->data, b->len, e);
}

static int metrics_out(struct gc_writer *w, struct metrics *m, double total_s,
		       int64_t prime_units, uint64_t bytes, int nthumbs, struct err *e)
{
	double area = w->gp.filament_area_mm2;
	int64_t units = prime_units, part_units = 0;
	double filament_mm;
	int rc = 0;
	char key[96];

	for (int r = 0; r < TP_ROLE_COUNT; r++) {
		units += w->e_units[r];
		if (r != TP_ROLE_SKIRT)
			part_units += w->e_units[r];
	}
	filament_mm = (double)units / GC_E_PER_MM;
	rc |= metrics_num(m, "material_volume_mm3", filament_mm * area);
	rc |= metrics_num(m, "gcode.filament_mm", filament_mm);
	rc |= metrics_num(m, "gcode.filament_cm3", filament_mm * area / 1000);
	rc |= metrics_num(m, "gcode.filament_g", filament_mm * area / 1000 *
						     w->f.filament_density_g_cm3);
	rc |= metrics_num(m, "gcode.print_time_s", total_s);
	rc |= metrics_int(m, "gcode.layers", w->written);
	rc |= metrics_num(m, "gcode.part_material_mm3", (double)part_units / GC_E_PER_MM * area);
	rc |= metrics_num(m, "gcode.extrusion_mm", w->extrude_mm);
	rc |= metrics_num(m, "gcode.travel_mm", w->travel_mm);
	rc |= metrics_int(m, "gcode.retractions", w->retractions);
	rc |= metrics_int(m, "gcode.thin_regions", w->thin_regions);
	rc |= metrics_int(m, "gcode.thin_dropped", w->thin_dropped);
	rc |= metrics_num(m, "gcode.thin_dropped_mm2", w->thin_dropped_mm2);
	rc |= metrics_int(m, "gcode.thumbnails", nthumbs);
	rc |= metrics_int(m, "gcode.bytes", (long long)bytes);
	for (int r = 0; r < TP_ROLE_COUNT; r++) {
		snprintf(key, sizeof key, "gcode.volume_mm3.%s", tp_role_key((enum tp_role)r));
		rc |= metrics_num(m, key, (double)w->e_units[r] / GC_E_PER_MM * area);
	}
	return rc ? ERR_SET(e, ERR_NOMEM, "out of memory recording G-code metrics") : 0;
}

static int gc_close(void *state, struct metrics *m, struct err *e)
{
	struct gc_writer *w = state;
	struct buf head, start, end;
	struct sink hs, ss, es;
	int64_t prime_units = 0, units = 0;
	double start_s = 0, end_s = 0, total_s, filament_mm;
	uint64_t bytes0 = w->sink->bytes;
	int rc = 0, nthumbs = 0;

	if (w->failed) {
		if (e)
			*e = w->fail_err;
		return w->failed;
	}
	buf_init(&head);
	buf_init(&start);
	buf_init(&end);
	sink_init_buf(&hs, &head);
	sink_init_buf(&ss, &start);
	sink_init_buf(&es, &end);
	/* Plan the last top_layers layers (nothing above them). */
	for (int j = w->submitted; !rc && j < w->received; j++)
		rc = submit(w, j, e);
	if (!rc)
		rc = pipeline_finish(w->pl, e);
	if (!rc && w->written == 0)
		rc = ERR_SET(e, ERR_GEOMETRY,
			     "none of the %d layers has anything printable at a %g mm line width",
			     w->received, w->f.line_width_mm);
	/* Every total is known now: header, start, body, end, footer. */
	if (!rc)
		rc = start_code(w, &ss, &prime_units, &start_s, e);
	if (!rc)
		rc = end_code(w, &es, &end_s, e);
	for (int r = 0; r < TP_ROLE_COUNT; r++)
		units += w->e_units[r];
	units += prime_units;
	filament_mm = (double)units / GC_E_PER_MM;
	total_s = start_s + w->elapsed_s + end_s;
	if (!rc)
		rc = header(w, &hs, total_s, filament_mm, e);
	if (!rc)
		rc = thumbnails(w, &hs, &nthumbs, e);
	if (!rc) {
		char line[32];
		rc = sink_write(&hs, line, gc_m73(line, 0, total_s), e);
	}
	if (!rc)
		rc = put_buf(w->sink, &head, e);
	if (!rc)
		rc = put_buf(w->sink, &start, e);
	if (!rc)
		rc = gc_spool_replay(&w->spool, w->sink, start_s, total_s, e);
	if (!rc)
		rc = put_buf(w->sink, &end, e);
	buf_reset(&head);
	if (!rc)
		rc = footer(w, &hs, total_s, filament_mm, e);
	if (!rc)
		rc = put_buf(w->sink, &head, e);
	if (!rc && m)
		rc = metrics_out(w, m, total_s, prime_units, w->sink->bytes - bytes0,
				 nthumbs, e);
	buf_fini(&head);
	buf_fini(&start);
	buf_fini(&end);
	return fail(w, rc, e);
}

const struct writer_ops gcode_writer_ops = {
	.name = "gcode",
	.wants_raster = 0,
	.wants_region = 1,
	.open = gc_open,
	.raster_get = NULL,
	.raster_map = NULL,
	.layer = gc_layer,
	.close = gc_close,
	.free_state = gc_free,
};
