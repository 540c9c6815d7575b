/* density.c - target density fields and the NRRD voxel-grid reader (density.h). */
#include "engine/lattice/density.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define NRRD_MAX_VOXELS (256u * 1024 * 1024) /* 1 GiB of floats */

static struct vec3 frac_point(struct box3 b, struct vec3 f)
{
	struct vec3 s = box3_size(b);
	return v3(b.lo.x + f.x * s.x, b.lo.y + f.y * s.y, b.lo.z + f.z * s.z);
}

static double clamp01(double v)
{
	return v < 0 ? 0 : v > 1 ? 1 : v;
}

void lattice_density_constant(struct lattice_density *d, struct box3 box, double value)
{
	memset(d, 0, sizeof *d);
	d->mode = LATTICE_DENSITY_CONSTANT;
	d->box = box;
	d->value = d->lo = d->hi = clamp01(value);
}

void lattice_density_gradient(struct lattice_density *d, struct box3 box, struct vec3 f0,
			      struct vec3 f1, double d0, double d1)
{
	memset(d, 0, sizeof *d);
	d->mode = LATTICE_DENSITY_GRADIENT;
	d->box = box;
	d->p0 = frac_point(box, f0);
	d->p1 = frac_point(box, f1);
	d->d0 = clamp01(d0);
	d->d1 = clamp01(d1);
	d->lo = fmin(d->d0, d->d1);
	d->hi = fmax(d->d0, d->d1);
}

void lattice_density_radial(struct lattice_density *d, struct box3 box, struct vec3 fc,
			    double radius_mm, double d_center, double d_rim)
{
	memset(d, 0, sizeof *d);
	d->mode = LATTICE_DENSITY_RADIAL;
	d->box = box;
	d->p0 = frac_point(box, fc);
	if (!(radius_mm > 0)) {
		radius_mm = 0;
		for (int c = 0; c < 8; c++) {
			struct vec3 q = v3((c & 1) ? box.hi.x : box.lo.x, (c & 2) ? box.hi.y : box.lo.y,
					   (c & 4) ? box.hi.z : box.lo.z);
			radius_mm = fmax(radius_mm, v3_dist(q, d->p0));
		}
	}
	d->radius_mm = radius_mm > 0 ? radius_mm : 1;
	d->d0 = clamp01(d_center);
	d->d1 = clamp01(d_rim);
	d->lo = fmin(d->d0, d->d1);
	d->hi = fmax(d->d0, d->d1);
}

void lattice_density_fini(struct lattice_density *d)
{
	if (!d)
		return;
	mem_free(d->grid);
	d->grid = NULL;
}

static double grid_at(const struct lattice_density *d, int i, int j, int k)
{
	return d->grid[((size_t)k * d->ny + j) * d->nx + i];
}

double lattice_density_at(const struct lattice_density *d, struct vec3 p)
{
	switch (d->mode) {
	case LATTICE_DENSITY_CONSTANT:
		return d->value;
	case LATTICE_DENSITY_GRADIENT: {
		struct vec3 u = v3_sub(d->p1, d->p0);
		double l2 = v3_len2(u);
		double t = l2 > 0 ? clamp01(v3_dot(v3_sub(p, d->p0), u) / l2) : 0;
		return clamp01(d->d0 + t * (d->d1 - d->d0));
	}
	case LATTICE_DENSITY_RADIAL: {
		double t = clamp01(v3_dist(p, d->p0) / d->radius_mm);
		return clamp01(d->d0 + t * (d->d1 - d->d0));
	}
	case LATTICE_DENSITY_FILE: {
		struct vec3 s = box3_size(d->box);
		double g[3], f[3];
		int i0[3], n[3] = {d->nx, d->ny, d->nz};
		double pc[3] = {p.x - d->box.lo.x, p.y - d->box.lo.y, p.z - d->box.lo.z};
		double sz[3] = {s.x, s.y, s.z};
		double v = 0;

		for (int a = 0; a < 3; a++) {
			g[a] = sz[a] > 0 ? pc[a] / sz[a] * n[a] - 0.5 : 0;
			if (g[a] < 0)
				g[a] = 0;
			if (g[a] > n[a] - 1)
				g[a] = n[a] - 1;
			i0[a] = (int)floor(g[a]);
			if (i0[a] > n[a] - 2)
				i0[a] = n[a] >= 2 ? n[a] - 2 : 0;
			f[a] = n[a] >= 2 ? g[a] - i0[a] : 0;
		}
		for (int c = 0; c < 8; c++) {
			int di = c & 1, dj = (c >> 1) & 1, dk = (c >> 2) & 1;
			double wgt = (di ? f[0] : 1 - f[0]) * (dj ? f[1] : 1 - f[1]) *
				     (dk ? f[2] : 1 - f[2]);
			if (wgt == 0)
				continue;
			v += wgt * grid_at(d, i0[0] + (n[0] >= 2 ? di : 0), i0[1] + (n[1] >= 2 ? dj : 0),
					   i0[2] + (n[2] >= 2 ? dk : 0));
		}
		return clamp01(v);
	}
	}
	return 0;
}

