/* tree.c - the rhombic cell hierarchy as a quadtree in the sheared (s, r)
 * lattice times a binary subdivision along v (rhombic.h; docs/rhombic.md
 * sections 1-2): frame and root (eq. 1-4), cell geometry and cavities
 * (eq. 2), splitting, point location by integer arithmetic.
 */
#include "engine/rhombic/rhombic.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"

#include <math.h>
#include <string.h>

void rh_to_cell(const struct rh_frame *f, double x, double y, double *u, double *v)
{
	*u = x * f->cos_o + y * f->sin_o;
	*v = -x * f->sin_o + y * f->cos_o;
}

void rh_to_printer(const struct rh_frame *f, double u, double v, double *x, double *y)
{
	*x = u * f->cos_o - v * f->sin_o;
	*y = u * f->sin_o + v * f->cos_o;
}

double rh_face_distance(double a, double b)
{
	return 2 * a * b / sqrt(a * a + b * b);
}

void rh_frame_init(struct rh_frame *f, const struct mesh *m, double alpha_rad, double orient_deg,
		   double wall_mm, double tau_mm)
{
	double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
	double zmin = INFINITY, zmax = -INFINITY, slope, w;

	memset(f, 0, sizeof *f);
	f->orient_deg = orient_deg;
	f->cos_o = cos(orient_deg * M_PI / 180);
	f->sin_o = sin(orient_deg * M_PI / 180);
	for (size_t i = 0; i < m->nv; i++) {
		double u, v;
		rh_to_cell(f, m->v[i].x, m->v[i].y, &u, &v);
		umin = fmin(umin, u);
		umax = fmax(umax, u);
		vmin = fmin(vmin, v);
		vmax = fmax(vmax, v);
		zmin = fmin(zmin, m->v[i].z);
		zmax = fmax(zmax, m->v[i].z);
	}
	/* eq. 1: h / w = tan(pi/2 - alpha); eq. 3-4: the inner box (w/2, h/2)
	 * holds (L_u, L_z), so w = max(2 L_u, 2 L_z / tan(pi/2 - alpha)) */
	slope = tan(M_PI / 2 - alpha_rad);
	w = fmax(2 * (umax - umin), 2 * (zmax - zmin) / slope);
	f->cu_mm = (umin + umax) / 2;
	f->cz_mm = (zmin + zmax) / 2;
	f->a0_mm = w / 2;
	f->b0_mm = w / 2 * slope;
	f->v0_mm = vmin + tau_mm;
	f->e_mm = vmax - vmin - 2 * tau_mm;
	f->t_mm = wall_mm / 2;
	f->tmin_mm = wall_mm;
	f->max_level = -1;
	for (int L = 0; L <= RH_MAX_LEVEL; L++) {
		double wl = ldexp(w, -L), ev;
		int mm = 0;
		while (f->e_mm > 0 && ldexp(f->e_mm, -mm) > wl && mm < 62)
			mm++;
		f->vsplit[L] = mm;
		ev = ldexp(f->e_mm, -mm);
		if (!(w > 0) || !(f->e_mm > 0) ||
		    rh_face_distance(ldexp(f->a0_mm, -L), ldexp(f->b0_mm, -L)) < 2 * f->tmin_mm ||
		    ev < 2 * f->tmin_mm)
			break;
		f->max_level = L;
	}
}

void rh_cell_geom(const struct rh_frame *f, const struct rh_cell *c, struct rh_geom *g)
{
	double h = ldexp(1.0, -(int)c->level);
	double sc = -0.5 + (c->i + 0.5) * h, rc = -0.5 + (c->j + 0.5) * h;
	double ev = ldexp(f->e_mm, -f->vsplit[c->level]);

	g->cu = f->cu_mm + f->a0_mm * (sc - rc);
	g->cz = f->cz_mm + f->b0_mm * (sc + rc);
	g->a = f->a0_mm * h;
	g->b = f->b0_mm * h;
	g->vlo = f->v0_mm + c->kv * ev;
	g->vhi = g->vlo + ev;
}

