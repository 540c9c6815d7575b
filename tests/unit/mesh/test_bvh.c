/* test_bvh.c - BVH queries against brute force computed here.
 *
 * closest point: every triangle, with a distance routine written for the
 * test (plane projection + edge segments); ray: every triangle; inside:
 * ray parity over every triangle on closed meshes, a punched copy of a
 * closed mesh for the open case, and the Monte Carlo volume of the open
 * bunny; winding number: exact sum of solid angles.
 */
#include "harness.h"

#include "mesh_fixtures.h"

static struct mesh *load_repaired(const char *rel)
{
	struct mesh *m = NULL;
	struct mesh_report r;
	struct err e;
	char path[256];

	snprintf(path, sizeof path, "meshes/%s", rel);
	err_clear(&e);
	if (mesh_read_file(shared_path(path), MESH_FMT_AUTO, &m, NULL, &e) ||
	    mesh_repair(m, &r, &e)) {
		fprintf(stderr, "%s: %s\n", rel, e.msg);
		mesh_free(m);
		return NULL;
	}
	return m;
}

static double frand(void)
{
	return rand() / (double)RAND_MAX;
}

static struct vec3 sample_box(struct box3 b, double margin)
{
	struct vec3 s = box3_size(b);

	return v3(b.lo.x - margin * s.x + (1 + 2 * margin) * s.x * frand(),
		  b.lo.y - margin * s.y + (1 + 2 * margin) * s.y * frand(),
		  b.lo.z - margin * s.z + (1 + 2 * margin) * s.z * frand());
}

static double seg_dist2(struct vec3 p, struct vec3 a, struct vec3 b)
{
	struct vec3 ab = v3_sub(b, a);
	double t = v3_dot(v3_sub(p, a), ab) / v3_len2(ab);

	t = t < 0 ? 0 : t > 1 ? 1 : t;
	return v3_len2(v3_sub(p, v3_madd(a, ab, t)));
}

/* Squared distance point-triangle: inside the prism -> plane distance,
 * else the nearest edge. */
static double tri_dist2(struct vec3 p, struct vec3 a, struct vec3 b, struct vec3 c)
{
	struct vec3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
	double nn = v3_len2(n);

	if (nn > 0) {
		double s = v3_dot(v3_sub(p, a), n) / nn;
		struct vec3 q = v3_madd(p, n, -s);
		double u = v3_dot(v3_cross(v3_sub(c, b), v3_sub(q, b)), n);
		double v = v3_dot(v3_cross(v3_sub(a, c), v3_sub(q, c)), n);
		double w = v3_dot(v3_cross(v3_sub(b, a), v3_sub(q, a)), n);
		if (u >= 0 && v >= 0 && w >= 0)
			return s * s * nn;
	}
	return fmin(seg_dist2(p, a, b), fmin(seg_dist2(p, b, c), seg_dist2(p, c, a)));
}

static void test_closest(void)
{
	struct mesh *m = load_repaired("femur.off");
	struct mesh_report r;
	struct mesh_bvh *b = NULL;
	struct err e;
	int i;

	REQUIRE(m);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	srand(11);
	for (i = 0; i < 300; i++) {
		struct vec3 p = sample_box(r.bbox, 0.3), q;
		size_t t, tri, best_t = 0;
		double best = INFINITY, d = mesh_bvh_closest(b, p, &q, &tri);
		for (t = 0; t < m->nt; t++) {
			double d2 = tri_dist2(p, m->v[m->tri[3 * t]], m->v[m->tri[3 * t + 1]],
					      m->v[m->tri[3 * t + 2]]);
			if (d2 < best) {
				best = d2;
				best_t = t;
			}
		}
		CHECK_NEAR(d, sqrt(best), 1e-12);
		CHECK_NEAR(v3_dist(p, q), d, 1e-12);
		/* the reported triangle holds q at that distance */
		CHECK_NEAR(sqrt(tri_dist2(p, m->v[m->tri[3 * tri]], m->v[m->tri[3 * tri + 1]],
					  m->v[m->tri[3 * tri + 2]])),
			   d, 1e-12);
		(void)best_t;
	}
	mesh_bvh_free(b);
	mesh_free(m);
}

/* Brute-force ray against every triangle (Cramer's rule on
 * o + t d = a + u (b-a) + v (c-a)): nearest t > 0 and the number of hits;
 * *grazing when a hit is within eps (barycentric) of an edge. */
