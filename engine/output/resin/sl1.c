/* sl1.c - resin archive writers: sl1_writer_ops (SL1/SL1S .sl1/.sl1s)
 * and zip_writer_ops (generic 1.png ... N.png stack).
 *
 * Layers flow through an ordered pipeline (core/pipeline.h): worker
 * threads rasterise the region (unless the engine rendered pixels),
 * encode the PNG and measure coverage; the caller's thread appends the
 * entries to the zip stream in order.  Layer images come from a bounded
 * pool, so memory is a few images whatever the layer count.  Formats and
 * records: docs/formats.md.
 */
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/metrics.h"
#include "engine/core/pipeline.h"
#include "engine/core/sink.h"
#include "engine/output/image/image.h"
#include "engine/output/printer/printer.h"
#include "engine/output/resin/resin_int.h"
#include "engine/output/resin/resin.h"
#include "engine/output/writer.h"
#include "engine/slice/slice.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#define SL1_MAX_THREADS 64

/* PrusaSlicer's SL1/SL1S printer profiles: thumbnails = 400x400,800x480. */
static const int thumb_sizes[][2] = {{400, 400}, {800, 480}};

enum sl1_kind { KIND_SL1, KIND_ZIP };

struct sl1_item {
	struct sl1_item *next; /* in the writer's spare list */
	int index;
	double z_lo_mm, z_hi_mm;
	struct raster *r; /* pool image, NULL once returned to the pool */
	int ready;        /* the engine rendered r */
	struct paths region;
	struct buf png;
	struct out_png_scratch scratch; /* kept with the item between layers */
	struct out_png_stats st;
	uint8_t *mask;  /* thumbnail cells (kept allocated with the item) */
	int thumb;      /* this layer feeds the thumbnail grid */
};

struct sl1_writer {
	enum sl1_kind kind;
	struct out_info info; /* pointers in it are borrowed */
	const struct resin_printer *rp;
	struct raster_map map;
	int w, h;
	double px_area_mm2;
	char job_dir[SL1_JOB_DIR_MAX + 1];
	const char *prefix; /* metrics object: "sl1", "sl1s", "zip" */
	struct sink *sink;
	uint64_t bytes0; /* sink bytes before the archive */
	struct out_zip *zip;
	struct pipeline *pipe;
	int threads;

	/* image pool, at most `cap` images: `idle` are zeroed and free,
	 * `lent` belong to the caller (out_raster_get .. out_layer),
	 * `in_pipe` are held by queued layers */
	pthread_mutex_t mu;
	pthread_cond_t cv;
	struct raster **idle, **lent;
	int nfree, nlent, in_pipe, cap;

	struct sl1_item *spare;   /* finished items, buffers kept (job's thread only) */
	struct thumb_acc *thumbs; /* no mesh: thumbnails from the layers */
	int next_index;           /* next layer expected */
	int emitted;              /* layers through sl1_emit, written or held back */
	struct buf empty_png;     /* an empty layer's PNG (all are alike), for held-back ones */
	struct sl1_summary sum;
	uint64_t png_bytes;
	int failed;      /* sticky first failure (negative err_code), 0 if none */
	struct err ferr; /* its record */
	int closed;
};

/* Record the first failure rc (whose record is in e) and return it. */
static int writer_fail(struct sl1_writer *w, int rc, const struct err *e)
{
	if (!w->failed) {
		w->failed = rc;
		if (e)
			w->ferr = *e;
		else
			ERR_SET(&w->ferr, rc, "the archive writer failed");
	}
	return rc;
}

/* The recorded failure, again. */
static int writer_failed(const struct sl1_writer *w, struct err *e)
{
	if (e)
		*e = w->ferr;
	return w->failed;
}

static const char *metrics_prefix(enum out_format f)
{
	return f == OUT_SL1S ? "sl1s" : f == OUT_ZIP ? "zip" : "sl1";
}

/* ---- image pool ---- */

/* A zeroed image lent to the caller: an idle one, a new one while under
 * the cap, or wait for a queued layer to give one back. */