void rh_cell_cavity(const struct rh_frame *f, const struct rh_cell *c, struct rh_cavity *cv)
{
	struct rh_geom g;

	rh_cell_geom(f, c, &g);
	cv->cu = g.cu;
	cv->cz = g.cz;
	cv->a = g.a;
	cv->b = g.b;
	/* the edge p + q = 1 moved inward by t: its distance from the centre
	 * 1 / sqrt(1/a^2 + 1/b^2) less t, in units of that distance */
	cv->k = 1 - f->t_mm * sqrt(1 / (g.a * g.a) + 1 / (g.b * g.b));
	cv->vlo = g.vlo + f->t_mm;
	cv->vhi = g.vhi - f->t_mm;
	cv->zlo = g.cz - g.b * cv->k;
	cv->zhi = g.cz + g.b * cv->k;
	cv->volume_mm3 = cv->k > 0 && cv->vhi > cv->vlo
				 ? 2 * g.a * g.b * cv->k * cv->k * (cv->vhi - cv->vlo)
				 : 0;
}

void rh_tree_init(struct rh_tree *t, const struct rh_frame *f)
{
	memset(t, 0, sizeof *t);
	t->f = *f;
}

void rh_tree_fini(struct rh_tree *t)
{
	mem_free(t->c);
	memset(t, 0, sizeof *t);
}

static int32_t push_cell(struct rh_tree *t, int L, int32_t i, int32_t j, int32_t kv,
			 int32_t parent, struct err *e)
{
	struct rh_cell *c;

	if (t->n >= INT32_MAX - 8)
		return ERR_SET(e, ERR_LIMIT, "rhombic: more than 2^31 cells");
	if (mem_grow((void **)&t->c, &t->cap, t->n + 1, sizeof *t->c))
		return ERR_SET(e, ERR_NOMEM, "rhombic: out of memory for %zu cells", t->n + 1);
	c = &t->c[t->n];
	c->i = i;
	c->j = j;
	c->kv = kv;
	c->parent = parent;
	c->child = -1;
	c->level = (uint8_t)L;
	c->nchild = 0;
	c->state = RH_OUT;
	return (int32_t)t->n++;
}

int rh_tree_roots(struct rh_tree *t, struct err *e)
{
	int32_t n = (int32_t)1 << t->f.vsplit[0];

	if (t->f.vsplit[0] > 20)
		return ERR_SET(e, ERR_LIMIT, "rhombic: the part is more than 2^20 root cells long");
	for (int32_t k = 0; k < n; k++) {
		int32_t rc = push_cell(t, 0, 0, 0, k, -1, e);
		if (rc < 0)
			return rc;
	}
	t->nroots = n;
	return 0;
}

int rh_tree_can_split(const struct rh_tree *t, int32_t idx)
{
	return (int)t->c[idx].level < t->f.max_level;
}

int rh_tree_split(struct rh_tree *t, int32_t idx, struct err *e)
{
	struct rh_cell p = t->c[idx];
	int L = p.level + 1;
	int vsplit = t->f.vsplit[L] > t->f.vsplit[p.level];
	int32_t first = (int32_t)t->n;

	if (p.child >= 0 || L > t->f.max_level)
		return ERR_SET(e, ERR_INTERNAL, "rhombic: cell %d cannot be split", (int)idx);
	for (int dv = 0; dv <= vsplit; dv++)
		for (int dj = 0; dj < 2; dj++)
			for (int di = 0; di < 2; di++) {
				int32_t rc = push_cell(t, L, 2 * p.i + di, 2 * p.j + dj,
						       vsplit ? 2 * p.kv + dv : p.kv, idx, e);
				if (rc < 0)
					return rc;
			}
	t->c[idx].child = first;
	t->c[idx].nchild = (uint8_t)(vsplit ? 8 : 4);
	t->c[idx].state = RH_SPLIT;
	return 0;
}

