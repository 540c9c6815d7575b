/* path.c - integer 2D polygons (see path.h). */
#include "engine/geom/path.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <stdlib.h>
#include <string.h>

void path_init(struct path *p)
{
	memset(p, 0, sizeof *p);
}

void path_fini(struct path *p)
{
	mem_free(p->pts);
	memset(p, 0, sizeof *p);
}

int path_push(struct path *p, struct pt2 q)
{
	void *arr = p->pts;

	if (p->n == p->cap) {
		if (mem_grow(&arr, &p->cap, p->n + 1, sizeof *p->pts))
			return ERR_NOMEM;
		p->pts = arr;
	}
	p->pts[p->n++] = q;
	return 0;
}

int path_copy(struct path *dst, const struct path *src)
{
	struct path t;

	path_init(&t);
	if (src->n) {
		t.pts = mem_alloc(src->n * sizeof *t.pts);
		if (!t.pts)
			return ERR_NOMEM;
		memcpy(t.pts, src->pts, src->n * sizeof *t.pts);
		t.n = t.cap = src->n;
	}
	path_fini(dst);
	*dst = t;
	return 0;
}

void paths_init(struct paths *ps)
{
	memset(ps, 0, sizeof *ps);
}

void paths_clear(struct paths *ps)
{
	for (size_t i = 0; i < ps->n; i++)
		path_fini(&ps->v[i]);
	ps->n = 0;
}

void paths_fini(struct paths *ps)
{
	paths_clear(ps);
	mem_free(ps->v);
	memset(ps, 0, sizeof *ps);
}

struct path *paths_add(struct paths *ps)
{
	void *arr = ps->v;

	if (mem_grow(&arr, &ps->cap, ps->n + 1, sizeof *ps->v))
		return NULL;
	ps->v = arr;
	path_init(&ps->v[ps->n]);
	return &ps->v[ps->n++];
}

int paths_add_pts(struct paths *ps, const struct pt2 *pts, size_t n)
{
	struct path *p = paths_add(ps);

	if (!p)
		return ERR_NOMEM;
	if (n == 0)
		return 0;
	p->pts = mem_alloc(n * sizeof *pts);
	if (!p->pts) {
		ps->n--;
		return ERR_NOMEM;
	}
	memcpy(p->pts, pts, n * sizeof *pts);
	p->n = p->cap = n;
	return 0;
}

int paths_copy(struct paths *dst, const struct paths *src)
{
	struct paths t;

	paths_init(&t);
	for (size_t i = 0; i < src->n; i++) {
		if (paths_add_pts(&t, src->v[i].pts, src->v[i].n)) {
			paths_fini(&t);
			return ERR_NOMEM;
		}
	}
	paths_fini(dst);
	*dst = t;
	return 0;
}

int paths_append_move(struct paths *dst, struct paths *src)
{
	void *arr = dst->v;

	if (src->n == 0)
		return 0;
	if (mem_grow(&arr, &dst->cap, dst->n + src->n, sizeof *dst->v))
		return ERR_NOMEM;
	dst->v = arr;
	memcpy(dst->v + dst->n, src->v, src->n * sizeof *src->v);
	dst->n += src->n;
	src->n = 0;
	return 0;
}

size_t paths_point_count(const struct paths *ps)
{
	size_t k = 0;

	for (size_t i = 0; i < ps->n; i++)
		k += ps->v[i].n;
	return k;
}

__int128 path_area2_nm2(const struct path *p)
{
	__int128 a = 0;

	if (p->n < 3)
		return 0;
	for (size_t i = 0, j = p->n - 1; i < p->n; j = i++)
		a += (__int128)p->pts[j].x * p->pts[i].y - (__int128)p->pts[i].x * p->pts[j].y;
	return a;
}

double path_area_mm2(const struct path *p)
{
	return (double)path_area2_nm2(p) * 0.5 / (GEOM_NM_PER_MM * GEOM_NM_PER_MM);
}

double paths_area_mm2(const struct paths *ps)
{
	__int128 a = 0;

	for (size_t i = 0; i < ps->n; i++)
		a += path_area2_nm2(&ps->v[i]);
	return (double)a * 0.5 / (GEOM_NM_PER_MM * GEOM_NM_PER_MM);
}

double path_length_mm(const struct path *p, int closed)
{
	double l = 0;

	for (size_t i = 1; i < p->n; i++)
		l += hypot((double)(p->pts[i].x - p->pts[i - 1].x),
			   (double)(p->pts[i].y - p->pts[i - 1].y));
	if (closed && p->n > 2)
		l += hypot((double)(p->pts[0].x - p->pts[p->n - 1].x),
			   (double)(p->pts[0].y - p->pts[p->n - 1].y));
	return l / GEOM_NM_PER_MM;
}

void path_reverse(struct path *p)
{
	for (size_t i = 0, j = p->n ? p->n - 1 : 0; i < j; i++, j--) {
		struct pt2 t = p->pts[i];
		p->pts[i] = p->pts[j];
		p->pts[j] = t;
	}
}

/* Sign of the cross product (b - a) x (q - a) computed exactly. */
static int orient(struct pt2 a, struct pt2 b, struct pt2 q)
{
	__int128 c = (__int128)(b.x - a.x) * (q.y - a.y) - (__int128)(b.y - a.y) * (q.x - a.x);
	return (c > 0) - (c < 0);
}

static int on_segment(struct pt2 a, struct pt2 b, struct pt2 q)
{
	if (orient(a, b, q) != 0)
		return 0;
	return q.x >= (a.x < b.x ? a.x : b.x) && q.x <= (a.x > b.x ? a.x : b.x) &&
	       q.y >= (a.y < b.y ? a.y : b.y) && q.y <= (a.y > b.y ? a.y : b.y);
}