static int pool_get(struct sl1_writer *w, struct raster **out, struct err *e)
{
	struct raster *r = NULL;

	pthread_mutex_lock(&w->mu);
	for (;;) {
		if (w->nfree > 0) {
			r = w->idle[--w->nfree];
			break;
		}
		if (w->nfree + w->nlent + w->in_pipe < w->cap)
			break;
		if (w->in_pipe == 0) {
			pthread_mutex_unlock(&w->mu);
			return ERR_SET(e, ERR_INTERNAL,
				       "all %d layer images are held outside the writer", w->cap);
		}
		pthread_cond_wait(&w->cv, &w->mu);
	}
	if (!r)
		r = raster_new(w->w, w->h);
	if (r)
		w->lent[w->nlent++] = r;
	pthread_mutex_unlock(&w->mu);
	if (!r)
		return ERR_SET(e, ERR_NOMEM, "out of memory for a %d x %d layer image", w->w,
			       w->h);
	*out = r;
	return 0;
}

/* Take back an image lent by pool_get(); 0 if r was not lent by us. */
static int pool_take_back(struct sl1_writer *w, struct raster *r)
{
	int found = 0;

	pthread_mutex_lock(&w->mu);
	for (int i = 0; i < w->nlent; i++)
		if (w->lent[i] == r) {
			w->lent[i] = w->lent[--w->nlent];
			found = 1;
			break;
		}
	pthread_mutex_unlock(&w->mu);
	return found;
}

/* Make r (zeroed) idle; from_pipe: it was held by a queued layer. */
static void pool_put(struct sl1_writer *w, struct raster *r, int from_pipe)
{
	pthread_mutex_lock(&w->mu);
	if (from_pipe)
		w->in_pipe--;
	w->idle[w->nfree++] = r;
	pthread_cond_broadcast(&w->cv);
	pthread_mutex_unlock(&w->mu);
}

/* Clear rect of r (inclusive bounds, clamped). */
static void clear_rect(struct raster *r, struct out_px_rect c)
{
	c.x0 = c.x0 < 0 ? 0 : c.x0;
	c.y0 = c.y0 < 0 ? 0 : c.y0;
	c.x1 = c.x1 > r->w - 1 ? r->w - 1 : c.x1;
	c.y1 = c.y1 > r->h - 1 ? r->h - 1 : c.y1;
	if (c.x0 > c.x1 || c.y0 > c.y1)
		return;
	for (int y = c.y0; y <= c.y1; y++)
		memset(r->px + (size_t)y * r->stride + (size_t)c.x0, 0, (size_t)(c.x1 - c.x0 + 1));
}

/* Pixel rectangle holding region's bounding box, with a pixel to spare;
 * empty (x0 > x1) for an empty region. */
static struct out_px_rect region_rect(const struct sl1_writer *w, const struct paths *region)
{
	struct out_px_rect c = {1, 1, 0, 0};
	struct pt2 lo, hi;
	double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;

	if (!paths_bbox(region, &lo, &hi))
		return c;
	for (int k = 0; k < 4; k++) {
		double u, v;
		raster_map_apply(&w->map, geom_nm_to_mm(k & 1 ? hi.x : lo.x),
				 geom_nm_to_mm(k & 2 ? hi.y : lo.y), &u, &v);
		u_lo = fmin(u_lo, u);
		u_hi = fmax(u_hi, u);
		v_lo = fmin(v_lo, v);
		v_hi = fmax(v_hi, v);
	}
	if (u_hi < 0 || v_hi < 0 || u_lo > w->w || v_lo > w->h)
		return c; /* entirely off the display: nothing to draw */
	c.x0 = (int)floor(fmax(u_lo, -1.0)) - 1;
	c.y0 = (int)floor(fmax(v_lo, -1.0)) - 1;
	c.x1 = (int)ceil(fmin(u_hi, (double)w->w)) + 1;
	c.y1 = (int)ceil(fmin(v_hi, (double)w->h)) + 1;
	c.x0 = c.x0 < 0 ? 0 : c.x0;
	c.y0 = c.y0 < 0 ? 0 : c.y0;
	c.x1 = c.x1 > w->w - 1 ? w->w - 1 : c.x1;
	c.y1 = c.y1 > w->h - 1 ? w->h - 1 : c.y1;
	return c;
}