static double brute_ray(const struct mesh *m, struct vec3 o, struct vec3 d, double eps, int *hits,
			int *grazing)
{
	double best = INFINITY;
	size_t t;

	*grazing = 0;
	*hits = 0;
	for (t = 0; t < m->nt; t++) {
		struct vec3 a = m->v[m->tri[3 * t]], e1 = v3_sub(m->v[m->tri[3 * t + 1]], a),
			    e2 = v3_sub(m->v[m->tri[3 * t + 2]], a), rhs = v3_sub(o, a);
		struct vec3 nd = v3_scale(d, -1);
		double det = v3_dot(e1, v3_cross(e2, nd)), u, v, s;
		if (det == 0)
			continue;
		u = v3_dot(rhs, v3_cross(e2, nd)) / det;
		v = v3_dot(e1, v3_cross(rhs, nd)) / det;
		s = v3_dot(e1, v3_cross(e2, rhs)) / det;
		if (u < -eps || v < -eps || u + v > 1 + eps || s <= 0)
			continue;
		if (u < eps || v < eps || u + v > 1 - eps)
			*grazing = 1;
		(*hits)++;
		if (s < best)
			best = s;
	}
	return best;
}

static void test_ray(void)
{
	struct mesh *m = load_repaired("cow.off");
	struct mesh_report r;
	struct mesh_bvh *b = NULL;
	struct err e;
	int i, hits = 0;

	REQUIRE(m);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	srand(5);
	for (i = 0; i < 400; i++) {
		struct vec3 o = sample_box(r.bbox, 0.2);
		struct vec3 d = v3_normalize(v3(frand() - 0.5, frand() - 0.5, frand() - 0.5));
		size_t tri = 0;
		int grazing, crossings;
		double t = mesh_bvh_ray(b, o, d, &tri);
		double tb = brute_ray(m, o, d, 1e-9, &crossings, &grazing);
		if (grazing)
			continue;
		if (isinf(tb)) {
			CHECK(isinf(t));
		} else {
			CHECK_NEAR(t, tb, 1e-9 * (1 + tb));
			hits++;
		}
	}
	CHECK_INT(hits, >, 50);
	mesh_bvh_free(b);
	mesh_free(m);
}

static double exact_winding(const struct mesh *m, struct vec3 p)
{
	double w = 0;
	size_t t;

	for (t = 0; t < m->nt; t++) {
		struct vec3 a = v3_sub(m->v[m->tri[3 * t]], p), b = v3_sub(m->v[m->tri[3 * t + 1]], p),
			    c = v3_sub(m->v[m->tri[3 * t + 2]], p);
		double la = v3_len(a), lb = v3_len(b), lc = v3_len(c);
		w += 2 * atan2(v3_dot(a, v3_cross(b, c)),
			       la * lb * lc + v3_dot(a, b) * lc + v3_dot(b, c) * la +
				       v3_dot(c, a) * lb);
	}
	return w / (4 * M_PI);
}

static void test_inside_closed(void)
{
	static const char *const files[] = {"armadillo.off", "knot1.off", "fandisk.off"};
	size_t f;

	for (f = 0; f < sizeof files / sizeof files[0]; f++) {
		struct mesh *m = load_repaired(files[f]);
		struct mesh_report r;
		struct mesh_bvh *b = NULL;
		struct err e;
		int i, inside = 0, n = f == 0 ? 120 : 300;
		REQUIRE(m);
		REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
		REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
		srand(17 + (unsigned)f);
		for (i = 0; i < n; i++) {
			struct vec3 p = sample_box(r.bbox, 0.05);
			struct vec3 d = v3_normalize(v3(frand() - 0.5, frand() - 0.5, frand() - 0.5));
			int grazing, hits, par;
			(void)brute_ray(m, p, d, 1e-7, &hits, &grazing);
			par = hits & 1;
			double w = mesh_bvh_winding(b, p);
			if (grazing)
				continue;
			CHECK_EQ_INT(mesh_bvh_inside(b, p), par);
			/* the fast winding number agrees with the exact one */
			CHECK_NEAR(w, exact_winding(m, p), 0.05);
			CHECK_NEAR(w, par, 0.05);
			inside += par;
		}
		CHECK_INT(inside, >, n / 20);
		mesh_bvh_free(b);
		mesh_free(m);
	}
}

/* Remove faces near a point: the winding number still decides like the
 * closed original away from the holes. */