int path_edge_winding(struct pt2 a, struct pt2 b, struct pt2 q, int *on_edge)
{
	if (on_segment(a, b, q)) {
		*on_edge = 1;
		return 0;
	}
	if (a.y <= q.y)
		return b.y > q.y && orient(a, b, q) > 0 ? 1 : 0;
	return b.y <= q.y && orient(a, b, q) < 0 ? -1 : 0;
}

int paths_winding(const struct paths *ps, struct pt2 q)
{
	int w = 0, on = 0;

	for (size_t k = 0; k < ps->n; k++) {
		const struct path *p = &ps->v[k];
		if (p->n < 2)
			continue;
		for (size_t i = 0, j = p->n - 1; i < p->n; j = i++) {
			w += path_edge_winding(p->pts[j], p->pts[i], q, &on);
			if (on)
				return 1;
		}
	}
	return w;
}

int paths_bbox(const struct paths *ps, struct pt2 *lo, struct pt2 *hi)
{
	int any = 0;

	for (size_t k = 0; k < ps->n; k++) {
		for (size_t i = 0; i < ps->v[k].n; i++) {
			struct pt2 q = ps->v[k].pts[i];
			if (!any) {
				*lo = *hi = q;
				any = 1;
				continue;
			}
			if (q.x < lo->x) lo->x = q.x;
			if (q.y < lo->y) lo->y = q.y;
			if (q.x > hi->x) hi->x = q.x;
			if (q.y > hi->y) hi->y = q.y;
		}
	}
	return any;
}

void paths_measure(const struct paths *ps, struct path_measure *m)
{
	for (size_t i = 0; i < ps->n; i++) {
		struct paths one = {(struct path *)&ps->v[i], 1, 1};
		m[i].area2_nm2 = (double)path_area2_nm2(&ps->v[i]);
		if (!paths_bbox(&one, &m[i].lo, &m[i].hi)) {
			m[i].lo = (struct pt2){1, 1};
			m[i].hi = (struct pt2){0, 0};
		}
	}
}

double path_measure_mm2(const struct path_measure *m)
{
	return m->area2_nm2 * 0.5 / (GEOM_NM_PER_MM * GEOM_NM_PER_MM);
}

int path_holds(const struct path *p, const struct path_measure *m, struct pt2 q)
{
	struct paths one = {(struct path *)p, 1, 1};

	if (q.x < m->lo.x || q.x > m->hi.x || q.y < m->lo.y || q.y > m->hi.y)
		return 0;
	return paths_winding(&one, q) != 0;
}

/* An outer loop of paths_hole_owners: its index and twice its area. */
struct loop_area {
	double area2;
	size_t i;
};

static int cmp_loop_area(const void *pa, const void *pb)
{
	const struct loop_area *a = pa, *b = pb;

	if (a->area2 != b->area2)
		return a->area2 < b->area2 ? -1 : 1;
	return (a->i > b->i) - (a->i < b->i);
}

int paths_hole_owners(const struct paths *ps, const struct path_measure *m, size_t *owner)
{
	struct path_measure *own = NULL;
	struct loop_area *lb;
	size_t no = 0;

	if (ps->n == 0)
		return 0;
	lb = mem_alloc(ps->n * sizeof *lb);
	if (!m)
		m = own = mem_alloc(ps->n * sizeof *own);
	if (!lb || !m) {
		mem_free(lb);
		return ERR_NOMEM;
	}
	if (own)
		paths_measure(ps, own);
	/* the outer loops into lb, the holes marked owner 0 until their
	 * owner is found (paths under 3 points have area 0) */
	for (size_t i = 0; i < ps->n; i++) {
		owner[i] = m[i].area2_nm2 < 0 ? 0 : SIZE_MAX;
		if (m[i].area2_nm2 > 0)
			lb[no++] = (struct loop_area){m[i].area2_nm2, i};
	}
	/* smallest first: the first loop around a hole is its owner */
	qsort(lb, no, sizeof *lb, cmp_loop_area);
	for (size_t i = 0; i < ps->n; i++) {
		struct pt2 q;
		if (owner[i] == SIZE_MAX)
			continue;
		owner[i] = SIZE_MAX;
		q = ps->v[i].pts[0];
		for (size_t k = 0; k < no; k++)
			if (path_holds(&ps->v[lb[k].i], &m[lb[k].i], q)) {
				owner[i] = lb[k].i;
				break;
			}
	}
	mem_free(lb);
	mem_free(own);
	return 0;
}

double paths_distance_mm(const struct paths *ps, struct pt2 q)
{
	double best = INFINITY;

	for (size_t k = 0; k < ps->n; k++) {
		const struct path *p = &ps->v[k];
		for (size_t i = 0, j = p->n ? p->n - 1 : 0; i < p->n; j = i++) {
			double ax = (double)p->pts[j].x, ay = (double)p->pts[j].y;
			double dx = (double)p->pts[i].x - ax, dy = (double)p->pts[i].y - ay;
			double px = (double)q.x - ax, py = (double)q.y - ay;
			double l2 = dx * dx + dy * dy, t = l2 > 0 ? (px * dx + py * dy) / l2 : 0;
			double d;
			if (t < 0) t = 0;
			if (t > 1) t = 1;
			d = hypot(px - t * dx, py - t * dy);
			if (d < best)
				best = d;
		}
	}
	return best / GEOM_NM_PER_MM;
}