/* ---- pipeline stages ---- */

static void item_free(struct sl1_item *it)
{
	paths_fini(&it->region);
	buf_fini(&it->png);
	out_png_scratch_fini(&it->scratch);
	mem_free(it->mask);
	mem_free(it);
}

/* An item for the next layer: a spare one with its buffers, or a new
 * one.  Spares number at most the layers ever in flight at once. */
static struct sl1_item *item_get(struct sl1_writer *w)
{
	struct sl1_item *it = w->spare;

	if (!it)
		return mem_calloc(1, sizeof *it);
	w->spare = it->next;
	it->next = NULL;
	return it;
}

/* Keep a finished item for reuse (its image already returned). */
static void item_put(struct sl1_writer *w, struct sl1_item *it)
{
	paths_fini(&it->region);
	buf_reset(&it->png);
	it->next = w->spare;
	w->spare = it;
}

/* Worker thread: pixels, PNG, coverage, thumbnail cells; the image goes
 * back to the pool zeroed (only its dirty rectangle is cleared). */
static int sl1_work(void *ctx, void *item, struct err *e)
{
	struct sl1_writer *w = ctx;
	struct sl1_item *it = item;
	struct out_px_rect hint = {0, 0, -1, -1}, dirty;
	int rc = 0;

	if (!it->ready) {
		hint = region_rect(w, &it->region);
		if (hint.x0 <= hint.x1)
			rc = slice_rasterize(&it->region, &w->map, w->rp->antialias, it->r, e);
	}
	if (!rc)
		rc = out_png_gray(it->r, it->ready ? NULL : &hint, &it->scratch, &it->png, &it->st,
				  e);
	if (!rc && it->thumb) {
		/* only the nonzero box: a view into r with the map shifted */
		struct raster view = *it->r;
		struct raster_map m = w->map;
		const struct out_px_rect *nz = &it->st.nz;
		if (nz->x0 <= nz->x1) {
			view.px += (size_t)nz->y0 * view.stride + (size_t)nz->x0;
			view.w = nz->x1 - nz->x0 + 1;
			view.h = nz->y1 - nz->y0 + 1;
			m.b[0] -= nz->x0;
			m.b[1] -= nz->y0;
		} else {
			view.w = view.h = 0;
		}
		rc = thumb_acc_reduce(w->thumbs, NULL, &view, &m, it->mask, e);
	}
	if (rc) {
		raster_clear(it->r);
	} else {
		dirty = it->ready ? it->st.nz : hint;
		clear_rect(it->r, dirty);
	}
	pool_put(w, it->r, 1);
	it->r = NULL;
	paths_fini(&it->region);
	return rc;
}

static void layer_name(const struct sl1_writer *w, int index, char *name, size_t len)
{
	if (w->kind == KIND_SL1)
		snprintf(name, len, "%s%05d.png", w->job_dir, index);
	else
		snprintf(name, len, "%d.png", index + 1);
}

/* The zip entry of layer index (PNG png, coverage sum_px in pixel values
 * 0..255) and the running figures. */
static int add_layer(struct sl1_writer *w, int index, const struct buf *png, uint64_t sum_px,
		     double height_mm, struct err *e)
{
	char name[SL1_JOB_DIR_MAX + 16];
	double area_mm2 = (double)sum_px / 255.0 * w->px_area_mm2;
	int slow = sl1_layer_is_slow(w->rp, area_mm2);
	int rc;

	layer_name(w, index, name, sizeof name);
	rc = out_zip_add(w->zip, name, png->data, png->len, e);
	if (!rc) {
		w->sum.layers++;
		w->sum.slow_layers += slow;
		w->sum.fast_layers += !slow;
		w->sum.volume_mm3 += area_mm2 * height_mm;
		w->sum.print_time_s += sl1_layer_time_s(w->rp, index, height_mm, slow);
		w->sum.max_area_mm2 = fmax(w->sum.max_area_mm2, area_mm2);
		w->png_bytes += png->len;
	}
	return rc;
}

