/* fill_int.h - internals of the top-down fill (engine/hollow/fill/): the
 * pixel-grid helpers (grid.c: row runs of masks, the nearest-seed label
 * transform on the exact Euclidean feature transform of geom/edt.h) and
 * the per-layer steps (fillstep.c, fillwall.c) that make the void of
 * print layer k from that of layer k + 1 on a window of the fill's grid;
 * topdown.c drives them top-down, then groups the runs into 3D voids and
 * apart.c keeps two voids wall_next apart.  Rules and measurements: docs/hollow.md
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

/* rs[y] = the index of the first run of row y (rs[h] = n) in r[0..n), a
 * row-major run list of rows 0 .. h - 1. */
void hl_grid_row_starts(const struct hl_span *r, size_t n, int h, size_t *rs);

/* Set mask[y * w + x] = val for every pixel of runs[0..n). */
void hl_grid_paint(uint8_t *mask, int w, const struct hl_span *runs, size_t n, uint8_t val);

/* Nearest-seed transform on a w x h window (row stride w): for every
 * pixel, d2 = squared distance (mm^2, pitches px_mm along x, py_mm along
 * y) between pixel centres to the nearest pixel with lab != 0, and
 * near = that pixel's lab (0 and INFINITY without seeds).  O(w h).
 * edt_nearest_sq does the work in es (the caller's, with its threads);
 * seed (w h bytes) and idx (w h) are the caller's scratch, overwritten.
 * 0 or an EDT error. */
int hl_grid_nearest(const int32_t *lab, int w, int h, double px_mm, double py_mm, float *d2,
		    int32_t *near, uint8_t *seed, int32_t *idx, struct edt_scratch *es,
		    struct err *e);

/* ---- grouping and walls between voids (topdown.c, apart.c) ---- */

/* Union-find over f's runs: each run's comp becomes the global index (layer
 * by layer, runs in order) of the first run of its 3D component.  Runs of
 * one layer join where they overlap in a row's neighbour row (diag 0:
 * 4-connected, the fill's own grouping) or also touch at a corner (diag 1:
 * 8-connected, the verifier's); runs of consecutive layers where they
 * overlap.  *runs: how many runs f holds.  0, ERR_NOMEM or ERR_LIMIT. */
int hl_fill_label(struct hl_fill *f, int diag, size_t *runs, struct err *e);

/* Walls between voids, read in 3D (apart.c): in every layer where two
 * void pixels of different 3D components (diag 1 grouping) lie closer
 * than lim = wall_mm + min(px, py) (pixel centres: the verifier's
 * min_wall_between_mm under wall_mm), turn solid the void pixels nearer
 * than (lim + max(px, py)) / 2 to the pixels astride the Voronoi boundary
 * between such components, where the layer below is solid there; layers
 * bottom-up; regroup and repeat while a round cuts (8 rounds at most).
 * *cut: pixels turned solid; *left: layers that still hold two
 * components nearer than lim.  px, py: pitches (mm); threads: the EDTs'.
 * Each run's comp ends as its diag 1 group.  0, ERR_NOMEM, ERR_LIMIT or
 * an EDT error. */
int hl_fill_apart(struct hl_fill *f, double wall_mm, double px, double py, int threads,
		  long *cut, long *left, struct err *e);

/* ---- the per-layer steps (fillstep.c, fillwall.c) ---- */

/* Beside a void of its region of C, a new void needs wall + dg + this
 * much (mm) of room: each void costs walls of wall_next down to its
 * floor, and within a few millimetres the neighbour's own growth (dd per
 * layer) fills the space anyway.  3 mm: measured on the cube (one groin
 * vault instead of five cells), camel, cow, elephant and armadillo
 * (docs/hollow.md); 1.5 mm gave the cow 54 % instead of 59 %. */
#define HL_FILL_LONE_MM 3.0

/* hl_step_grow() carries the inside distance down the layers (sig) only
 * while the design's slope dd is under this many pixels: there a front
 * stepped in whole pixels falls behind the slope and sig makes it up (SL1
 * pitch: dd 1.04 px at alpha 45).  At a few pixels a layer (0.2 mm FDM
 * layers on the 0.05 mm grid: 3.9 px) the EDT's own threshold moves the
 * front, and sig, carried pixel by pixel under a front that moved several
 * pixels, broke diagonal fronts into checkerboards: a 50 mm ball's G-code
 * 3,326 mm3 of slivers at 68.3 %, without sig 2.5 mm3 at 79.3 %
 * (docs/hollow.md 4.2, limit 10). */
