/* corner.c - straight edges fitted to a grey pixel's neighbourhood where
 * one edge cannot describe it (corner.h; docs/verify.md "Sub-pixel
 * overhangs"). */
#include "engine/verify/corner.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>

#include "engine/core/mem.h"
#include "engine/verify/subpx.h"
#include "engine/verify/verify.h"

#define WIN 2              /* the fit's window: (2 WIN + 1)^2 pixels */
#define SIDE (2 * WIN + 1)
#define NWIN (SIDE * SIDE)
#define CENTRE_WEIGHT 4.0  /* the pixel's own coverage counts 4 times */
#define MAX_ITER 10
#define NPAR 4             /* (angle, offset) per edge */
#define KWIN (WIN + 1)     /* the neighbourhood a fit reads: (2 KWIN + 1)^2 */
#define KSIDE (2 * KWIN + 1)
#define KEY (KSIDE * KSIDE)
#define MEMO_LOCKS 64

/* Coverage of the unit square centred at (i, j) by n.u <= d (n unit): the
 * forward form of subpx.c's edge offset.  With a >= b the absolute
 * components and s = (a + b) / 2: (d' + s)^2 / (2ab) while the line cuts
 * one corner, 1/2 + d'/a across the middle, symmetric at the far corner,
 * where d' = d - n.(i, j). */
static double line_area(double nx, double ny, double d, double i, double j)
{
	double a = fabs(nx), b = fabs(ny), s, dd = d - nx * i - ny * j;

	if (b > a) {
		double t = a;
		a = b;
		b = t;
	}
	s = (a + b) / 2;
	if (dd <= -s)
		return 0;
	if (dd >= s)
		return 1;
	if (b > 1e-12 && dd < b - s)
		return (dd + s) * (dd + s) / (2 * a * b);
	if (b > 1e-12 && dd > s - b)
		return 1 - (s - dd) * (s - dd) / (2 * a * b);
	return 0.5 + dd / a;
}

double verify_corner_area(const struct verify_corner *k, double i, double j)
{
	double ux[8] = {i - 0.5, i + 0.5, i + 0.5, i - 0.5};
	double uy[8] = {j - 0.5, j - 0.5, j + 0.5, j + 0.5};
	double a = 0, s = k->convex ? 1 : -1;
	int n = 4, cut[2];

	/* the convex side: the solid when convex, else the void (the square
	 * in both complements); a square wholly on one side of an edge needs
	 * no clipping */
	for (int e = 0; e < 2; e++) {
		double h = (fabs(k->nx[e]) + fabs(k->ny[e])) / 2; /* half the square's extent */
		double f = s * (k->nx[e] * i + k->ny[e] * j - k->d[e]); /* > 0: outside the side */
		if (f >= h)
			return k->convex ? 0 : 1;
		cut[e] = f > -h;
	}
	if (!cut[0] || !cut[1]) {
		int e = cut[0] ? 0 : 1;
		a = cut[e] ? line_area(s * k->nx[e], s * k->ny[e], s * k->d[e], i, j) : 1;
		return k->convex ? a : 1 - a;
	}
	for (int e = 0; e < 2 && n; e++)
		verify_subpx_clip(ux, uy, &n, s * k->nx[e], s * k->ny[e], s * k->d[e]);
	for (int p = 0; p < n; p++) {
		int q = (p + 1) % n;
		a += ux[p] * uy[q] - ux[q] * uy[p];
	}
	a = fabs(a) / 2;
	return k->convex ? a : 1 - a;
}

/* Parameters (angle, offset) per edge to a corner. */
static void corner_set(struct verify_corner *k, const double *th, int convex)
{
	k->n = 2;
	k->convex = convex;
	for (int e = 0; e < 2; e++) {
		k->nx[e] = cos(th[2 * e]);
		k->ny[e] = sin(th[2 * e]);
		k->d[e] = th[2 * e + 1];
	}
}

/* Weighted squared error of th over the window; r gets the residuals
 * when not NULL. */
static double corner_sse(const double *th, int convex, const double *c, const double *w, double *r)
{
	struct verify_corner k;
	double sse = 0;

	corner_set(&k, th, convex);
	for (int t = 0; t < NWIN; t++) {
		double e = verify_corner_area(&k, t % SIDE - WIN, t / SIDE - WIN) - c[t];
		sse += w[t] * e * e;
		if (r)
			r[t] = e;
	}
	return sse;
}