/* Caller's thread, in layer order: the zip entry and the running figures.
 * An empty layer (no pixel lit: a lattice above its last strut) is held
 * back and written only when a later layer exposes something, so the
 * archive ends with the last layer that carries material and numSlow +
 * numFast count exactly the layers written.  Held-back layers share one
 * stored PNG: every empty image of the writer encodes alike. */
static int sl1_emit(void *ctx, void *item, struct err *e)
{
	struct sl1_writer *w = ctx;
	struct sl1_item *it = item;
	double height_mm = it->z_hi_mm - it->z_lo_mm;
	int rc = 0;

	w->emitted++;
	if (it->st.sum == 0) {
		if (w->empty_png.len == 0)
			rc = buf_append(&w->empty_png, it->png.data, it->png.len)
				     ? ERR_SET(e, ERR_NOMEM, "out of memory for an empty layer")
				     : 0;
		item_put(w, it);
		return rc;
	}
	/* resin layers all have the job's layer height */
	for (int j = w->sum.layers; !rc && j < it->index; j++)
		rc = add_layer(w, j, &w->empty_png, 0, w->info.layer_mm, e);
	if (!rc)
		rc = add_layer(w, it->index, &it->png, it->st.sum, height_mm, e);
	if (!rc && it->thumb)
		thumb_acc_merge(w->thumbs, it->z_lo_mm, it->z_hi_mm, it->mask);
	item_put(w, it);
	return rc;
}

/* Release a layer that will not be emitted. */
static void sl1_drop(void *ctx, void *item)
{
	struct sl1_writer *w = ctx;
	struct sl1_item *it = item;

	if (it->r) {
		raster_clear(it->r);
		pool_put(w, it->r, 1);
		it->r = NULL;
	}
	item_put(w, it);
}

static const struct pipeline_ops sl1_pipeline_ops = {sl1_work, sl1_emit, sl1_drop};

/* ---- writer_ops ---- */

static void sl1_free_state(void *state)
{
	struct sl1_writer *w = state;

	if (!w)
		return;
	pipeline_free(w->pipe); /* joins the workers, drops queued layers */
	while (w->spare) {
		struct sl1_item *it = w->spare;
		w->spare = it->next;
		item_free(it);
	}
	out_zip_free(w->zip);   /* abandons an unclosed archive */
	thumb_acc_free(w->thumbs);
	buf_fini(&w->empty_png);
	/* lent images belong to the caller; queued ones came back above */
	for (int i = 0; i < w->nfree; i++)
		raster_free(w->idle[i]);
	mem_free(w->idle);
	mem_free(w->lent);
	pthread_mutex_destroy(&w->mu);
	pthread_cond_destroy(&w->cv);
	mem_free(w);
}

/* The thumbnails of the SL1 presets: from the mesh, or (no mesh) from
 * the layers collected so far. */
static int add_thumbnails(struct sl1_writer *w, struct err *e)
{
	struct buf png;
	char name[64];
	int rc = 0;

	buf_init(&png);
	for (size_t i = 0; !rc && i < sizeof thumb_sizes / sizeof thumb_sizes[0]; i++) {
		int tw = thumb_sizes[i][0], th = thumb_sizes[i][1];
		buf_reset(&png);
		rc = w->info.mesh ? thumbnail_png_from_mesh(w->info.mesh, tw, th, &png, e)
				  : thumb_acc_png(w->thumbs, tw, th, &png, e);
		snprintf(name, sizeof name, "thumbnail/thumbnail%dx%d.png", tw, th);
		if (!rc)
			rc = out_zip_add(w->zip, name, png.data, png.len, e);
	}
	buf_fini(&png);
	return rc;
}

