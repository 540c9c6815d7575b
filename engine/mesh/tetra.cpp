/* tetra.cpp - extern "C" shim over TetGen 1.5 (see tetra.h).
 *
 * Thin on purpose: build a tetgenio (arrays from new[], TetGen's
 * destructor delete[]s them), run tetrahedralize() with fixed switches,
 * copy the result out.  Every call runs in a forked child that streams
 * the result through a pipe, so a TetGen crash, exit() or exception ends
 * the child only; the parent reports it as an error.
 */
#ifndef TETLIBRARY /* also set by the Makefile */
#define TETLIBRARY
#endif
#include <tetgen.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <new>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

extern "C" {
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/mesh/mesh.h"
#include "engine/mesh/tetra.h"
}

namespace {

/* Child -> parent protocol: a header, then the arrays. */
struct result_head {
	int32_t status;      /* 0 ok, else a child_status code */
	int32_t tetgen_code; /* TetGen's thrown code, if any */
	uint64_t npoints, ntets, count;
};

enum child_status { CHILD_OK = 0, CHILD_THREW = 1, CHILD_NOMEM = 2, CHILD_BAD = 3 };

/* Hard caps on what the parent accepts from the child. */
const uint64_t MAX_POINTS = 200000000ull;
const uint64_t MAX_TETS = 1500000000ull;

bool write_all(int fd, const void *p, size_t n)
{
	const char *c = static_cast<const char *>(p);
	while (n) {
		ssize_t w = write(fd, c, n);
		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0)
			return false;
		c += w;
		n -= static_cast<size_t>(w);
	}
	return true;
}

bool read_all(int fd, void *p, size_t n)
{
	char *c = static_cast<char *>(p);
	while (n) {
		ssize_t r = read(fd, c, n);
		if (r < 0 && errno == EINTR)
			continue;
		if (r <= 0)
			return false;
		c += r;
		n -= static_cast<size_t>(r);
	}
	return true;
}

/* What a job asks TetGen to do (filled by the parent, run by the child). */
struct job {
	const char *switches;
	const double *xyz;     /* points (delaunay) */
	size_t n;
	const struct mesh *surface; /* facets (volume meshing / checks) */
	const double *sizing;
	bool want_tets;        /* else report numberoftrifaces (intersection check) */
};

void fill_input(const job &j, tetgenio &in)
{
	in.firstnumber = 0;
	if (j.surface) {
		const struct mesh *m = j.surface;
		in.numberofpoints = static_cast<int>(m->nv);
		in.pointlist = new REAL[3 * m->nv];
		for (size_t i = 0; i < m->nv; i++) {
			in.pointlist[3 * i] = m->v[i].x;
			in.pointlist[3 * i + 1] = m->v[i].y;
			in.pointlist[3 * i + 2] = m->v[i].z;
		}
		if (j.sizing) {
			in.numberofpointmtrs = 1;
			in.pointmtrlist = new REAL[m->nv];
			for (size_t i = 0; i < m->nv; i++)
				in.pointmtrlist[i] = j.sizing[i];
		}
		in.numberoffacets = static_cast<int>(m->nt);
		in.facetlist = new tetgenio::facet[m->nt];
		in.facetmarkerlist = NULL;
		for (size_t t = 0; t < m->nt; t++) {
			tetgenio::facet &f = in.facetlist[t];
			f.numberofpolygons = 1;
			f.polygonlist = new tetgenio::polygon[1];
			f.numberofholes = 0;
			f.holelist = NULL;
			f.polygonlist[0].numberofvertices = 3;
			f.polygonlist[0].vertexlist = new int[3];
			for (int k = 0; k < 3; k++)
				f.polygonlist[0].vertexlist[k] = static_cast<int>(m->tri[3 * t + k]);
		}
	} else {
		in.numberofpoints = static_cast<int>(j.n);
		in.pointlist = new REAL[3 * j.n];
		std::memcpy(in.pointlist, j.xyz, 3 * j.n * sizeof(REAL));
	}
}