/* Solve the NPAR x NPAR system a x = b in place (partial pivoting); 0
 * when singular. */
static int solve(double a[NPAR][NPAR], double *b)
{
	const int m = NPAR;

	for (int c = 0; c < m; c++) {
		int p = c;
		for (int r = c + 1; r < m; r++)
			if (fabs(a[r][c]) > fabs(a[p][c]))
				p = r;
		if (fabs(a[p][c]) < 1e-15)
			return 0;
		if (p != c) {
			double t;
			for (int k = 0; k < m; k++) {
				t = a[c][k];
				a[c][k] = a[p][k];
				a[p][k] = t;
			}
			t = b[c];
			b[c] = b[p];
			b[p] = t;
		}
		for (int r = c + 1; r < m; r++) {
			double f = a[r][c] / a[c][c];
			for (int k = c; k < m; k++)
				a[r][k] -= f * a[c][k];
			b[r] -= f * b[c];
		}
	}
	for (int c = m - 1; c >= 0; c--) {
		for (int k = c + 1; k < m; k++)
			b[c] -= a[c][k] * b[k];
		b[c] /= a[c][c];
	}
	return 1;
}

/* Levenberg-Marquardt on th (forward-difference Jacobian, the areas
 * being piecewise quadratic in the parameters); returns the final
 * weighted squared error.  At most MAX_ITER steps of 5 window
 * evaluations (25 clipped squares each) and the damping's retries. */
static double corner_refine(double *th, int convex, const double *c, const double *w)
{
	double r[NWIN], jac[NWIN][NPAR], lambda = 1e-3, sse = corner_sse(th, convex, c, w, r);
	const int m = NPAR;

	for (int it = 0; it < MAX_ITER && sse > 1e-12; it++) {
		double a[NPAR][NPAR] = {{0}}, g[NPAR] = {0}, step = 0;
		int better = 0;
		for (int q = 0; q < m; q++) {
			double t[NPAR], rq[NWIN], h = 1e-6;
			memcpy(t, th, sizeof t);
			t[q] += h;
			corner_sse(t, convex, c, w, rq);
			for (int s = 0; s < NWIN; s++)
				jac[s][q] = (rq[s] - r[s]) / h;
		}
		for (int s = 0; s < NWIN; s++)
			for (int p = 0; p < m; p++) {
				g[p] += w[s] * jac[s][p] * r[s];
				for (int q = 0; q < m; q++)
					a[p][q] += w[s] * jac[s][p] * jac[s][q];
			}
		while (lambda < 1e6) {
			double ma[NPAR][NPAR], dlt[NPAR], t[NPAR], rt[NWIN], st;
			memcpy(ma, a, sizeof ma);
			for (int p = 0; p < m; p++) {
				ma[p][p] += lambda * (a[p][p] + 1e-9);
				dlt[p] = -g[p];
			}
			if (!solve(ma, dlt)) {
				lambda *= 10;
				continue;
			}
			memcpy(t, th, sizeof t);
			for (int p = 0; p < m; p++)
				t[p] += dlt[p];
			st = corner_sse(t, convex, c, w, rt);
			if (st < sse) {
				for (int p = 0; p < m; p++)
					step += fabs(dlt[p]);
				memcpy(th, t, sizeof t);
				memcpy(r, rt, sizeof r);
				sse = st;
				lambda = fmax(lambda * 0.3, 1e-9);
				better = 1;
				break;
			}
			lambda *= 10;
		}
		if (!better || step < 1e-7)
			break;
	}
	return sse;
}

/* The straight edges of the window's grey pixels: angle of the normal
 * and offset, both in the centre pixel's frame. */
struct edges {
	int n;
	double ang[NWIN], d[NWIN];
};

/* Start from the window's two edges most turned from each other; 0 when
 * they turn by less than VERIFY_CORNER_MIN_TURN_DEG. */
static int corner_start(const struct edges *ed, double *th)
{
	double best = -1;

	for (int p = 0; p < ed->n; p++)
		for (int q = p + 1; q < ed->n; q++) {
			double t = fabs(remainder(ed->ang[p] - ed->ang[q], 2 * M_PI));
			if (t > best) {
				best = t;
				th[0] = ed->ang[p];
				th[1] = ed->d[p];
				th[2] = ed->ang[q];
				th[3] = ed->d[q];
			}
		}
	return best >= VERIFY_CORNER_MIN_TURN_DEG * M_PI / 180;
}