static int add_text(struct sl1_writer *w, const char *name,
		    int (*fmt)(struct sl1_writer *w, struct buf *b, struct err *e), struct err *e)
{
	struct buf b;
	int rc;

	buf_init(&b);
	rc = fmt(w, &b, e);
	if (!rc)
		rc = out_zip_add(w->zip, name, b.data, b.len, e);
	buf_fini(&b);
	return rc;
}

static int fmt_prusaslicer_ini(struct sl1_writer *w, struct buf *b, struct err *e)
{
	return sl1_prusaslicer_ini(&w->info, w->rp, b, e);
}

static int fmt_config_ini(struct sl1_writer *w, struct buf *b, struct err *e)
{
	return sl1_config_ini(&w->info, w->rp, w->job_dir, &w->sum, b, e);
}

static int fmt_manifest(struct sl1_writer *w, struct buf *b, struct err *e)
{
	return sl1_manifest_json(&w->info, w->rp, &w->map, w->w, w->h, &w->sum, b, e);
}

static int check_info(const struct out_info *info, enum sl1_kind kind, struct err *e)
{
	const struct printer *p = info->printer;
	int rc;

	if (!p || p->kind != PRINTER_RESIN)
		return ERR_FIELD(e, "printer", "format %s needs a resin printer profile%s%s",
				 metrics_prefix(info->format), p ? ", not " : "", p ? p->name : "");
	rc = printer_resin_check(&p->resin, e);
	if (rc)
		return rc;
	if (kind == KIND_SL1 && (info->format == OUT_SL1S) != (strcmp(p->resin.model, "SL1S") == 0))
		return ERR_FIELD(e, "format",
				 "format %s does not match printer %s (model %s): use %s",
				 metrics_prefix(info->format), p->name, p->resin.model,
				 info->format == OUT_SL1S ? "format sl1" : "format sl1s");
	if (info->layer_count < 1)
		return ERR_SET(e, ERR_GEOMETRY, "the part has no layers to write");
	if (!(info->layer_mm > 0 && info->layer_mm < 10))
		return ERR_FIELD(e, "layer_mm", "layer height %g mm is not usable", info->layer_mm);
	return 0;
}

static int open_common(const struct out_info *info, struct sink *s, enum sl1_kind kind,
		       void **state, struct err *e)
{
	struct sl1_writer *w;
	int rc, in_flight;

	rc = check_info(info, kind, e);
	if (rc)
		return rc;
	w = mem_calloc(1, sizeof *w);
	if (!w)
		return ERR_SET(e, ERR_NOMEM, "out of memory opening the archive writer");
	buf_init(&w->empty_png);
	pthread_mutex_init(&w->mu, NULL);
	pthread_cond_init(&w->cv, NULL);
	w->kind = kind;
	w->info = *info;
	w->rp = &info->printer->resin;
	w->prefix = metrics_prefix(info->format);
	w->sink = s;
	w->bytes0 = s->bytes;
	printer_raster_geometry(info->printer, &w->map, &w->w, &w->h);
	w->px_area_mm2 = raster_map_pixel_area_mm2(&w->map);
	out_job_dir(info->job_name, w->job_dir);
	w->threads = info->threads < 1 ? 1 : info->threads > SL1_MAX_THREADS ? SL1_MAX_THREADS
									   : info->threads;
	/* two layers per worker keep every worker busy while the emitter
	 * waits for the oldest; two more images for the engine's hands */
	in_flight = 2 * w->threads;
	w->cap = in_flight + 2;
	w->idle = mem_calloc((size_t)w->cap, sizeof *w->idle);
	w->lent = mem_calloc((size_t)w->cap, sizeof *w->lent);
	if (!w->idle || !w->lent) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory opening the archive writer");
		goto fail;
	}
	if (kind == KIND_SL1 && !info->mesh) {
		rc = thumb_acc_new(info->part_bbox, &w->thumbs, e);
		if (rc)
			goto fail;
	}
	rc = out_zip_new(s, info->created, &w->zip, e);
	if (rc)
		goto fail;
	/* every item that can be alive at once (in flight, plus the one being
	 * queued) with its encoder memory, so memory is flat from layer 0 */
	for (int i = 0; i < in_flight + 1; i++) {
		struct sl1_item *it = mem_calloc(1, sizeof *it);
		if (it)
			it->scratch.tok = mem_alloc(OUT_PNG_TOKENS * sizeof *it->scratch.tok);
		if (!it || !it->scratch.tok) {
			mem_free(it);
			rc = ERR_SET(e, ERR_NOMEM, "out of memory opening the archive writer");
			goto fail;
		}
		item_put(w, it);
	}
	rc = pipeline_new(&sl1_pipeline_ops, w, w->threads, in_flight, &w->pipe, e);
	if (rc)
		goto fail;
	if (kind == KIND_SL1) {
		rc = add_text(w, "prusaslicer.ini", fmt_prusaslicer_ini, e);
		if (!rc && info->mesh)
			rc = add_thumbnails(w, e);
		if (rc)
			goto fail;
	}
	*state = w;
	return 0;