int32_t rh_tree_locate(const struct rh_tree *t, double x, double y, double z)
{
	const struct rh_frame *f = &t->f;
	double u, v, p, q, s, r, w;
	int32_t idx;

	if (t->nroots <= 0)
		return -1;
	rh_to_cell(f, x, y, &u, &v);
	p = (u - f->cu_mm) / f->a0_mm;
	q = (z - f->cz_mm) / f->b0_mm;
	s = (p + q) / 2 + 0.5;
	r = (q - p) / 2 + 0.5;
	w = (v - f->v0_mm) / f->e_mm;
	if (!(s >= 0 && s < 1 && r >= 0 && r < 1 && w >= 0 && w < 1))
		return -1;
	/* powers of two scale exactly, so floor(2^(L+1) s) is 2 floor(2^L s)
	 * or one more: the child index below is 0 or 1 */
	idx = (int32_t)floor(ldexp(w, f->vsplit[0]));
	if (idx >= t->nroots)
		idx = t->nroots - 1;
	while (t->c[idx].state == RH_SPLIT) {
		const struct rh_cell *c = &t->c[idx];
		int L = c->level + 1;
		int32_t i = (int32_t)floor(ldexp(s, L)) - 2 * c->i;
		int32_t j = (int32_t)floor(ldexp(r, L)) - 2 * c->j;
		int32_t dv = 0;
		if (c->nchild == 8)
			dv = (int32_t)floor(ldexp(w, f->vsplit[L])) - 2 * c->kv;
		i = i < 0 ? 0 : i > 1 ? 1 : i;
		j = j < 0 ? 0 : j > 1 ? 1 : j;
		dv = dv < 0 ? 0 : dv > 1 ? 1 : dv;
		idx = c->child + (dv * 2 + j) * 2 + i;
	}
	return idx;
}

int rh_tree_in_cavity(const struct rh_tree *t, double x, double y, double z)
{
	int32_t idx = rh_tree_locate(t, x, y, z);
	struct rh_cavity cv;
	double u, v;

	if (idx < 0 || t->c[idx].state != RH_CAVITY)
		return 0;
	rh_cell_cavity(&t->f, &t->c[idx], &cv);
	rh_to_cell(&t->f, x, y, &u, &v);
	return fabs(u - cv.cu) / cv.a + fabs(z - cv.cz) / cv.b < cv.k && v > cv.vlo && v < cv.vhi;
}

void rh_tree_recount(struct rh_tree *t)
{
	t->cavities = 0;
	t->cavity_volume_mm3 = 0;
	for (size_t i = 0; i < t->n; i++)
		if (t->c[i].state == RH_CAVITY) {
			struct rh_cavity cv;
			rh_cell_cavity(&t->f, &t->c[i], &cv);
			t->cavities++;
			t->cavity_volume_mm3 += cv.volume_mm3;
		}
}

int rh_tree_refine(struct rh_tree *t, int32_t idx, double *added_mm3, struct err *e)
{
	struct rh_cavity cv;
	double added;
	int rc;

	if (t->c[idx].state != RH_CAVITY)
		return ERR_SET(e, ERR_INTERNAL, "rhombic: cell %d is not a cavity leaf", (int)idx);
	rh_cell_cavity(&t->f, &t->c[idx], &cv);
	added = cv.volume_mm3;
	if (!rh_tree_can_split(t, idx)) {
		t->c[idx].state = RH_SOLID;
		t->cavities--;
	} else {
		if ((rc = rh_tree_split(t, idx, e)) != 0)
			return rc;
		t->cavities--;
		for (int k = 0; k < t->c[idx].nchild; k++) {
			struct rh_cell *ch = &t->c[t->c[idx].child + k];
			struct rh_cavity cc;
			ch->state = RH_CAVITY;
			rh_cell_cavity(&t->f, ch, &cc);
			added -= cc.volume_mm3;
			t->cavities++;
		}
	}
	t->cavity_volume_mm3 -= added;
	if (added_mm3)
		*added_mm3 = added;
	return 0;
}

double rh_tree_refine_gain(const struct rh_tree *t, int32_t idx)
{
	struct rh_cavity cv;
	double add;

	rh_cell_cavity(&t->f, &t->c[idx], &cv);
	add = cv.volume_mm3;
	if (rh_tree_can_split(t, idx)) {
		/* the children's cavities: 4 or 8 cells of the next level */
		const struct rh_cell *c = &t->c[idx];
		struct rh_cell ch = *c;
		struct rh_cavity cc;
		int L = c->level + 1, n = t->f.vsplit[L] > t->f.vsplit[c->level] ? 8 : 4;
		ch.level = (uint8_t)L;
		ch.i = 2 * c->i;
		ch.j = 2 * c->j;
		ch.kv = n == 8 ? 2 * c->kv : c->kv;
		rh_cell_cavity(&t->f, &ch, &cc);
		add -= n * cc.volume_mm3;
	}
	return add;
}

int rh_tree_levels(const struct rh_tree *t)
{
	int L = 0;

	for (size_t i = 0; i < t->n; i++)
		if (t->c[i].state != RH_OUT && t->c[i].level + 1 > L)
			L = t->c[i].level + 1;
	return L;
}