/* Refine phase `convex` from th; 1 with *k set when it passes corner.h's
 * tests against sse_line, the one straight edge's error. */
static int fit_phase(const double *th0, int convex, const double *c, const double *w,
		     double sse_line, struct verify_corner *k)
{
	double th[NPAR], r[NWIN];

	memcpy(th, th0, sizeof th);
	if (!(corner_refine(th, convex, c, w) <= VERIFY_CORNER_GAIN * sse_line))
		return 0;
	/* every pixel of the window explained, not only on average: not so
	 * where it holds a third edge */
	corner_sse(th, convex, c, w, r);
	for (int t = 0; t < NWIN; t++)
		if (fabs(r[t]) > VERIFY_CORNER_FIT_TOL)
			return 0;
	if (fabs(remainder(th[0] - th[2], 2 * M_PI)) < VERIFY_CORNER_MIN_TURN_DEG * M_PI / 180)
		return 0;
	corner_set(k, th, convex);
	return 1;
}

/* Fit the phase that starts nearer first, the other when it fails. */
static int fit_edges(const struct edges *ed, const double *c, const double *w, double sse_line,
		     struct verify_corner *k)
{
	double th[NPAR];
	int first;

	if (!corner_start(ed, th))
		return 0;
	first = corner_sse(th, 1, c, w, NULL) < corner_sse(th, 0, c, w, NULL);
	return fit_phase(th, first, c, w, sse_line, k) || fit_phase(th, !first, c, w, sse_line, k);
}

struct memo_slot {
	uint8_t key[KEY];
	uint8_t used;
	struct verify_corner k;
};

struct verify_fit_memo {
	pthread_mutex_t lock[MEMO_LOCKS]; /* slot s under lock[s % MEMO_LOCKS] */
	int nlock;                        /* locks initialised */
	struct memo_slot *slot;           /* mask + 1 slots, owned */
	size_t mask;                      /* slots - 1 (a power of two less one) */
	atomic_size_t lookups, hits;      /* verify_fit_memo_stats */
};

void verify_fit_memo_free(struct verify_fit_memo *m)
{
	if (!m)
		return;
	for (int i = 0; i < m->nlock; i++)
		pthread_mutex_destroy(&m->lock[i]);
	mem_free(m->slot);
	mem_free(m);
}

struct verify_fit_memo *verify_fit_memo_new(size_t slots)
{
	struct verify_fit_memo *m = mem_calloc(1, sizeof *m);
	size_t n = 1;

	if (!m)
		return NULL;
	if (slots == 0)
		slots = VERIFY_FIT_MEMO_SLOTS;
	while (n <= slots / 2)
		n *= 2;
	m->mask = n - 1;
	atomic_init(&m->lookups, 0);
	atomic_init(&m->hits, 0);
	m->slot = mem_calloc(n, sizeof *m->slot);
	for (; m->slot && m->nlock < MEMO_LOCKS; m->nlock++)
		if (pthread_mutex_init(&m->lock[m->nlock], NULL) != 0)
			break;
	if (!m->slot || m->nlock < MEMO_LOCKS) {
		verify_fit_memo_free(m);
		return NULL;
	}
	return m;
}

/* The neighbourhood a fit reads (pixels beyond the crop read 0) and its
 * slot in m (FNV-1a). */
static size_t memo_key(const struct verify_fit_memo *m, const struct verify_subpx_img *im, int x,
		       int y, uint8_t *key)
{
	uint64_t h = 14695981039346656037ull;

	for (int t = 0; t < KEY; t++) {
		key[t] = (uint8_t)verify_subpx_gray(im, x + t % KSIDE - KWIN, y + t / KSIDE - KWIN);
		h = (h ^ key[t]) * 1099511628211ull;
	}
	return (size_t)(h ^ (h >> 29)) & m->mask;
}

static int memo_get(struct verify_fit_memo *m, size_t at, const uint8_t *key,
		    struct verify_corner *k)
{
	struct memo_slot *s = &m->slot[at];
	int hit;

	pthread_mutex_lock(&m->lock[at % MEMO_LOCKS]);
	hit = s->used && memcmp(s->key, key, KEY) == 0;
	if (hit)
		*k = s->k;
	pthread_mutex_unlock(&m->lock[at % MEMO_LOCKS]);
	atomic_fetch_add_explicit(&m->lookups, 1, memory_order_relaxed);
	if (hit)
		atomic_fetch_add_explicit(&m->hits, 1, memory_order_relaxed);
	return hit;
}

