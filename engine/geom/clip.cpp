/* clip.cpp - extern "C" shim over Clipper 6.4 (see clip.h).
 *
 * Kept deliberately thin: convert struct paths <-> ClipperLib::Paths
 * (both int64 x/y), call Clipper, convert back, and turn exceptions
 * into error codes.  No geometry decisions are made here.
 */
#include <new>
#include <stdexcept>

#include <clipper.hpp>

extern "C" {
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
}

namespace {

using ClipperLib::IntPoint;
using ClipperLib::Path;
using ClipperLib::Paths;

void to_clipper(const struct paths *in, Paths &out)
{
	out.clear();
	if (!in)
		return;
	out.resize(in->n);
	for (size_t i = 0; i < in->n; i++) {
		Path &p = out[i];
		p.reserve(in->v[i].n);
		for (size_t k = 0; k < in->v[i].n; k++)
			p.push_back(IntPoint(in->v[i].pts[k].x, in->v[i].pts[k].y));
	}
}

int from_clipper(const Paths &in, struct paths *out, struct err *e)
{
	struct paths t;

	paths_init(&t);
	for (const Path &p : in) {
		struct path *q;
		if (p.empty())
			continue;
		q = paths_add(&t);
		if (!q)
			goto nomem;
		q->pts = static_cast<struct pt2 *>(mem_alloc(p.size() * sizeof(struct pt2)));
		if (!q->pts)
			goto nomem;
		q->cap = p.size();
		for (const IntPoint &ip : p)
			q->pts[q->n++] = {ip.X, ip.Y};
	}
	paths_fini(out);
	*out = t;
	return 0;
nomem:
	paths_fini(&t);
	return ERR_SET(e, ERR_NOMEM, "out of memory converting polygons");
}

bool has_polygon(const Paths &ps)
{
	for (const Path &p : ps)
		if (p.size() >= 3)
			return true;
	return false;
}

ClipperLib::PolyFillType fill_type(enum clip_fill f)
{
	switch (f) {
	case CLIP_FILL_EVENODD: return ClipperLib::pftEvenOdd;
	case CLIP_FILL_POSITIVE: return ClipperLib::pftPositive;
	case CLIP_FILL_NONZERO: break;
	}
	return ClipperLib::pftNonZero;
}

ClipperLib::ClipType clip_type(enum clip_op op)
{
	switch (op) {
	case CLIP_INTERSECTION: return ClipperLib::ctIntersection;
	case CLIP_DIFFERENCE: return ClipperLib::ctDifference;
	case CLIP_XOR: return ClipperLib::ctXor;
	case CLIP_UNION: break;
	}
	return ClipperLib::ctUnion;
}

/* Run f, mapping C++ exceptions to error codes. */
template <typename F> int guarded(struct err *e, const char *what, F f)
{
	try {
		return f();
	} catch (const std::bad_alloc &) {
		return ERR_SET(e, ERR_NOMEM, "out of memory in %s", what);
	} catch (const std::exception &x) {
		return ERR_SET(e, ERR_INTERNAL, "%s failed: %s", what, x.what());
	} catch (...) {
		return ERR_SET(e, ERR_INTERNAL, "%s failed", what);
	}
}

} // namespace

extern "C" int clip_boolean(enum clip_op op, const struct paths *subj, const struct paths *clip,
			    enum clip_fill fill, struct paths *out, struct err *e)
{
	return guarded(e, "polygon boolean", [&]() -> int {
		Paths s, c, r;
		ClipperLib::Clipper cl;
		to_clipper(subj, s);
		to_clipper(clip, c);
		/* Clipper's Execute() reports failure when no input polygon has an
		 * area to sweep; the result of such a boolean is simply empty. */
		if (!has_polygon(s) && !has_polygon(c))
			return from_clipper(r, out, e);
		cl.AddPaths(s, ClipperLib::ptSubject, true);
		if (!c.empty())
			cl.AddPaths(c, ClipperLib::ptClip, true);
		if (!cl.Execute(clip_type(op), r, fill_type(fill), fill_type(fill)))
			return ERR_SET(e, ERR_INTERNAL, "polygon boolean failed");
		return from_clipper(r, out, e);
	});
}

extern "C" int clip_union(const struct paths *in, enum clip_fill fill, struct paths *out,
			  struct err *e)
{
	return clip_boolean(CLIP_UNION, in, NULL, fill, out, e);
}

extern "C" int clip_offset(const struct paths *in, double delta_nm, enum clip_join join,
			   double miter_limit, double arc_tol_nm, struct paths *out, struct err *e)
{
	return guarded(e, "polygon offset", [&]() -> int {
		Paths s, r;
		ClipperLib::JoinType jt = join == CLIP_JOIN_ROUND   ? ClipperLib::jtRound
					  : join == CLIP_JOIN_MITER ? ClipperLib::jtMiter
								    : ClipperLib::jtSquare;
		ClipperLib::ClipperOffset co(miter_limit > 0 ? miter_limit : 2.0,
					     arc_tol_nm > 0 ? arc_tol_nm : 0.25);
		if (arc_tol_nm <= 0)
			co.ArcTolerance = (delta_nm < 0 ? -delta_nm : delta_nm) * 0.25;
		if (co.ArcTolerance < 1.0)
			co.ArcTolerance = 1.0;
		to_clipper(in, s);
		co.AddPaths(s, jt, ClipperLib::etClosedPolygon);
		co.Execute(r, delta_nm);
		return from_clipper(r, out, e);
	});
}

extern "C" int clip_lines(const struct paths *lines, const struct paths *region,
			  struct paths *out, struct err *e)
{
	return guarded(e, "line clipping", [&]() -> int {
		Paths s, c;
		ClipperLib::PolyTree tree;
		ClipperLib::Clipper cl;
		to_clipper(lines, s);
		to_clipper(region, c);
		cl.AddPaths(s, ClipperLib::ptSubject, false);
		cl.AddPaths(c, ClipperLib::ptClip, true);
		if (!cl.Execute(ClipperLib::ctIntersection, tree, ClipperLib::pftNonZero,
				ClipperLib::pftNonZero))
			return ERR_SET(e, ERR_INTERNAL, "line clipping failed");
		Paths r;
		ClipperLib::OpenPathsFromPolyTree(tree, r);
		return from_clipper(r, out, e);
	});
}

extern "C" int clip_clean(struct paths *ps, double dist_nm, struct err *e)
{
	return guarded(e, "polygon cleaning", [&]() -> int {
		Paths s;
		to_clipper(ps, s);
		ClipperLib::CleanPolygons(s, dist_nm > 0 ? dist_nm : 1.415);
		return from_clipper(s, ps, e);
	});
}