#define HL_FILL_SIG_MAX_PX 1.25

/* What hl_step_grow() keeps solid of the solid of layer k + 1 (s->keep). */
#define HL_KEEP_E 1      /* E: inside distance > dd */
#define HL_KEEP_R 2      /* R: no solid of layer k within dg */
#define HL_KEEP_BRIDGE 3 /* ties kept R to the walls */

/*
 * Scratch of one layer's window: ww x wh pixels, row stride ww, each buffer
 * np pixels long (hl_win_init()).  Per pixel: masks 0 / 1 (keep: a class
 * above), distances in mm, squared distances in mm^2 (pixel centre to pixel
 * centre at the pitches px, py; INFINITY without a seed pixel), labels and
 * layer indices.  The steps, in the order topdown.c runs them: grow (with
 * recede_fins), keep-apart (standing or lean), vertical walls, prune (lean
 * only), born, islands; "w" = written by, "r" = read by.  C(k), V(k), E, R,
 * F, sig, su, d1, B: docs/hollow.md "Top-down fill" and the steps' comments.
 * Every field holds one thing, except step_mask and step_label: each step
 * fills them afresh for its own use (listed below).
 */
struct hl_win {
	/* ---- the layer's state (topdown.c copies it in and out) ---- */
	/* C(k): 1 = pixel centre in the offset region of layer k.  In;
	 * r: grow, prune, born. */
	uint8_t *region;
	/* V(k + 1): 1 = void in layer k + 1 (the layer done before).  In;
	 * r: every step. */
	uint8_t *void_above;
	/* sig: the inside distance (mm) carried down from above to the solid
	 * of layer k + 1 (INFINITY where none).  In; r: grow. */
	float *sig_above_mm;
	/* The lowest layer (> k, so the last one going down) in which the
	 * pixel is void, INT32_MAX if none.  In; r: vertical walls, prune,
	 * born. */
	int32_t *last_void;
	/* V(k): 1 = void in layer k.  w: grow; edited by every later step;
	 * out (the runs of layer k, and V(k + 1) of layer k - 1). */
	uint8_t *void_out;
	/* sig of layer k - 1 (mm): w: grow (su - dd where kept solid,
	 * INFINITY where void); each later step sets the pixels it flips (0,
	 * or INFINITY: lean keep-apart, prune, born).  Out. */
	float *sig_out_mm;

	/* ---- grow (hl_step_grow, recede_fins) ---- */
	/* Squared distance to V(k + 1), mm^2.  w, r: grow. */
	float *void_above_d2_mm2;
	/* su (mm): the distance to V(k + 1), or sig where that is smaller and
	 * within 2 px of it.  w, r: grow (sig_out_mm = su - dd). */
	float *inside_mm;
	/* E: pixels of C(k), solid in layer k + 1, with su > dd.  w: grow;
	 * r: recede_fins (the ground grows through E). */
	uint8_t *core;
	/* Squared distance to E u not C(k), mm^2 (R: farther than dg).  w, r:
	 * grow. */
	float *support_d2_mm2;
	/* The HL_KEEP_* class of each pixel grow keeps solid (E, R or a
	 * bridge), 0 elsewhere.  w: grow (recede_fins edits); r: prune. */
	uint8_t *keep;
	/* h: steps from the ground (0), -1 where no step reaches.  w, r:
	 * recede_fins (not written when it has nothing to do: no R, or no
	 * neighbour within dg). */
	int32_t *fin_steps;
	/* The pixels (indices i = y ww + x) the breadth-first search over h
	 * has reached: first the ground, then those of h >= 1 in order of h.
	 * w, r: recede_fins. */
	int32_t *fin_queue;

	/* ---- keep-apart (hl_step_keep_apart, hl_step_keep_apart_lean) ---- */
	/* The label (step_label) of the component of V(k + 1) nearest to the
	 * pixel, 0 without V(k + 1).  w, r: keep-apart. */
	int32_t *near_void;
	/* d1 squared: squared distance to V(k + 1), mm^2.  w: keep-apart; r:
	 * prune. */
	float *near_void_d2_mm2;
	/* Squared distance to the nearest bisector pixel (B: where near_void
	 * changes, d1 within reach), mm^2.  w: keep-apart (lean: only when
	 * there is a B; not read otherwise); r: keep-apart, prune. */
	float *bisector_d2_mm2;
	/* The side of the nearest bisector pixel: 1 the larger component's,
	 * 2 the smaller's, 0 none.  w: lean keep-apart; r: prune. */
	int32_t *bisector_side;