/* Child body: never returns. */
[[noreturn]] void child_run(const job &j, int fd)
{
	result_head h;
	std::memset(&h, 0, sizeof h);
	int devnull = open("/dev/null", O_WRONLY);
	if (devnull >= 0) { /* TetGen prints; the engine must not */
		dup2(devnull, 1);
		dup2(devnull, 2);
	}
	try {
		tetgenio in, out;
		tetgenbehavior b;
		char sw[128];

		std::snprintf(sw, sizeof sw, "%s", j.switches);
		fill_input(j, in);
		if (!b.parse_commandline(sw)) {
			h.status = CHILD_BAD;
			write_all(fd, &h, sizeof h);
			_exit(0);
		}
		tetrahedralize(&b, &in, &out);
		if (!j.want_tets) {
			h.count = static_cast<uint64_t>(out.numberoftrifaces);
			write_all(fd, &h, sizeof h);
			_exit(0);
		}
		if (out.numberofcorners != 4 || out.numberofpoints < 0 ||
		    out.numberoftetrahedra < 0) {
			h.status = CHILD_BAD;
			write_all(fd, &h, sizeof h);
			_exit(0);
		}
		h.npoints = static_cast<uint64_t>(out.numberofpoints);
		h.ntets = static_cast<uint64_t>(out.numberoftetrahedra);
		if (!write_all(fd, &h, sizeof h) ||
		    !write_all(fd, out.pointlist, 3 * h.npoints * sizeof(REAL)))
			_exit(1);
		{
			/* int -> uint32 in chunks */
			uint32_t buf[4096];
			size_t total = 4 * h.ntets, k = 0;
			while (k < total) {
				size_t n = total - k < 4096 ? total - k : 4096;
				for (size_t i = 0; i < n; i++)
					buf[i] = static_cast<uint32_t>(out.tetrahedronlist[k + i]);
				if (!write_all(fd, buf, n * sizeof(uint32_t)))
					_exit(1);
				k += n;
			}
		}
		_exit(0);
	} catch (const std::bad_alloc &) {
		h.status = CHILD_NOMEM;
	} catch (int code) {
		h.status = CHILD_THREW;
		h.tetgen_code = code;
	} catch (...) {
		h.status = CHILD_THREW;
		h.tetgen_code = -1;
	}
	write_all(fd, &h, sizeof h);
	_exit(0);
}

const char *tetgen_code_text(int c)
{
	switch (c) {
	case 1: return "out of memory";
	case 2: return "internal error";
	case 3: return "a self-intersection was detected";
	case 4: return "a very small input feature size was detected";
	case 5: return "two very close input facets were detected";
	case 10: return "an input error was detected";
	default: return "unknown failure";
	}
}

/* Swap two corners of tet k if its signed volume is negative. */
void orient_positive(struct tetra_mesh *t, size_t k)
{
	uint32_t *q = t->tet + 4 * k;
	const double *p0 = t->xyz + 3 * q[0], *p1 = t->xyz + 3 * q[1];
	const double *p2 = t->xyz + 3 * q[2], *p3 = t->xyz + 3 * q[3];
	double a[3], b[3], c[3];

	for (int i = 0; i < 3; i++) {
		a[i] = p1[i] - p0[i];
		b[i] = p2[i] - p0[i];
		c[i] = p3[i] - p0[i];
	}
	if (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
		    a[2] * (b[0] * c[1] - b[1] * c[0]) <
	    0) {
		uint32_t tmp = q[2];
		q[2] = q[3];
		q[3] = tmp;
	}
}

/* Run j in a child.  want_tets: fill *out; else *count. */
int run_isolated(const job &j, struct tetra_mesh *out, size_t *count, struct err *e)
{
	int fds[2], status = 0, rc = 0;
	pid_t pid;
	result_head h;
	bool got_head;

	if (pipe(fds) != 0)
		return ERR_SET(e, ERR_IO, "TetGen: pipe failed: %s", std::strerror(errno));
	std::fflush(NULL);
	pid = fork();
	if (pid < 0) {
		close(fds[0]);
		close(fds[1]);
		return ERR_SET(e, ERR_LIMIT, "TetGen: cannot fork a meshing process: %s",
			       std::strerror(errno));
	}
	if (pid == 0) {
		close(fds[0]);
		child_run(j, fds[1]);
	}
	close(fds[1]);
	got_head = read_all(fds[0], &h, sizeof h);
	if (got_head && h.status == CHILD_OK && j.want_tets) {
		if (h.npoints > MAX_POINTS || h.ntets > MAX_TETS) {
			rc = ERR_SET(e, ERR_LIMIT, "TetGen produced %llu points / %llu tetrahedra",
				     (unsigned long long)h.npoints, (unsigned long long)h.ntets);
		} else {
			out->npoints = static_cast<size_t>(h.npoints);
			out->ntets = static_cast<size_t>(h.ntets);
			out->xyz = static_cast<double *>(mem_alloc(3 * out->npoints * sizeof(double) + 1));
			out->tet = static_cast<uint32_t *>(mem_alloc(4 * out->ntets * sizeof(uint32_t) + 1));
			if (!out->xyz || !out->tet)
				rc = ERR_SET(e, ERR_NOMEM, "out of memory for %zu tetrahedra", out->ntets);
			else if (!read_all(fds[0], out->xyz, 3 * out->npoints * sizeof(double)) ||
				 !read_all(fds[0], out->tet, 4 * out->ntets * sizeof(uint32_t)))
				rc = ERR_SET(e, ERR_GEOMETRY, "TetGen: the meshing process ended early");
			for (size_t i = 0; !rc && i < 4 * out->ntets; i++)
				if (out->tet[i] >= out->npoints)
					rc = ERR_SET(e, ERR_INTERNAL, "TetGen returned a bad index");
			for (size_t k = 0; !rc && k < out->ntets; k++)
				orient_positive(out, k);
		}
	}
	close(fds[0]); /* a child still writing gets EPIPE and ends */
	while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
		;
	if (!rc) {
		if (WIFSIGNALED(status))
			rc = ERR_SET(e, ERR_GEOMETRY,
				     "TetGen crashed (signal %d) on this input",
				     WTERMSIG(status));
		else if (!got_head)
			rc = ERR_SET(e, ERR_GEOMETRY, "TetGen exited (status %d) without a result",
				     WIFEXITED(status) ? WEXITSTATUS(status) : -1);
		else if (h.status == CHILD_NOMEM)
			rc = ERR_SET(e, ERR_NOMEM, "TetGen ran out of memory");
		else if (h.status == CHILD_THREW)
			rc = ERR_SET(e, ERR_GEOMETRY, "TetGen failed: %s (code %d)",
				     tetgen_code_text(h.tetgen_code), h.tetgen_code);
		else if (h.status != CHILD_OK)
			rc = ERR_SET(e, ERR_GEOMETRY, "TetGen returned an unusable result");
		else if (count)
			*count = static_cast<size_t>(h.count);
	}
	if (rc && out)
		tetra_mesh_fini(out);
	return rc;
}