void verify_fit_memo_stats(const struct verify_fit_memo *m, size_t *lookups, size_t *hits)
{
	*lookups = atomic_load(&m->lookups);
	*hits = atomic_load(&m->hits);
}

static void memo_put(struct verify_fit_memo *m, size_t at, const uint8_t *key,
		     const struct verify_corner *k)
{
	struct memo_slot *s = &m->slot[at];

	pthread_mutex_lock(&m->lock[at % MEMO_LOCKS]);
	memcpy(s->key, key, KEY);
	s->used = 1;
	s->k = *k;
	pthread_mutex_unlock(&m->lock[at % MEMO_LOCKS]);
}

/* The fit past the gate: c the 5 x 5 coverage, (nx, ny, d) the pixel's
 * one straight edge. */
static void fit_window(const struct verify_subpx_img *im, int x, int y, const double *c, double nx,
		       double ny, double d, struct verify_corner *k)
{
	struct edges ed;
	double w[NWIN], sse_line = 0, lo = -2, hi = 2, d0, d1;

	for (int t = 0; t < NWIN; t++) {
		int i = t % SIDE - WIN, j = t / SIDE - WIN;
		double e = line_area(nx, ny, d, i, j) - c[t];
		w[t] = i == 0 && j == 0 ? CENTRE_WEIGHT : 1;
		sse_line += w[t] * e * e;
	}
	ed.n = 0;
	for (int t = 0; t < NWIN; t++) {
		int i = t % SIDE - WIN, j = t / SIDE - WIN;
		double mx, my, md;
		if (c[t] <= 0 || c[t] >= 1 || !verify_subpx_line(im, x + i, y + j, &mx, &my, &md))
			continue;
		ed.ang[ed.n] = atan2(my, mx);
		ed.d[ed.n++] = md + mx * i + my * j; /* to the centre pixel's frame */
	}
	/* 4 parameters: at least 5 grey pixels.  A third edge in the window
	 * (the last hole of a closing roof, an outline jagged at the pixel's
	 * scale) fails the fit; three or four edges fitted there are not
	 * determined by the few grey pixels of a small hole (a square hole's
	 * coverage fits a turned quadrilateral as well) and read worse than
	 * one edge: not tried */
	if (ed.n < 5 || !fit_edges(&ed, c, w, sse_line, k)) {
		k->n = 0;
		return;
	}
	/* the pixel's own coverage exactly: both offsets moved alike (the
	 * area grows with them), by bisection */
	d0 = k->d[0];
	d1 = k->d[1];
	for (int it = 0; it < 40; it++) {
		double mid = (lo + hi) / 2;
		k->d[0] = d0 + mid;
		k->d[1] = d1 + mid;
		if (verify_corner_area(k, 0, 0) < c[NWIN / 2])
			lo = mid;
		else
			hi = mid;
	}
	k->d[0] = d0 + (lo + hi) / 2;
	k->d[1] = d1 + (lo + hi) / 2;
}

void verify_corner_fit(const struct verify_subpx_img *im, int x, int y, struct verify_corner *k)
{
	uint8_t key[KEY];
	double c[NWIN], nx, ny, d, gate = 0;
	size_t at = 0;

	k->n = 0;
	if (!verify_subpx_line(im, x, y, &nx, &ny, &d))
		return;
	for (int t = 0; t < NWIN; t++)
		c[t] = verify_subpx_gray(im, x + t % SIDE - WIN, y + t / SIDE - WIN) / 255.0;
	/* the one straight edge predicts the 8 neighbours: no corner */
	for (int j = -1; j <= 1; j++)
		for (int i = -1; i <= 1; i++)
			gate = fmax(gate, fabs(line_area(nx, ny, d, i, j) -
					       c[(j + WIN) * SIDE + i + WIN]));
	if (gate <= VERIFY_CORNER_GATE)
		return;
	if (im->memo) {
		at = memo_key(im->memo, im, x, y, key);
		if (memo_get(im->memo, at, key, k))
			return;
	}
	fit_window(im, x, y, c, nx, ny, d, k);
	if (im->memo)
		memo_put(im->memo, at, key, k);
}