	/* ---- born (hl_step_born) ---- */
	/* Squared distance to the void of layers k .. k + mv (void_out,
	 * void_above, last_void), mm^2.  w, r: born. */
	float *recent_void_d2_mm2;
	/* 1 = not in F (the free region).  w, r: born. */
	uint8_t *not_free;
	/* D squared: F's squared inside distance (to not_free), mm^2.  w, r:
	 * born. */
	float *free_d2_mm2;
	/* F's ridge where D >= birth: where a void may be born.  w, r: born. */
	uint8_t *ridge;
	/* Squared distance to the nearest pixel off the ridge, mm^2 (a ridge
	 * pixel within dg of one turns void).  w, r: born. */
	float *off_ridge_d2_mm2;

	/* ---- per-step scratch: each step fills these before it reads them */
	/* Mask.  grow: E u not C(k) (seeds of support_d2_mm2); keep-apart:
	 * first the seeds of hl_grid_nearest(), then, standing, B (seeds of
	 * bisector_d2_mm2); vertical walls: the floor
	 * pixels (void in layer k and in one of k + 2 .. k + mv, solid in
	 * k + 1); born: the void of layers k .. k + mv (seeds of
	 * recent_void_d2_mm2), then F (where ridge() looks), then the pixels
	 * off the ridge (seeds of off_ridge_d2_mm2); islands: the solid of
	 * layer k + 1. */
	uint8_t *step_mask;
	/* Labels.  keep-apart: the components of V(k + 1) (seeds of
	 * near_void), then, lean only, the bisector pixels marked 1 or 2 by
	 * side (seeds of bisector_side); vertical walls: the floor patches;
	 * born: the components of C(k); islands: the solid components of
	 * layer k + 1.  8-connected components, label_components8(). */
	int32_t *step_label;
	/* Feature indices of hl_grid_nearest() (its seeds go in step_mask).
	 * w, r: keep-apart. */
	int32_t *nearest_index;
	/* Scratch of the squared distance transforms (edt_sq()). */
	struct edt_scratch edt;
};

/* Free every buffer of s and its EDT scratch.  s must have been zeroed
 * (memset and edt_scratch_init(), as topdown.c does before hl_win_init())
 * or passed to hl_win_init(), even one that failed.  s is not zeroed. */
void hl_win_fini(struct hl_win *s);
/* Zero s and allocate each of its buffers for windows of up to np pixels
 * (topdown.c: the whole grid), contents undefined: every buffer is written
 * before it is read, the inputs by topdown.c and the rest by the steps the
 * fields' comments above name.  1 = ok, 0 = out of memory (s then holds
 * what was allocated: hl_win_fini frees it). */
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
	int corners;  /* lean: convex void corners grow square (hl_step_prune) */
	double half;  /* lean: a void pixel centre from the bisector pixels, wall / 2 / cos */
	double px, py, pmax;
};

/* The steps, in the order topdown.c runs them on one window (ww x wh):
 * inputs s->region = C(k), s->void_above = V(k + 1), s->sig_above_mm =
 * the carried inside distance, s->last_void = the lowest void layer per
 * pixel; output s->void_out = V(k) and s->sig_out_mm (the distance to
 * carry); what each step writes and reads: struct hl_win.  Each returns 0,
 * ERR_NOMEM or an EDT error.  Keep-apart, vertical walls and islands only
 * turn void solid; prune (its icicles and corners) and births add void
 * that keeps solid within dg; so the rule of hl_step_grow() holds on the
 * result. */
int hl_step_grow(struct hl_win *s, int ww, int wh, const struct hl_geo *g, struct err *e);
/* Keep-apart's first half (both variants): s->step_label = the
 * 8-connected components of V(k + 1) (*count of them), s->near_void =
 * the label of the nearest one per pixel, s->near_void_d2_mm2 = the
 * squared distance (mm^2) to it.  0, ERR_NOMEM or an EDT error. */
int hl_step_near_voids(struct hl_win *s, int ww, int wh, const struct hl_geo *g, int32_t *count,
		       struct err *e);
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