int check_surface(const struct mesh *m, struct err *e)
{
	if (!m || m->nv < 4 || m->nt < 4)
		return ERR_SET(e, ERR_GEOMETRY, "a closed surface needs at least 4 triangles");
	if (m->nv > MAX_POINTS || m->nt > MAX_POINTS)
		return ERR_SET(e, ERR_LIMIT, "surface too large for TetGen");
	return 0;
}

} // namespace

extern "C" void tetra_mesh_fini(struct tetra_mesh *t)
{
	if (!t)
		return;
	mem_free(t->xyz);
	mem_free(t->tet);
	t->xyz = NULL;
	t->tet = NULL;
	t->npoints = t->ntets = 0;
}

extern "C" int tetra_delaunay(const double *xyz, size_t n, struct tetra_mesh *out, struct err *e)
{
	job j = {"zQ", xyz, n, NULL, NULL, true};

	std::memset(out, 0, sizeof *out);
	if (n < 4)
		return ERR_SET(e, ERR_GEOMETRY, "Delaunay meshing needs at least 4 points (got %zu)", n);
	if (n > MAX_POINTS)
		return ERR_SET(e, ERR_LIMIT, "too many points for TetGen (%zu)", n);
	for (size_t i = 0; i < 3 * n; i++)
		if (!std::isfinite(xyz[i]))
			return ERR_SET(e, ERR_PARAM, "point %zu has a non-finite coordinate", i / 3);
	int rc = run_isolated(j, out, NULL, e);
	if (!rc && out->ntets == 0) {
		tetra_mesh_fini(out);
		return ERR_SET(e, ERR_GEOMETRY, "the points are coplanar: no tetrahedra");
	}
	return rc;
}

extern "C" int tetra_self_intersections(const struct mesh *m, size_t *pairs, struct err *e)
{
	job j = {"dzQ", NULL, 0, m, NULL, false};
	int rc = check_surface(m, e);

	if (rc)
		return rc;
	*pairs = 0;
	return run_isolated(j, NULL, pairs, e);
}

extern "C" int tetra_mesh_volume(const struct mesh *m, const struct tetra_opts *o,
				 struct tetra_mesh *out, struct err *e)
{
	char sw[96];
	size_t pairs = 0;
	int rc, n;

	std::memset(out, 0, sizeof *out);
	if ((rc = tetra_self_intersections(m, &pairs, e)) != 0)
		return rc;
	if (pairs)
		return ERR_SET(e, ERR_GEOMETRY,
			       "the surface intersects itself (%zu intersecting face pairs); "
			       "repair it before meshing",
			       pairs);
	n = std::snprintf(sw, sizeof sw, "pzQ");
	if (o && o->radius_edge > 0)
		n += std::snprintf(sw + n, sizeof sw - n, "q%.4g", o->radius_edge);
	if (o && o->max_volume > 0)
		n += std::snprintf(sw + n, sizeof sw - n, "a%.6g", o->max_volume);
	if (o && o->sizing)
		std::snprintf(sw + n, sizeof sw - n, "m");
	job j = {sw, NULL, 0, m, o ? o->sizing : NULL, true};
	return run_isolated(j, out, NULL, e);
}