fail:
	sl1_free_state(w);
	return rc;
}

static int sl1_open(const struct out_info *info, struct sink *s, void **state, struct err *e)
{
	return open_common(info, s, KIND_SL1, state, e);
}

static int zip_open(const struct out_info *info, struct sink *s, void **state, struct err *e)
{
	return open_common(info, s, KIND_ZIP, state, e);
}

static int sl1_raster_get(void *state, struct raster **r, struct err *e)
{
	struct sl1_writer *w = state;

	if (w->failed)
		return writer_failed(w, e);
	return pool_get(w, r, e);
}

static const struct raster_map *sl1_raster_map(const void *state)
{
	const struct sl1_writer *w = state;
	return &w->map;
}

static int sl1_layer(void *state, struct layer *ly, struct err *e)
{
	struct sl1_writer *w = state;
	struct sl1_item *it = NULL;
	struct raster *r = ly->raster;
	struct paths region = ly->region;
	int ready = r && ly->raster_ready, rc = 0;
	double z_lo = ly->z_top_mm - ly->height_mm;

	/* take what the layer owns, so every exit leaves ly empty */
	paths_init(&ly->region);
	ly->raster = NULL;
	ly->raster_ready = 0;
	if (r && !pool_take_back(w, r)) {
		raster_free(r);
		r = NULL;
		rc = ERR_SET(e, ERR_INTERNAL, "layer %d carries an image not from out_raster_get",
			     ly->index);
	} else if (w->failed) {
		rc = writer_failed(w, e);
	} else if (w->closed || ly->index != w->next_index || ly->index >= w->info.layer_count) {
		rc = ERR_SET(e, ERR_INTERNAL, "layer %d arrived, expected %d of %d", ly->index,
			     w->next_index, w->info.layer_count);
	}
	if (!rc) {
		it = item_get(w);
		if (!it)
			rc = ERR_SET(e, ERR_NOMEM, "out of memory queueing layer %d", ly->index);
	}
	if (!rc && !r) {
		rc = pool_get(w, &r, e);
		if (!rc)
			pool_take_back(w, r);
	}
	if (!rc) {
		it->thumb = w->thumbs && thumb_acc_wants(w->thumbs, z_lo, ly->z_top_mm);
		if (it->thumb && !it->mask) {
			it->mask = mem_alloc(thumb_acc_mask_bytes(w->thumbs));
			if (!it->mask)
				rc = ERR_SET(e, ERR_NOMEM, "out of memory queueing layer %d",
					     ly->index);
		}
	}
	if (rc) {
		paths_fini(&region);
		if (r) {
			raster_clear(r);
			pool_put(w, r, 0);
		}
		if (it)
			item_put(w, it);
		return writer_fail(w, rc, e);
	}
	it->r = r;
	it->ready = ready;
	it->region = region;
	it->index = ly->index;
	it->z_lo_mm = z_lo;
	it->z_hi_mm = ly->z_top_mm;
	pthread_mutex_lock(&w->mu);
	w->in_pipe++;
	pthread_mutex_unlock(&w->mu);
	w->next_index++;
	rc = pipeline_submit(w->pipe, it, e); /* the pipeline owns it now */
	return rc ? writer_fail(w, rc, e) : 0;
}

