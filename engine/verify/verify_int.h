/* verify_int.h - the verifier's state, shared by verify.c (the layer
 * loop, walls, the 3D resolution) and support.c (what holds each layer
 * up: overhangs and islands).  Internal to engine/verify.
 */
#ifndef INFILLD_VERIFY_INT_H
#define INFILLD_VERIFY_INT_H

#include <stddef.h>
#include <stdint.h>

#include "engine/geom/edt.h"
#include "engine/verify/between.h"
#include "engine/verify/contact.h"
#include "engine/verify/fins.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify.h"

struct err;

#define VX_OUT 1u /* union-find id of the outside */
#define VX_FIN_PX 2 /* fins and shelves: solid runs of at most this many pixels / layers */

struct crop {
	int x0, y0, w, h; /* w == 0: empty */
	int sx0, sy0, sx1, sy1; /* bounding box of the layer's solid; sx1 < 0: none */
	size_t cap;
	uint8_t *solid;   /* 1 = solid */
	uint8_t *gray;    /* the layer's gray (coverage x 255), for subpx.h */
	uint32_t *lab;    /* void component id, 0 on solid */
	float *d2;        /* squared distance (mm^2) to this layer's solid */
	int32_t *near;    /* crop index of that nearest solid pixel, -1 if none */
	float *any_d2;    /* squared distance (mm^2) to the nearest pixel with
			   * gray > 0; computed on demand (any_ok) */
	int any_ok;
	struct verify_subpx_fits fits; /* corner fits made on this layer (subpx.h) */
};

struct rec {
	uint32_t id;
	uint32_t id2; /* vertical walls: the void on the run's other side */
	int layer;
	double val; /* px count (overhang, void volume) or wall mm */
};

struct recs {
	struct rec *v;
	size_t n, cap;
};

struct verify {
	struct verify_params p;
	double slope_mm;  /* layer_mm tan(alpha): the rule's reach */
	double reach_mm;  /* slope_mm + tolerance_px pixels: interior overhang beyond it */
	double ext_reach_mm; /* slope_mm + 1 pixel: the centre test over the outside */
	int margin;
	int w, h, next;
	struct crop a, b, *prev, *cur;
	uint32_t *uf;
	size_t nuf, ufcap;
	struct recs ov, wall, vol, vwall, fin;
	struct recs ovx;      /* per component and layer: largest slope excess (mm) */
	struct recs between;  /* in-layer walls between two 2D-enclosed voids */
	struct recs shelf;    /* column runs of <= VX_FIN_PX layers between them */
	struct verify_between vb;
	uint32_t *wlab;       /* walls_between's window of void labels */
	size_t wlab_cap;
	uint16_t *col;        /* per image pixel: layer where its solid run began */
	uint32_t *col_id;     /* per image pixel: void component under that run when
			       * it was 2D-enclosed, else VX_OUT (outside, plate) */
	int col_ok;           /* layer count fits the 16-bit counter */
	uint8_t *enc;         /* per component of the current layer: 2D-enclosed */
	size_t enc_cap;
	uint8_t *prev_enc;    /* same for the previous layer's components */
	size_t prev_enc_cap;
	/* per union-find id: 1 when that layer component holds a pixel the
	 * reference holds void (the part's own air; verify_layer_ref), joined
	 * to the outside in verify_finish after its overhangs are counted */
	uint8_t *air;
	size_t air_cap, air_n; /* entries allocated, set (the others unread) */
	uint32_t prev_first, cur_first; /* first component id of each layer */
	double *agg;          /* per-component scratch */
	size_t agg_cap;
	double *aggx;         /* per-component scratch: largest slope excess (mm) */
	size_t aggx_cap;
	struct verify_fit_memo *memo; /* corner fits by neighbourhood (corner.h; owned) */
	struct verify_ovh *ovh; /* verify_overhangs: the pixels it reads (support.c) */
	size_t ovh_cap;       /* elements */
	int32_t *isl_lab;     /* verify_islands: labels of the crop's solid components */
	size_t isl_lab_cap;
	size_t *isl_area;     /* verify_islands: per solid component, pixels */
	size_t isl_area_cap;
	uint8_t *isl_flag;    /* verify_islands: per solid component, ISL_* bits */
	size_t isl_flag_cap;
	uint8_t *seed;
	float *ext_d2;
	size_t ext_cap;
	double *cnt;          /* per-component pixel counts */
	size_t cnt_cap;
	double *fcnt;         /* per-component fin, then sliver, pixel counts */
	struct verify_fins vf;
	struct recs sliver;   /* fin pixels standing free (fins.h) */
	size_t fcnt_cap;
	size_t scratch_cap;
	struct edt_scratch es;
	struct verify_contact ref; /* the reference stack's own islands (has_reference) */
	struct verify_report r;
	int failed, finished;
};

/* One pixel verify_overhangs reads at sub-pixel accuracy: crop indices
 * in the current (i) and previous (pi) layer, the void component of the
 * previous layer it overhangs, its upper bound and reading (mm). */
struct verify_ovh {
	size_t i, pi;
	uint32_t id;
	double u_mm, far_mm;
};

uint32_t verify_uf_find(struct verify *v, uint32_t a);
int verify_rec_add(struct recs *r, uint32_t id, int layer, double val);
/* Scratch growth: the old contents are dropped, not copied. */
int verify_grow_bytes(void **p, size_t *cap, size_t need);
/* Solid state of image pixel (x, y) in crop c: 1 solid, 0 void (outside
 * the crop is void; *idx = SIZE_MAX there). */
int verify_crop_solid(const struct crop *c, int x, int y, size_t *idx);
/* Is component id (of the previous layer) 2D-enclosed there? */
int verify_prev_enclosed(const struct verify *v, uint32_t id);
/* 3. overhangs of the current layer over the previous one (support.c) */
int verify_overhangs(struct verify *v, int layer, struct err *e);
/* 4. islands of the current layer (support.c); 0 or ERR_NOMEM */
int verify_islands(struct verify *v, int layer);

#endif
