/* contours.c - marching squares: the region where a sampled field
 * exceeds an iso value (slice_field_contours).
 *
 * Samples sit at pixel centres; a virtual ring of "below" samples around
 * the grid closes every contour.  Crossings are linear interpolations on
 * grid edges, numbered once per edge, and each cell links its crossings
 * pairwise (material on the left), so loops are chained topologically
 * like the mesh slicer's.  Saddles are decided by the cell-centre value
 * (mean of the corners).  The loops come out simple, pairwise disjoint
 * and oriented (material left), i.e. already a normalised region, so no
 * polygon union is run.  Design: docs/slicing.md "Marching squares".
 */
#include "engine/slice/slice.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

struct xing {
	double u, v;  /* pixel coordinates */
	int32_t next; /* crossing that follows along the contour */
};

struct xings {
	struct xing *v;
	size_t n, cap;
	int nomem;
};

/* Id of a new crossing at (u, v). */
static int32_t xing_new(struct xings *x, double u, double v)
{
	if (x->n == x->cap) {
		void *a = x->v;
		if (x->n >= (size_t)INT32_MAX || mem_grow(&a, &x->cap, x->n + 1, sizeof *x->v)) {
			x->nomem = 1;
			return 0;
		}
		x->v = a;
	}
	x->v[x->n].u = u;
	x->v[x->n].v = v;
	x->v[x->n].next = -1;
	return (int32_t)x->n++;
}

/* Crossings stay this far (in pixels) from the samples, so crossings of
 * different edges never coincide (a sample exactly at iso would put
 * all its edges' crossings on it) and loops never touch. */
#define XING_MARGIN 1e-3

/* Position of the iso crossing between samples a (value fa, real iff
 * ra) and b, as a fraction of the way from a to b.  Against a virtual
 * sample the crossing is half way: on the image border; likewise
 * against a NaN sample (counted as below iso, value unknown). */
static double xing_t(float fa, int ra, float fb, int rb, float iso)
{
	double t;

	if (!ra || !rb || isnan(fa) || isnan(fb))
		return 0.5;
	t = ((double)iso - fa) / ((double)fb - fa);
	return t < XING_MARGIN ? XING_MARGIN : t > 1 - XING_MARGIN ? 1 - XING_MARGIN : t;
}

struct grid {
	const float *f;
	int w, h;
	float iso;
};

static int real(const struct grid *g, int i, int j)
{
	return i >= 0 && j >= 0 && i < g->w && j < g->h;
}

static float val(const struct grid *g, int i, int j)
{
	return real(g, i, j) ? g->f[(size_t)j * (size_t)g->w + (size_t)i] : -INFINITY;
}

/* Crossing id of the horizontal edge (i,j)-(i+1,j), created on demand. */
static int32_t hx(const struct grid *g, struct xings *x, int32_t *slot, int i, int j)
{
	if (*slot < 0) {
		double t = xing_t(val(g, i, j), real(g, i, j), val(g, i + 1, j), real(g, i + 1, j),
				  g->iso);
		*slot = xing_new(x, i + 0.5 + t, j + 0.5);
	}
	return *slot;
}

/* Crossing id of the vertical edge (i,j)-(i,j+1). */
static int32_t vx(const struct grid *g, struct xings *x, int32_t *slot, int i, int j)
{
	if (*slot < 0) {
		double t = xing_t(val(g, i, j), real(g, i, j), val(g, i, j + 1), real(g, i, j + 1),
				  g->iso);
		*slot = xing_new(x, i + 0.5, j + 0.5 + t);
	}
	return *slot;
}

/* Link the crossings of cell (i, j) (corners c0=(i,j) c1=(i+1,j)
 * c2=(i+1,j+1) c3=(i,j+1), edges k = ck -> ck+1, counter-clockwise in
 * the (u, v) frame): each edge run from inside to outside starts a
 * segment ending on an edge run from outside to inside, so the material
 * lies on the segment's left. */
static void cell(const struct grid *g, struct xings *x, int i, int j, const int in[4],
		 int32_t *top, int32_t *right, int32_t *bottom, int32_t *left)
{
	int32_t id[4] = {-1, -1, -1, -1};
	int saddle = in[0] == in[2] && in[1] == in[3] && in[0] != in[1];
	int connected = 0;

	if (in[0] != in[1])
		id[0] = hx(g, x, top, i, j);
	if (in[1] != in[2])
		id[1] = vx(g, x, right, i + 1, j);
	if (in[2] != in[3])
		id[2] = hx(g, x, bottom, i, j + 1);
	if (in[3] != in[0])
		id[3] = vx(g, x, left, i, j);
	if (x->nomem)
		return;
	if (saddle) { /* all four corners are real samples */
		double c = ((double)val(g, i, j) + val(g, i + 1, j) + val(g, i + 1, j + 1) +
			    val(g, i, j + 1)) * 0.25;
		connected = c > g->iso;
	}
	for (int k = 0; k < 4; k++) {
		int partner = -1;
		if (!in[k] || in[(k + 1) & 3])
			continue; /* not an inside -> outside edge */
		if (saddle) {
			partner = connected ? (k + 1) & 3 : (k + 3) & 3;
		} else {
			for (int q = 0; q < 4; q++)
				if (!in[q] && in[(q + 1) & 3])
					partner = q;
		}
		if (partner >= 0) /* always: a mixed cell has both kinds of edge */
			x->v[id[k]].next = id[partner];
	}
}

