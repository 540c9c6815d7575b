/* read.c - mesh_read_file/mesh_read_buffer: mapping, format detection, dispatch.
 *
 * Detection is by content first (PLY magic, OFF keyword, the binary STL
 * size rule 84 + 50 n, the ASCII STL grammar, OBJ record keywords), then
 * by the name's extension.  Rules and their order: docs/mesh.md.
 */
#include "engine/mesh/mesh.h"
#include "engine/mesh/mesh_int.h"
#include "engine/mesh/text.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

#ifdef MAP_POPULATE
#define MAP_POPULATE_IF MAP_POPULATE
#else
#define MAP_POPULATE_IF 0
#endif

void mesh_warn(struct mesh_read_info *info, const char *fmt, ...)
{
	va_list ap;

	if (info->warnings++ == 0) {
		va_start(ap, fmt);
		vsnprintf(info->first_warning, sizeof info->first_warning, fmt, ap);
		va_end(ap);
	}
}

static const char *format_name(enum mesh_format f)
{
	switch (f) {
	case MESH_FMT_STL: return "STL";
	case MESH_FMT_OBJ: return "OBJ";
	case MESH_FMT_OFF: return "OFF";
	case MESH_FMT_PLY: return "PLY";
	case MESH_FMT_AUTO: break;
	}
	return "unknown";
}

/* Is data an OFF header: optional comment lines, then a first word
 * [ST][C][N][4][n]OFF (we read the plain 3D variants). */
static int looks_off(struct mesh_text *t)
{
	const char *w;
	size_t n;

	n = mesh_text_word(t, &w);
	return n >= 3 && n <= 8 && memcmp(w + n - 3, "OFF", 3) == 0 &&
	       strspn(w, "STCN4n") >= n - 3;
}

static int looks_obj(struct mesh_text *t)
{
	static const char *const kw[] = {"v",  "vt", "vn",     "vp",     "f", "o", "g",
					 "s", "l",  "mtllib", "usemtl", "p", NULL};
	const char *w;
	size_t n = mesh_text_word(t, &w), i;

	for (i = 0; kw[i]; i++)
		if (n == strlen(kw[i]) && memcmp(w, kw[i], n) == 0)
			return 1;
	return 0;
}

/* Starts with the word "solid" (the STL reader then tells a binary STL
 * whose header starts with "solid" from ASCII by the size rule). */
static int starts_solid(const unsigned char *d, size_t len)
{
	struct mesh_text t;
	const char *w;
	size_t n;

	mesh_text_init(&t, d, len);
	mesh_text_skip_ws(&t);
	n = mesh_text_word(&t, &w);
	return mesh_text_word_is(w, n, "solid");
}

static int binary_stl_size_ok(const unsigned char *d, size_t len)
{
	return len >= 84 && (len - 84) % 50 == 0 && (len - 84) / 50 == mesh_le32(d + 80);
}

static enum mesh_format by_extension(const char *name)
{
	const char *dot = name ? strrchr(name, '.') : NULL;

	if (!dot)
		return MESH_FMT_AUTO;
	if (!strcasecmp(dot, ".stl"))
		return MESH_FMT_STL;
	if (!strcasecmp(dot, ".obj"))
		return MESH_FMT_OBJ;
	if (!strcasecmp(dot, ".off"))
		return MESH_FMT_OFF;
	if (!strcasecmp(dot, ".ply"))
		return MESH_FMT_PLY;
	return MESH_FMT_AUTO;
}

static enum mesh_format detect(const unsigned char *d, size_t len, const char *name)
{
	struct mesh_text t;

	if (len >= 4 && memcmp(d, "ply", 3) == 0 && (d[3] == '\n' || d[3] == '\r'))
		return MESH_FMT_PLY;
	if (binary_stl_size_ok(d, len) || starts_solid(d, len))
		return MESH_FMT_STL;
	mesh_text_init(&t, d, len);
	if (len >= 3 && memcmp(d, "\xef\xbb\xbf", 3) == 0) /* UTF-8 byte order mark */
		t.p += 3;
	for (;;) { /* skip blank and comment lines */
		mesh_text_skip_ws(&t);
		if (t.p < t.end && *t.p == '#')
			mesh_text_next_line(&t);
		else
			break;
	}
	if (t.p < t.end && looks_off(&t))
		return MESH_FMT_OFF;
	if (t.p < t.end && looks_obj(&t))
		return MESH_FMT_OBJ;
	return by_extension(name);
}

