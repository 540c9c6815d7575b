/* gcode_preview.c - gcode_preview_layer(): read a G-code file back and draw
 * one layer's moves (a top view, image row 0 at the largest y).
 *
 * One pass over the file: layers are the ";LAYER_CHANGE" blocks the
 * writer (gcode_write.c) emits, roles its ";TYPE:" comments, bead widths
 * its ";WIDTH:" comments.  The extrusion bounds of every layer fix the
 * view, so all layers of one file share scale and origin; layer k's moves
 * are kept until the end of the file and then drawn: each extrusion as a
 * capsule of its width (pixels within w/2 of the segment, O(segment
 * length * width) pixels each), each travel as a one-pixel line.
 */
#include "engine/output/gcode/gcode_preview.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/image/image.h"
#include "engine/output/toolpath/toolpath.h"

#define GP_MARGIN_PX 8
#define GP_LINE_MAX 4096
#define GP_COORD_MAX_MM 1e6  /* moves to farther XY are ignored (no printer is that large) */
#define GP_WIDTH_MAX_MM 100.0
#define GP_ROLE_TRAVEL TP_ROLE_COUNT     /* a move without extrusion */
#define GP_ROLE_OTHER (TP_ROLE_COUNT + 1) /* extrusion of an unknown ;TYPE: */

/* Colours, RGB; the roles' order is enum tp_role's (PrusaSlicer's palette). */
static const uint8_t role_rgb[TP_ROLE_COUNT + 2][3] = {
	[TP_ROLE_SKIRT] = {0x00, 0x87, 0x6e},
	[TP_ROLE_EXT_PERIMETER] = {0xff, 0x7d, 0x38},
	[TP_ROLE_PERIMETER] = {0xff, 0xe6, 0x4d},
	[TP_ROLE_GAP_FILL] = {0xff, 0xff, 0xff},
	[TP_ROLE_SPARSE] = {0xb0, 0x30, 0x29},
	[TP_ROLE_SOLID] = {0x96, 0x54, 0xcc},
	[TP_ROLE_TOP] = {0xf0, 0x40, 0x40},
	[TP_ROLE_BRIDGE] = {0x4d, 0x80, 0xba},
	[GP_ROLE_TRAVEL] = {0x5a, 0x5a, 0x66},
	[GP_ROLE_OTHER] = {0x90, 0x90, 0x90},
};
static const uint8_t background_rgb[3] = {0x20, 0x20, 0x24};

struct gp_seg {
	float x0, y0, x1, y1; /* mm, printer frame */
	float width_mm;
	uint8_t role;         /* enum tp_role, GP_ROLE_TRAVEL or GP_ROLE_OTHER */
};

struct gp_state {
	double x, y, e;      /* mm; e only counts in absolute-E mode */
	int rel_xy, rel_e;   /* G91, M83 */
	int layer;           /* index of the current ;LAYER_CHANGE block, -1 before */
	int role;
	double width_mm;
	double lo_x, lo_y, hi_x, hi_y;
	int has_bounds;
	struct gp_seg *segs; /* layer k's moves */
	size_t nsegs, cap;
};

static int role_of(const char *name)
{
	for (int r = 0; r < TP_ROLE_COUNT; r++)
		if (!strcmp(name, tp_role_name((enum tp_role)r)))
			return r;
	return GP_ROLE_OTHER;
}

/* The number after letter c in a G-code word list, if present. */
static int word(const char *s, char c, double *v)
{
	for (const char *p = s; *p && *p != ';'; p++) {
		if ((*p == c || *p == c + 32) && (p == s || p[-1] == ' ' || p[-1] == '\t')) {
			char *end;
			double x = strtod(p + 1, &end);
			if (end != p + 1 && isfinite(x)) {
				*v = x;
				return 1;
			}
		}
	}
	return 0;
}

static void grow_bounds(struct gp_state *st, double x, double y)
{
	if (!st->has_bounds) {
		st->lo_x = st->hi_x = x;
		st->lo_y = st->hi_y = y;
		st->has_bounds = 1;
		return;
	}
	st->lo_x = fmin(st->lo_x, x);
	st->hi_x = fmax(st->hi_x, x);
	st->lo_y = fmin(st->lo_y, y);
	st->hi_y = fmax(st->hi_y, y);
}