/* ---- NRRD ---- */

enum ntype { NT_NONE, NT_U8, NT_F32, NT_F64 };

static int ntype_of(const char *v)
{
	if (!strcmp(v, "uchar") || !strcmp(v, "unsigned char") || !strcmp(v, "uint8") ||
	    !strcmp(v, "uint8_t"))
		return NT_U8;
	if (!strcmp(v, "float"))
		return NT_F32;
	if (!strcmp(v, "double"))
		return NT_F64;
	return NT_NONE;
}

#define NRRD_ERR(off, line, ...) ERR_PLACE(e, ERR_PARSE, (off), (line), -1, __VA_ARGS__)

int lattice_density_load_buffer(struct lattice_density *d, struct box3 box, const void *data,
				size_t len, struct err *e)
{
	const char *s = data, *end = s + len, *p = s;
	char line[512];
	long ln = 0;
	int type = NT_NONE, dim = 0, raw = 0, little = -1, sizes_ok = 0;
	long long n[3] = {0, 0, 0};
	size_t count, esz;
	float *grid;

	memset(d, 0, sizeof *d);
	if (len < 8 || memcmp(s, "NRRD000", 7) != 0)
		return NRRD_ERR(0, 1, "not a NRRD file (expected the magic NRRD000x)");
	for (;;) {
		const char *nl = memchr(p, '\n', (size_t)(end - p));
		size_t ll;
		const char *colon;

		if (!nl)
			return NRRD_ERR(p - s, ln + 1, "header does not end with an empty line");
		ll = (size_t)(nl - p);
		if (ll && p[ll - 1] == '\r')
			ll--;
		ln++;
		if (ll >= sizeof line)
			return NRRD_ERR(p - s, ln, "header line too long");
		memcpy(line, p, ll);
		line[ll] = 0;
		p = nl + 1;
		if (ln == 1)
			continue; /* magic */
		if (ll == 0)
			break;
		if (line[0] == '#')
			continue;
		colon = strstr(line, ": ");
		if (!colon) {
			if (strstr(line, ":="))
				continue; /* key/value pairs: ignored */
			return NRRD_ERR(p - s, ln, "malformed header line '%s'", line);
		}
		{
			char key[64];
			const char *val = colon + 2;
			size_t kl = (size_t)(colon - line);

			if (kl >= sizeof key)
				return NRRD_ERR(p - s, ln, "header key too long");
			memcpy(key, line, kl);
			key[kl] = 0;
			if (!strcmp(key, "type")) {
				if ((type = ntype_of(val)) == NT_NONE)
					return NRRD_ERR(p - s, ln,
							"type '%s' unsupported (uchar, float or double)",
							val);
			} else if (!strcmp(key, "dimension")) {
				dim = atoi(val);
				if (dim != 3)
					return NRRD_ERR(p - s, ln, "dimension must be 3 (got '%s')",
							val);
			} else if (!strcmp(key, "sizes")) {
				char *q;
				const char *v = val;
				for (int a = 0; a < 3; a++) {
					errno = 0;
					n[a] = strtoll(v, &q, 10);
					if (q == v || errno || n[a] < 1 || n[a] > 100000)
						return NRRD_ERR(p - s, ln,
								"sizes needs three integers in "
								"1..100000");
					v = q;
				}
				sizes_ok = 1;
			} else if (!strcmp(key, "encoding")) {
				if (strcmp(val, "raw") != 0)
					return NRRD_ERR(p - s, ln,
							"encoding '%s' unsupported (only raw)", val);
				raw = 1;
			} else if (!strcmp(key, "endian")) {
				little = !strcmp(val, "little") ? 1 : !strcmp(val, "big") ? 0 : -1;
				if (little != 1)
					return NRRD_ERR(p - s, ln,
							"endian '%s' unsupported (only little)", val);
			} else if (!strcmp(key, "data file") || !strcmp(key, "datafile")) {
				return NRRD_ERR(p - s, ln, "detached data files are not supported");
			}
			/* other keys (spacings, space origin, ...) are ignored: the
			 * grid always spans the part's bounding box */
		}
	}
	if (type == NT_NONE || !dim || !sizes_ok || !raw)
		return NRRD_ERR(p - s, ln, "header needs type, dimension, sizes and encoding");
	if (type != NT_U8 && little != 1)
		return NRRD_ERR(p - s, ln, "multi-byte types need 'endian: little'");
	count = (size_t)(n[0] * n[1] * n[2]);
	if (count > NRRD_MAX_VOXELS)
		return NRRD_ERR(p - s, ln, "%zu voxels exceed the limit %u", count, NRRD_MAX_VOXELS);
	esz = type == NT_U8 ? 1 : type == NT_F32 ? 4 : 8;
	if ((size_t)(end - p) != count * esz)
		return NRRD_ERR(p - s, ln, "data has %zu bytes, sizes and type need %zu",
				(size_t)(end - p), count * esz);
	grid = mem_alloc(count * sizeof *grid);
	if (!grid)
		return ERR_SET(e, ERR_NOMEM, "out of memory for %zu voxels", count);
	d->lo = INFINITY;
	d->hi = -INFINITY;
	for (size_t i = 0; i < count; i++) {
		const unsigned char *b = (const unsigned char *)p + i * esz;
		double v;
		if (type == NT_U8) {
			v = b[0] / 255.0;
		} else if (type == NT_F32) {
			uint32_t u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
				     (uint32_t)b[3] << 24;
			float f;
			memcpy(&f, &u, 4);
			v = f;
		} else {
			uint64_t u = 0;
			double f;
			for (int k = 7; k >= 0; k--)
				u = u << 8 | b[k];
			memcpy(&f, &u, 8);
			v = f;
		}
		if (!(v >= 0 && v <= 1)) {
			mem_free(grid);
			return ERR_PLACE(e, ERR_PARSE, (long long)(p - s + i * esz), 0, (long long)i,
					 "voxel %zu: density %g outside [0, 1]", i, v);
		}
		grid[i] = (float)v;
		d->lo = fmin(d->lo, v);
		d->hi = fmax(d->hi, v);
	}
	d->mode = LATTICE_DENSITY_FILE;
	d->box = box;
	d->grid = grid;
	d->nx = (int)n[0];
	d->ny = (int)n[1];
	d->nz = (int)n[2];
	return 0;
}