int mesh_read_buffer(const void *data, size_t len, enum mesh_format fmt, const char *name_hint,
		     struct mesh **out, struct mesh_read_info *info, struct err *e)
{
	struct mesh_read_info local;
	struct mesh *m = NULL;
	mesh_reader_fn *fn;
	int rc;

	memset(&local, 0, sizeof local);
	if (len == 0)
		return ERR_PLACE(e, ERR_PARSE, 0, 0, -1, "empty file (0 bytes)");
	if (fmt == MESH_FMT_AUTO)
		fmt = detect(data, len, name_hint);
	switch (fmt) {
	case MESH_FMT_STL: fn = mesh_read_stl; break;
	case MESH_FMT_OBJ: fn = mesh_read_obj; break;
	case MESH_FMT_OFF: fn = mesh_read_off; break;
	case MESH_FMT_PLY: fn = mesh_read_ply; break;
	case MESH_FMT_AUTO:
	default:
		return ERR_PLACE(e, ERR_PARSE, 0, 0, -1,
				 "unrecognised mesh format (not STL, OBJ, OFF or PLY by content "
				 "or by name)");
	}
	local.format = fmt;
	m = mesh_new();
	if (!m)
		return ERR_SET(e, ERR_NOMEM, "out of memory reading a %s file", format_name(fmt));
	rc = fn(data, len, m, &local, e);
	if (rc)
		goto out;
	if (m->nt == 0) {
		rc = ERR_PLACE(e, ERR_GEOMETRY, (long long)len, 0, -1,
			       "the %s file contains no triangles", format_name(fmt));
		goto out;
	}
	for (size_t i = 0; i < m->nv; i++) {
		const double c[3] = {m->v[i].x, m->v[i].y, m->v[i].z};
		for (int k = 0; k < 3; k++)
			if (!(fabs(c[k]) <= MESH_MAX_COORD)) { /* also NaN */
				rc = ERR_PLACE(e, ERR_GEOMETRY, -1, 0, (long long)i,
					       "vertex %zu: coordinate %g is not a finite number "
					       "within +-%g (not a printable part in any unit)",
					       i, c[k], MESH_MAX_COORD);
				goto out;
			}
	}
	*out = m;
	m = NULL;
	if (info)
		*info = local;
out:
	mesh_free(m);
	return rc;
}

int mesh_read_file(const char *path, enum mesh_format fmt, struct mesh **out,
		   struct mesh_read_info *info, struct err *e)
{
	struct stat st;
	void *map = NULL;
	int fd, rc;

	fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return ERR_SET(e, errno == ENOENT ? ERR_NOTFOUND : ERR_IO, "cannot open %s: %s",
			       path, strerror(errno));
	if (fstat(fd, &st) != 0) {
		rc = ERR_SET(e, ERR_IO, "cannot stat %s: %s", path, strerror(errno));
		goto out;
	}
	if (!S_ISREG(st.st_mode)) {
		rc = ERR_SET(e, ERR_IO, "%s is not a regular file", path);
		goto out;
	}
	if (st.st_size > 0) {
		/* Prefault the whole mapping: the readers touch every byte once,
		 * and one populate call is far cheaper than a fault per page. */
		map = mmap(NULL, (size_t)st.st_size, PROT_READ, MAP_PRIVATE | MAP_POPULATE_IF,
			   fd, 0);
		if (map == MAP_FAILED) {
			map = NULL;
			rc = ERR_SET(e, ERR_IO, "cannot map %s: %s", path, strerror(errno));
			goto out;
		}
		madvise(map, (size_t)st.st_size, MADV_SEQUENTIAL);
	}
	rc = mesh_read_buffer(map ? map : "", (size_t)st.st_size, fmt, path, out, info, e);
out:
	if (map)
		munmap(map, (size_t)st.st_size);
	close(fd);
	return rc;
}