/* One G0/G1 line: move, maybe extrude; keep it when it is in layer k. */
static int move(struct gp_state *st, const char *args, int k, struct err *e)
{
	double x = st->x, y = st->y, v, de = 0;
	int extrudes;

	if (word(args, 'X', &v))
		x = st->rel_xy ? st->x + v : v;
	if (word(args, 'Y', &v))
		y = st->rel_xy ? st->y + v : v;
	if (word(args, 'E', &v)) {
		de = st->rel_e ? v : v - st->e;
		if (!st->rel_e)
			st->e = v;
	}
	if (x == st->x && y == st->y)
		return 0; /* retraction, z move or feed change only */
	if (!(fabs(x) <= GP_COORD_MAX_MM && fabs(y) <= GP_COORD_MAX_MM))
		return 0; /* not a place on any bed: the nozzle stays */
	extrudes = de > 0;
	if (extrudes && st->layer >= 0) {
		grow_bounds(st, st->x, st->y);
		grow_bounds(st, x, y);
	}
	if (st->layer == k) {
		struct gp_seg *s;
		if (st->nsegs >= GCODE_PREVIEW_SEGS)
			return ERR_SET(e, ERR_LIMIT, "layer %d has more than %u moves", k,
				       GCODE_PREVIEW_SEGS);
		if (st->nsegs == st->cap) {
			void *arr = st->segs;
			if (mem_grow(&arr, &st->cap, st->nsegs + 1, sizeof *st->segs))
				return ERR_SET(e, ERR_NOMEM, "out of memory reading layer %d", k);
			st->segs = arr;
		}
		s = &st->segs[st->nsegs++];
		s->x0 = (float)st->x;
		s->y0 = (float)st->y;
		s->x1 = (float)x;
		s->y1 = (float)y;
		s->width_mm = (float)st->width_mm;
		s->role = (uint8_t)(extrudes ? st->role : GP_ROLE_TRAVEL);
	}
	st->x = x;
	st->y = y;
	return 0;
}

static int read_file(FILE *f, int k, struct gp_state *st, struct err *e)
{
	char line[GP_LINE_MAX];
	long lineno = 0;
	int rc;

	while (fgets(line, sizeof line, f)) {
		size_t n = strlen(line);
		lineno++;
		if (n == sizeof line - 1 && line[n - 1] != '\n') {
			int c; /* overlong (no such line is written): skip the rest */
			while ((c = fgetc(f)) != EOF && c != '\n')
				;
		}
		line[strcspn(line, "\r\n")] = '\0';
		if (line[0] == ';') {
			if (!strcmp(line, ";LAYER_CHANGE"))
				st->layer++;
			else if (!strncmp(line, ";TYPE:", 6))
				st->role = role_of(line + 6);
			else if (!strncmp(line, ";WIDTH:", 7)) {
				double w = atof(line + 7);
				st->width_mm = w > 0 && w <= GP_WIDTH_MAX_MM ? w : st->width_mm;
			}
			continue;
		}
		if ((line[0] == 'G' || line[0] == 'g') && (line[1] == '0' || line[1] == '1') &&
		    (line[2] == ' ' || line[2] == '\0')) {
			if ((rc = move(st, line + 2, k, e)))
				return rc;
		} else if (!strncmp(line, "G90", 3)) {
			st->rel_xy = 0;
		} else if (!strncmp(line, "G91", 3)) {
			st->rel_xy = 1;
		} else if (!strncmp(line, "M83", 3)) {
			st->rel_e = 1;
		} else if (!strncmp(line, "M82", 3)) {
			st->rel_e = 0;
		} else if (!strncmp(line, "G92", 3)) {
			double v;
			if (word(line + 3, 'E', &v))
				st->e = v;
		}
	}
	if (ferror(f))
		return ERR_PLACE(e, ERR_IO, -1, lineno, -1, "reading the G-code failed");
	return 0;
}

/* v clamped to [lo, hi] before it becomes an int (far-off moves would
 * overflow one). */
static int clamp_px(double v, int lo, int hi)
{
	return v < lo ? lo : v > hi ? hi : (int)v;
}

/* Paint the pixels within r of segment (x0,y0)-(x1,y1), image
 * coordinates (pixel centres at +0.5).  Row by row, only the columns
 * where the segment, widened by r, can reach that row are tested, so the
 * cost is about (length + 2r) * 2r pixels, not the segment's bounding
 * box (a long diagonal infill line). */