int lattice_density_load(struct lattice_density *d, struct box3 box, const char *path,
			 struct err *e)
{
	struct stat st;
	char *buf;
	size_t done = 0;
	int fd = open(path, O_RDONLY | O_CLOEXEC), rc;

	memset(d, 0, sizeof *d);
	if (fd < 0)
		return ERR_SET(e, ERR_IO, "cannot open density file %s: %s", path, strerror(errno));
	if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) ||
	    (uint64_t)st.st_size > (uint64_t)NRRD_MAX_VOXELS * 8 + (1u << 20)) {
		close(fd);
		return ERR_SET(e, ERR_IO, "density file %s is not a regular file of sensible size",
			       path);
	}
	buf = mem_alloc((size_t)st.st_size + 1);
	if (!buf) {
		close(fd);
		return ERR_SET(e, ERR_NOMEM, "out of memory reading %s", path);
	}
	while (done < (size_t)st.st_size) {
		ssize_t n = read(fd, buf + done, (size_t)st.st_size - done);
		if (n < 0 && errno == EINTR)
			continue;
		if (n <= 0)
			break;
		done += (size_t)n;
	}
	close(fd);
	rc = lattice_density_load_buffer(d, box, buf, done, e);
	mem_free(buf);
	if (rc)
		err_prefix(e, "density file %s", path);
	return rc;
}