int slice_field_contours(const float *field, int w, int h, float iso,
			 const struct raster_map *map, struct paths *region, struct err *e)
{
	struct grid g = {field, w, h, iso};
	struct xings x;
	struct paths raw;
	int32_t *top = NULL, *bottom = NULL, *vert = NULL;
	unsigned char *rows = NULL;
	int *touched = NULL;
	struct pt2 *buf = NULL;
	size_t buf_cap = 0;
	unsigned char *seen = NULL;
	double det, ia00, ia01, ia10, ia11;
	int rc = 0;

	memset(&x, 0, sizeof x);
	paths_init(&raw);
	if (w < 1 || h < 1 || !field)
		return ERR_SET(e, ERR_PARAM, "field grid %dx%d is empty", w, h);
	det = map->a[0][0] * map->a[1][1] - map->a[0][1] * map->a[1][0];
	if (!(det != 0) || !isfinite(det))
		return ERR_SET(e, ERR_PARAM, "raster map is singular or not finite");
	ia00 = map->a[1][1] / det, ia01 = -map->a[0][1] / det;
	ia10 = -map->a[1][0] / det, ia11 = map->a[0][0] / det;
	top = mem_alloc(((size_t)w + 1) * sizeof *top);
	bottom = mem_alloc(((size_t)w + 1) * sizeof *bottom);
	vert = mem_alloc(((size_t)w + 2) * sizeof *vert);
	rows = mem_alloc(2 * ((size_t)w + 2));
	touched = mem_alloc(2 * ((size_t)w + 1) * sizeof *touched);
	if (!top || !bottom || !vert || !rows || !touched) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for marching squares");
		goto out;
	}
	memset(top, 0xff, ((size_t)w + 1) * sizeof *top);
	memset(bottom, 0xff, ((size_t)w + 1) * sizeof *bottom);
	memset(vert, 0xff, ((size_t)w + 2) * sizeof *vert);
	/* Inside flags of sample rows j and j + 1, index i + 1 for i = -1..w
	 * (the virtual ring is 0). */
	memset(rows, 0, 2 * ((size_t)w + 2));
	{
		unsigned char *r0 = rows, *r1 = rows + w + 2;
		int *tcur = touched, *tprev = touched + w + 1;
		int ncur = 0, nprev = 0;

		/* Cell rows j = -1 .. h-1 over the grid plus its virtual ring. */
		for (int j = -1; j < h; j++) {
			if (j + 1 < h) {
				const float *f = field + (size_t)(j + 1) * (size_t)w;
				for (int i = 0; i < w; i++)
					r1[i + 1] = f[i] > iso;
			} else {
				memset(r1, 0, (size_t)w + 2);
			}
			for (int i = -1; i < w; i++) {
				int in[4] = {r0[i + 1], r0[i + 2], r1[i + 2], r1[i + 1]};
				if (in[0] == in[1] && in[1] == in[2] && in[2] == in[3])
					continue;
				cell(&g, &x, i, j, in, &top[i + 1], &vert[i + 2], &bottom[i + 1],
				     &vert[i + 1]);
				if (x.nomem) {
					rc = ERR_SET(e, ERR_NOMEM,
						     "out of memory for %zu contour crossings", x.n);
					goto out;
				}
				tcur[ncur++] = i;
			}
			/* Reset only what was set: this row's vertical edges, and
			 * the previous row's bottom edges (the top array now). */
			for (int t = 0; t < ncur; t++)
				vert[tcur[t] + 1] = vert[tcur[t] + 2] = -1;
			for (int t = 0; t < nprev; t++)
				top[tprev[t] + 1] = -1;
			{
				int32_t *tb = top;
				unsigned char *tr = r0;
				int *tt = tprev;
				top = bottom, bottom = tb;
				r0 = r1, r1 = tr;
				tprev = tcur, tcur = tt;
				nprev = ncur, ncur = 0;
			}
		}
	}
	/* Every crossing starts one segment and ends one: follow the loops. */
	seen = mem_calloc(x.n ? x.n : 1, 1);
	if (!seen) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu contour crossings", x.n);
		goto out;
	}
	for (size_t s = 0; s < x.n; s++) {
		struct path *p;
		size_t len = 0;
		if (seen[s])
			continue;
		/* follow the loop once into a reused buffer, then copy it out */
		for (int32_t c = (int32_t)s; c >= 0 && !seen[c]; c = x.v[c].next) {
			double du = x.v[c].u - map->b[0], dv = x.v[c].v - map->b[1];
			if (len == buf_cap) {
				void *a = buf;
				if (mem_grow(&a, &buf_cap, len + 1, sizeof *buf)) {
					rc = ERR_SET(e, ERR_NOMEM, "out of memory for contours");
					goto out;
				}
				buf = a;
			}
			buf[len].x = geom_mm_to_nm(ia00 * du + ia01 * dv);
			buf[len].y = geom_mm_to_nm(ia10 * du + ia11 * dv);
			len++;
			seen[c] = 1;
		}
		if (paths_add_pts(&raw, buf, len)) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory for contours");
			goto out;
		}
		p = &raw.v[raw.n - 1];
		if (det < 0) /* the map mirrors: material-left becomes material-right */
			path_reverse(p);
	}
	/* Simple, disjoint, oriented loops: already normalised. */
	paths_fini(region);
	*region = raw;
	paths_init(&raw);
out:
	mem_free(top);
	mem_free(bottom);
	mem_free(vert);
	mem_free(rows);
	mem_free(touched);
	mem_free(buf);
	mem_free(seen);
	mem_free(x.v);
	paths_fini(&raw);
	return rc;
}
