/* vec.h - 3D vectors and boxes in double precision millimetres.
 *
 * The one home of small 3D geometry helpers shared by every engine.
 * Frame: whatever the caller's (mesh file frame before placement,
 * printer frame after: x, y on the build plate, z up from the plate).
 */
#ifndef INFILLD_VEC_H
#define INFILLD_VEC_H

#include <math.h>

struct vec3 {
	double x, y, z;
};

struct box3 {
	struct vec3 lo, hi; /* empty when lo.x > hi.x */
};

static inline struct vec3 v3(double x, double y, double z)
{
	struct vec3 r = {x, y, z};
	return r;
}
static inline struct vec3 v3_add(struct vec3 a, struct vec3 b)
{
	return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline struct vec3 v3_sub(struct vec3 a, struct vec3 b)
{
	return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline struct vec3 v3_scale(struct vec3 a, double s)
{
	return v3(a.x * s, a.y * s, a.z * s);
}
static inline struct vec3 v3_madd(struct vec3 a, struct vec3 b, double s) /* a + b*s */
{
	return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
static inline double v3_dot(struct vec3 a, struct vec3 b)
{
	return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline struct vec3 v3_cross(struct vec3 a, struct vec3 b)
{
	return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline double v3_len2(struct vec3 a)
{
	return v3_dot(a, a);
}
static inline double v3_len(struct vec3 a)
{
	return sqrt(v3_dot(a, a));
}
static inline double v3_dist(struct vec3 a, struct vec3 b)
{
	return v3_len(v3_sub(a, b));
}
/* Unit vector; the zero vector stays zero. */
static inline struct vec3 v3_normalize(struct vec3 a)
{
	double l = v3_len(a);
	return l > 0 ? v3_scale(a, 1.0 / l) : a;
}
static inline struct vec3 v3_lerp(struct vec3 a, struct vec3 b, double t)
{
	return v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}
static inline double v3_comp(struct vec3 a, int axis) /* 0 = x, 1 = y, 2 = z */
{
	return axis == 0 ? a.x : axis == 1 ? a.y : a.z;
}

static inline struct box3 box3_empty(void)
{
	struct box3 b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
	return b;
}
static inline int box3_is_empty(struct box3 b)
{
	return !(b.lo.x <= b.hi.x && b.lo.y <= b.hi.y && b.lo.z <= b.hi.z);
}
static inline void box3_add(struct box3 *b, struct vec3 p)
{
	b->lo.x = fmin(b->lo.x, p.x);
	b->lo.y = fmin(b->lo.y, p.y);
	b->lo.z = fmin(b->lo.z, p.z);
	b->hi.x = fmax(b->hi.x, p.x);
	b->hi.y = fmax(b->hi.y, p.y);
	b->hi.z = fmax(b->hi.z, p.z);
}
static inline struct vec3 box3_size(struct box3 b)
{
	return v3_sub(b.hi, b.lo);
}
static inline struct vec3 box3_center(struct box3 b)
{
	return v3_scale(v3_add(b.lo, b.hi), 0.5);
}
static inline struct box3 box3_inflate(struct box3 b, double r)
{
	b.lo = v3_sub(b.lo, v3(r, r, r));
	b.hi = v3_add(b.hi, v3(r, r, r));
	return b;
}
static inline int box3_contains(struct box3 b, struct vec3 p)
{
	return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y &&
	       p.z >= b.lo.z && p.z <= b.hi.z;
}

#endif