static void test_inside_punched(void)
{
	struct mesh *m = load_repaired("camel.off"), *holed;
	struct mesh_report r;
	struct mesh_bvh *bc = NULL, *bh = NULL;
	struct err e;
	struct vec3 centre[3];
	size_t t, kept = 0;
	int i, k, checked = 0;

	REQUIRE(m);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	holed = mesh_clone(m);
	REQUIRE(holed);
	for (k = 0; k < 3; k++)
		centre[k] = m->v[m->tri[3 * (size_t)(k * 5000)]];
	for (t = 0; t < m->nt; t++) {
		struct vec3 c = m->v[m->tri[3 * t]];
		int drop = 0;
		for (k = 0; k < 3; k++)
			drop |= v3_dist(c, centre[k]) < 0.02;
		if (drop)
			continue;
		memcpy(holed->tri + 3 * kept, m->tri + 3 * t, 3 * sizeof *m->tri);
		kept++;
	}
	holed->nt = kept;
	CHECK_INT(kept, <, m->nt - 10);
	REQUIRE_OK(mesh_bvh_new(m, &bc, &e), &e);
	REQUIRE_OK(mesh_bvh_new(holed, &bh, &e), &e);
	srand(23);
	for (i = 0; i < 2000; i++) {
		struct vec3 p = sample_box(r.bbox, 0.05);
		int near = 0;
		for (k = 0; k < 3; k++)
			near |= v3_dist(p, centre[k]) < 0.06;
		if (near || mesh_bvh_closest(bc, p, NULL, NULL) < 0.004)
			continue;
		CHECK_EQ_INT(mesh_bvh_inside(bh, p), mesh_bvh_inside(bc, p));
		checked++;
	}
	CHECK_INT(checked, >, 1000);
	mesh_bvh_free(bc);
	mesh_bvh_free(bh);
	mesh_free(holed);
	mesh_free(m);
}

/* Open bunny: Monte Carlo volume from the inside test matches the
 * divergence-theorem volume (the holes are small). */
static void test_inside_bunny_volume(void)
{
	struct mesh *m = load_repaired("bunny.stl");
	struct mesh_report r;
	struct mesh_bvh *b = NULL;
	struct err e;
	struct vec3 s;
	int i, in = 0, n = 20000;

	REQUIRE(m);
	REQUIRE_OK(mesh_analyze(m, &r, &e), &e);
	CHECK_EQ_INT(r.border_edges, 223);
	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	s = box3_size(r.bbox);
	srand(29);
	for (i = 0; i < n; i++)
		in += mesh_bvh_inside(b, sample_box(r.bbox, 0));
	CHECK_REL((double)in / n * s.x * s.y * s.z, r.volume_mm3, 0.03);
	mesh_bvh_free(b);
	mesh_free(m);
}

static void test_empty_and_sphere(void)
{
	struct mesh *m = mesh_new(), *sph = fx_icosphere(5, 3);
	struct mesh_bvh *b = NULL;
	struct err e;
	int i;

	REQUIRE_OK(mesh_bvh_new(m, &b, &e), &e);
	CHECK(isinf(mesh_bvh_closest(b, v3(0, 0, 0), NULL, NULL)));
	CHECK_EQ_INT(mesh_bvh_inside(b, v3(0, 0, 0)), 0);
	CHECK(isinf(mesh_bvh_ray(b, v3(0, 0, 0), v3(1, 0, 0), NULL)));
	mesh_bvh_free(b);
	mesh_free(m);
	/* unwelded soup (not "closed" by edges): winding number path */
	REQUIRE_OK(mesh_bvh_new(sph, &b, &e), &e);
	srand(31);
	for (i = 0; i < 500; i++) {
		struct vec3 p = v3(12 * frand() - 6, 12 * frand() - 6, 12 * frand() - 6);
		double rr = v3_len(p);
		if (rr > 4.8 && rr < 5.05)
			continue; /* between the polyhedron and the sphere */
		CHECK_EQ_INT(mesh_bvh_inside(b, p), rr < 5);
	}
	mesh_bvh_free(b);
	mesh_free(sph);
}

int main(void)
{
	RUN(test_closest);
	RUN(test_ray);
	RUN(test_inside_closed);
	RUN(test_inside_punched);
	RUN(test_inside_bunny_volume);
	RUN(test_empty_and_sphere);
	return harness_report();
}