static void draw_capsule(uint8_t *rgba, int w, int h, double x0, double y0, double x1,
			 double y1, double r, const uint8_t rgb[3])
{
	double dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
	int ay = clamp_px(floor(fmin(y0, y1) - r), 0, h), by = clamp_px(ceil(fmax(y0, y1) + r), -1, h - 1);

	for (int py = ay; py <= by; py++) {
		double yc = py + 0.5, t0 = 0, t1 = 1, xa, xb;
		if (dy != 0) {
			double ta = (yc - r - y0) / dy, tb = (yc + r - y0) / dy;
			t0 = fmax(fmin(ta, tb), 0);
			t1 = fmin(fmax(ta, tb), 1);
			if (t0 > t1)
				continue;
		} else if (fabs(yc - y0) > r) {
			continue;
		}
		xa = fmin(x0 + t0 * dx, x0 + t1 * dx) - r;
		xb = fmax(x0 + t0 * dx, x0 + t1 * dx) + r;
		for (int px = clamp_px(floor(xa), 0, w), end = clamp_px(ceil(xb), -1, w - 1); px <= end;
		     px++) {
			double cx = px + 0.5 - x0, cy = yc - y0;
			double t = len2 > 0 ? (cx * dx + cy * dy) / len2 : 0, qx, qy;
			uint8_t *p;
			t = t < 0 ? 0 : t > 1 ? 1 : t;
			qx = cx - t * dx;
			qy = cy - t * dy;
			if (qx * qx + qy * qy > r * r)
				continue;
			p = rgba + ((size_t)py * (size_t)w + (size_t)px) * 4;
			p[0] = rgb[0];
			p[1] = rgb[1];
			p[2] = rgb[2];
		}
	}
}

static int draw(const struct gp_state *st, struct buf *png, struct err *e)
{
	double bw = st->has_bounds ? st->hi_x - st->lo_x : 1, bh = st->has_bounds ? st->hi_y - st->lo_y : 1;
	double inner = GCODE_PREVIEW_PX - 2 * GP_MARGIN_PX;
	double px_per_mm = inner / fmax(fmax(bw, bh), 1e-3);
	double ox = st->has_bounds ? st->lo_x : 0, oy = st->has_bounds ? st->hi_y : 0;
	int w = (int)ceil(bw * px_per_mm) + 2 * GP_MARGIN_PX;
	int h = (int)ceil(bh * px_per_mm) + 2 * GP_MARGIN_PX;
	uint8_t *rgba;
	int rc;

	w = w < 16 ? 16 : w > GCODE_PREVIEW_PX ? GCODE_PREVIEW_PX : w;
	h = h < 16 ? 16 : h > GCODE_PREVIEW_PX ? GCODE_PREVIEW_PX : h;
	rgba = mem_alloc((size_t)w * (size_t)h * 4);
	if (!rgba)
		return ERR_SET(e, ERR_NOMEM, "out of memory drawing the layer");
	for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
		memcpy(rgba + i * 4, background_rgb, 3);
		rgba[i * 4 + 3] = 255;
	}
	/* Travels first, so the beads cover them. */
	for (int pass = 0; pass < 2; pass++) {
		for (size_t i = 0; i < st->nsegs; i++) {
			const struct gp_seg *s = &st->segs[i];
			int travel = s->role == GP_ROLE_TRAVEL;
			double r = travel ? 0.5 : fmax(0.5 * s->width_mm * px_per_mm, 0.75);
			if (travel != (pass == 0))
				continue;
			draw_capsule(rgba, w, h, GP_MARGIN_PX + (s->x0 - ox) * px_per_mm,
				     GP_MARGIN_PX + (oy - s->y0) * px_per_mm,
				     GP_MARGIN_PX + (s->x1 - ox) * px_per_mm,
				     GP_MARGIN_PX + (oy - s->y1) * px_per_mm, r, role_rgb[s->role]);
		}
	}
	rc = out_png_rgba(rgba, w, h, png, e);
	mem_free(rgba);
	return rc;
}

int gcode_preview_layer(const char *path, int k, struct buf *png, int *count, struct err *e)
{
	struct gp_state st;
	FILE *f;
	int rc;

	memset(&st, 0, sizeof st);
	st.layer = -1;
	st.role = GP_ROLE_OTHER;
	st.width_mm = 0.45;
	if (!(f = fopen(path, "r")))
		return ERR_SET(e, ERR_IO, "cannot open %s", path);
	rc = read_file(f, k, &st, e);
	fclose(f);
	if (rc)
		goto out;
	*count = st.layer + 1;
	if (k < 0 || k > st.layer) {
		rc = ERR_SET(e, ERR_NOTFOUND, "no layer %d: the G-code has %d layers (0..%d)", k,
			     st.layer + 1, st.layer);
		goto out;
	}
	rc = draw(&st, png, e);
out:
	mem_free(st.segs);
	return rc;
}
