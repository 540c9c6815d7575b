/* fill_int.h - internals of the top-down fill (engine/hollow/fill/): the
 * pixel-grid helpers (grid.c: row runs of masks, the nearest-seed label
 * transform on the exact Euclidean feature transform of geom/edt.h) and
 * the per-layer steps (fillstep.c, fillwall.c) that make the void of
 * print layer k from that of layer k + 1 on a window of the fill's grid;
 * topdown.c drives them top-down.  Rules and measurements: docs/hollow.md
 * "Top-down fill".  Not for use outside engine/hollow/fill/.
 */
#ifndef INFILLD_HOLLOW_FILL_INT_H
#define INFILLD_HOLLOW_FILL_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/edt.h"
#include "engine/hollow/fill/fill.h"

struct err;

/* ---- pixel grids (grid.c) ---- */

/* The set pixels of mask (w x h, row stride w, nonzero = set) restricted
 * to columns [x0, x1) and rows [y0, y1), as runs in row-major order,
 * appended to *runs (*n, *cap: mem_grow array).  0 or ERR_NOMEM. */
int hl_grid_runs(const uint8_t *mask, int w, int x0, int y0, int x1, int y1,
		 struct hl_span **runs, size_t *n, size_t *cap, struct err *e);

/* Set mask[y * w + x] = val for every pixel of runs[0..n). */
void hl_grid_paint(uint8_t *mask, int w, const struct hl_span *runs, size_t n, uint8_t val);

/* Nearest-seed transform on a w x h window (row stride w): for every
 * pixel, d2 = squared distance (mm^2, pitches px_mm along x, py_mm along
 * y) between pixel centres to the nearest pixel with lab != 0, and
 * near = that pixel's lab (0 and INFINITY without seeds).  O(w h).
 * Scratch is allocated per call (edt_nearest_sq does the work).  0 or
 * ERR_NOMEM. */
int hl_grid_nearest(const int32_t *lab, int w, int h, double px_mm, double py_mm, float *d2,
		    int32_t *near, struct err *e);

/* ---- the per-layer steps (fillstep.c, fillwall.c) ---- */

/* Beside a void of its region of C, a new void needs wall + dg + this
 * much (mm) of room: each void costs walls of wall_next down to its
 * floor, and within a few millimetres the neighbour's own growth (dd per
 * layer) fills the space anyway.  3 mm: measured on the cube (one groin
 * vault instead of five cells), camel, cow, elephant and armadillo
 * (docs/hollow.md); 1.5 mm gave the cow 54 % instead of 59 %. */
#define HL_FILL_LONE_MM 3.0

/* What hl_step_grow() keeps solid of the solid of layer k + 1 (s->u). */
#define HL_KEEP_E 1      /* E: inside distance > dd */
#define HL_KEEP_R 2      /* R: no solid of layer k within dg */
#define HL_KEEP_BRIDGE 3 /* ties kept R to the walls */

/* Scratch of one layer's window (ww x wh pixels, row stride ww). */
struct hl_win {
	uint8_t *cm, *seed, *vw, *u, *ex, *v;
	float *dc2, *dv2, *su, *de2, *d1, *db2, *sn, *sw;
	int32_t *lab, *near, *lv, *hd, *hq;
	struct edt_scratch es;
};

/* Free the scratch (s zeroed or initialised). */
void hl_win_fini(struct hl_win *s);
/* Scratch for windows of up to np pixels; 1 = ok, 0 = out of memory
 * (s then holds what was allocated: hl_win_fini frees it). */
int hl_win_init(struct hl_win *s, size_t np);

/* The geometry of the rule, mm (pixel pitches px along x, py along y). */
struct hl_geo {
	double dd;    /* design shrink per layer: layer tan(alpha - margin) */
	double dg;    /* discrete reach a layer, px: layer tan(alpha) exactly (the verifier's rule) */
	double wall;  /* wall_next_mm between fill voids */
	double birth; /* inside distance of the free region a new void needs */
	int mv;       /* layers in wall_next: the vertical wall between voids */
	double lone;  /* a new void beside others keeps wall + dg + lone from them */
	int lean;     /* walls between voids lean at the design slope (else stand) */
	double half;  /* lean: a void pixel centre from the bisector pixels, wall / 2 / cos */
	double px, py, pmax;
};

/* The steps, in the order topdown.c runs them on one window (ww x wh):
 * inputs s->cm = C(k), s->vw = V(k + 1), s->sw = carried inside
 * distance, s->lv = lowest void layer per pixel; output s->v = V(k) and
 * s->sn (the distance to carry).  Each returns 0, ERR_NOMEM or an EDT
 * error.  Keep-apart, vertical walls and islands only turn void solid;
 * births add void that keeps solid within dg; so the rule of
 * hl_step_grow() holds on the result. */
int hl_step_grow(struct hl_win *s, int ww, int wh, const struct hl_geo *g, struct err *e);
int hl_step_keep_apart(struct hl_win *s, int ww, int wh, const struct hl_geo *g, struct err *e);
int hl_step_vertical_walls(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k,
			   struct err *e);
int hl_step_born(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k,
		 struct err *e);
/* fillwall.c: leaning walls between voids (g->lean) */
int hl_step_keep_apart_lean(struct hl_win *s, int ww, int wh, const struct hl_geo *g,
			    struct err *e);
int hl_step_prune(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int k);
int hl_step_islands(struct hl_win *s, int ww, int wh, struct err *e);

#endif