static int record_metrics(struct sl1_writer *w, struct metrics *m)
{
	char key[64];
	int rc = 0;

#define KEY(name) (snprintf(key, sizeof key, "%s." name, w->prefix), key)
	rc |= metrics_num(m, "material_volume_mm3", w->sum.volume_mm3);
	rc |= metrics_int(m, KEY("layers"), w->sum.layers);
	rc |= metrics_num(m, KEY("used_material_ml"), w->sum.volume_mm3 / 1000.0);
	rc |= metrics_num(m, KEY("print_time_s"), w->sum.print_time_s);
	rc |= metrics_int(m, KEY("slow_layers"), w->sum.slow_layers);
	rc |= metrics_int(m, KEY("fast_layers"), w->sum.fast_layers);
	rc |= metrics_num(m, KEY("max_layer_area_mm2"), w->sum.max_area_mm2);
	rc |= metrics_int(m, KEY("archive_bytes"), (long long)(w->sink->bytes - w->bytes0));
	rc |= metrics_int(m, KEY("png_bytes"), (long long)w->png_bytes);
	rc |= metrics_int(m, KEY("image_width_px"), w->w);
	rc |= metrics_int(m, KEY("image_height_px"), w->h);
	rc |= metrics_num(m, KEY("pixel_um"), 1000.0 * sqrt(w->px_area_mm2));
	rc |= metrics_int(m, KEY("encoder_threads"), w->threads);
	if (w->kind == KIND_SL1)
		rc |= metrics_str(m, KEY("job_dir"), w->job_dir);
#undef KEY
	return rc ? ERR_NOMEM : 0;
}

static int sl1_close(void *state, struct metrics *m, struct err *e)
{
	struct sl1_writer *w = state;
	int rc;

	if (w->closed)
		return ERR_SET(e, ERR_INTERNAL, "archive writer closed twice");
	if (w->failed)
		return writer_failed(w, e);
	rc = pipeline_finish(w->pipe, e);
	if (!rc && w->emitted != w->info.layer_count)
		rc = ERR_SET(e, ERR_INTERNAL, "%d of %d layers were written", w->emitted,
			     w->info.layer_count);
	if (!rc && w->sum.layers == 0)
		rc = ERR_SET(e, ERR_GEOMETRY, "none of the %d layers exposes a pixel",
			     w->info.layer_count);
	if (!rc && w->kind == KIND_SL1 && w->thumbs)
		rc = add_thumbnails(w, e);
	if (!rc && w->kind == KIND_SL1)
		rc = add_text(w, "config.ini", fmt_config_ini, e);
	if (!rc && w->kind == KIND_ZIP)
		rc = add_text(w, "manifest.json", fmt_manifest, e);
	if (!rc)
		rc = out_zip_close(w->zip, e);
	if (!rc && m && record_metrics(w, m))
		rc = ERR_SET(e, ERR_NOMEM, "out of memory recording metrics");
	if (rc)
		return writer_fail(w, rc, e);
	w->closed = 1;
	return 0;
}

const struct writer_ops sl1_writer_ops = {
	.name = "sl1",
	.wants_raster = 1,
	.wants_region = 0,
	.open = sl1_open,
	.raster_get = sl1_raster_get,
	.raster_map = sl1_raster_map,
	.layer = sl1_layer,
	.close = sl1_close,
	.free_state = sl1_free_state,
};

const struct writer_ops zip_writer_ops = {
	.name = "zip",
	.wants_raster = 1,
	.wants_region = 0,
	.open = zip_open,
	.raster_get = sl1_raster_get,
	.raster_map = sl1_raster_map,
	.layer = sl1_layer,
	.close = sl1_close,
	.free_state = sl1_free_state,
};
