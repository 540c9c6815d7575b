/* file_text.c - the text lattice format, format probing and lattice_read().
 *
 * Text form (docs/lattice.md 5.2): a first line "infilld-lattice 1", then
 * "support_mm R" (optional, 0 = derive), "nodes N" with N lines "x y z",
 * "edges M" with M lines "a b radius_mm" (0-based node indices, any order).
 * '#' starts a comment; blank lines are ignored.
 */
#include "engine/lattice/binfmt.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

enum lattice_file_kind lattice_file_probe_buffer(const void *data, size_t len)
{
	const char *s = data;
	size_t ml = strlen(LATTEXT_MAGIC);

	if (len >= 8 && memcmp(s, LATBIN_MAGIC, 8) == 0)
		return LATTICE_FILE_BINARY;
	if (len >= ml && memcmp(s, LATTEXT_MAGIC, ml) == 0 &&
	    (len == ml || s[ml] == ' ' || s[ml] == '\t' || s[ml] == '\n' || s[ml] == '\r'))
		return LATTICE_FILE_TEXT;
	return LATTICE_FILE_NONE;
}

enum lattice_file_kind lattice_file_probe(const char *path)
{
	unsigned char buf[64];
	ssize_t n;
	int fd = open(path, O_RDONLY | O_CLOEXEC);

	if (fd < 0)
		return LATTICE_FILE_NONE;
	n = read(fd, buf, sizeof buf);
	close(fd);
	return n > 0 ? lattice_file_probe_buffer(buf, (size_t)n) : LATTICE_FILE_NONE;
}

int lattice_write_text(const struct lattice *q, struct sink *s, struct err *e)
{
	int rc;

	if ((rc = sink_printf(s, e, "%s 1\nsupport_mm %.17g\nnodes %zu\n", LATTEXT_MAGIC,
			      q->support_mm, q->nnodes)) != 0)
		return rc;
	for (size_t i = 0; i < q->nnodes; i++)
		if ((rc = sink_printf(s, e, "%.17g %.17g %.17g\n", q->node[i].x, q->node[i].y,
				      q->node[i].z)) != 0)
			return rc;
	if ((rc = sink_printf(s, e, "edges %zu\n", q->nedges)) != 0)
		return rc;
	for (size_t i = 0; i < q->nedges; i++)
		if ((rc = sink_printf(s, e, "%u %u %.9g\n", q->edge[i].a, q->edge[i].b,
				      (double)q->edge[i].radius_mm)) != 0)
			return rc;
	return 0;
}

/* Line reader over a mutable, NUL-terminated buffer. */
struct lines {
	char *p, *end;
	long line;          /* 1-based number of the current line */
	long long offset;   /* byte offset of the current line */
	const char *base;
};

/* Next non-blank, non-comment line, NUL-terminated in place (comment
 * stripped); NULL at end. */
static char *next_line(struct lines *L)
{
	while (L->p < L->end) {
		char *s = L->p, *nl = memchr(s, '\n', (size_t)(L->end - s)), *c;

		L->line++;
		L->offset = s - L->base;
		if (nl) {
			*nl = 0;
			L->p = nl + 1;
		} else {
			L->p = L->end;
		}
		if ((c = strchr(s, '#')) != NULL)
			*c = 0;
		while (*s == ' ' || *s == '\t' || *s == '\r')
			s++;
		if (*s)
			return s;
	}
	return NULL;
}

static int parse_doubles(const char *s, double *v, int n)
{
	char *end;

	for (int i = 0; i < n; i++) {
		errno = 0;
		v[i] = strtod(s, &end);
		if (end == s || errno == ERANGE || !isfinite(v[i]))
			return -1;
		s = end;
	}
	while (*s == ' ' || *s == '\t' || *s == '\r')
		s++;
	return *s ? -1 : 0;
}

/* A decimal node index followed by a blank or the end; *end after it. */
static int parse_index(const char *s, char **end, unsigned long long *out)
{
	while (*s == ' ' || *s == '\t')
		s++;
	if (*s < '0' || *s > '9')
		return -1;
	errno = 0;
	*out = strtoull(s, end, 10);
	if (errno || (**end != ' ' && **end != '\t' && **end != 0))
		return -1;
	return 0;
}

/* "key N" with N an unsigned integer <= max. */
static int parse_count(const char *s, const char *key, unsigned long long max,
		       unsigned long long *out)
{
	size_t kl = strlen(key);
	char *end;
	unsigned long long v;

	if (strncmp(s, key, kl) != 0 || (s[kl] != ' ' && s[kl] != '\t'))
		return -1;
	s += kl;
	while (*s == ' ' || *s == '\t')
		s++;
	if (*s < '0' || *s > '9')
		return -1;
	errno = 0;
	v = strtoull(s, &end, 10);
	while (*end == ' ' || *end == '\t' || *end == '\r')
		end++;
	if (errno || *end || v > max)
		return -1;
	*out = v;
	return 0;
}

#define TEXT_ERR(L, item, ...) ERR_PLACE(e, ERR_PARSE, (L)->offset, (L)->line, (item), __VA_ARGS__)

static int read_text(char *buf, size_t len, struct lattice **out, struct err *e)
{
	struct lines L = {buf, buf + len, 0, 0, buf};
	struct lattice *q = lattice_new();
	unsigned long long nn, ne, maxc = len / 6 + 1; /* shortest record line: "0 1 1\n" */
	char *s;
	double v[3];
	int rc = ERR_PARSE;

	if (!q)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s = next_line(&L);
	if (!s || lattice_file_probe_buffer(s, strlen(s)) != LATTICE_FILE_TEXT ||
	    strcmp(s + strlen(LATTEXT_MAGIC), " 1") != 0) {
		rc = TEXT_ERR(&L, -1, "expected first line '%s 1'", LATTEXT_MAGIC);
		goto out;
	}
	s = next_line(&L);
	if (s && strncmp(s, "support_mm", 10) == 0) {
		if (parse_doubles(s + 10, v, 1) || v[0] < 0) {
			rc = TEXT_ERR(&L, -1, "support_mm needs one finite value >= 0");
			goto out;
		}
		q->support_mm = v[0];
		s = next_line(&L);
	}
	if (!s || parse_count(s, "nodes", LATTICE_MAX_NODES, &nn) || nn > maxc) {
		rc = TEXT_ERR(&L, -1, "expected 'nodes N' (N at most %llu for this file size)",
			      maxc < LATTICE_MAX_NODES ? maxc : (unsigned long long)LATTICE_MAX_NODES);
		goto out;
	}
	if (lattice_reserve(q, (size_t)nn, 0)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %llu nodes", nn);
		goto out;
	}
	for (unsigned long long i = 0; i < nn; i++) {
		if (!(s = next_line(&L)) || parse_doubles(s, v, 3) || fabs(v[0]) > 1e9 ||
		    fabs(v[1]) > 1e9 || fabs(v[2]) > 1e9) {
			rc = TEXT_ERR(&L, (long long)i,
				      "node %llu: expected three numbers within +-1e9 mm", i);
			goto out;
		}
		q->node[q->nnodes++] = v3(v[0], v[1], v[2]);
	}
	if (!(s = next_line(&L)) ||
	    parse_count(s, "edges", LATTICE_MAX_INCORE_EDGES, &ne) || ne > maxc) {
		rc = TEXT_ERR(&L, -1, "expected 'edges M' (M at most %llu for this file size)",
			      maxc < LATTICE_MAX_INCORE_EDGES ? maxc
							      : (unsigned long long)LATTICE_MAX_INCORE_EDGES);
		goto out;
	}
	if (lattice_reserve(q, (size_t)nn, (size_t)ne)) {
		rc = ERR_SET(e, ERR_NOMEM, "out of memory for %llu edges", ne);
		goto out;
	}
	for (unsigned long long i = 0; i < ne; i++) {
		char *end;
		unsigned long long a, b;

		if (!(s = next_line(&L))) {
			rc = TEXT_ERR(&L, (long long)i, "edge %llu missing (file ends early)", i);
			goto out;
		}
		if (parse_index(s, &end, &a) || parse_index(end, &end, &b) ||
		    parse_doubles(end, v, 1) || a >= nn || b >= nn || a == b ||
		    !((float)v[0] > 0) || !isfinite((float)v[0])) {
			rc = TEXT_ERR(&L, (long long)i,
				      "edge %llu: expected 'a b radius_mm' with distinct node "
				      "indices below %llu and radius > 0",
				      i, nn);
			goto out;
		}
		q->edge[q->nedges].a = (uint32_t)a;
		q->edge[q->nedges].b = (uint32_t)b;
		q->edge[q->nedges].radius_mm = (float)v[0];
		q->nedges++;
	}
	if ((s = next_line(&L)) != NULL) {
		rc = TEXT_ERR(&L, -1, "unexpected content after the last edge");
		goto out;
	}
	*out = q;
	return 0;
out:
	lattice_free(q);
	return rc;
}

int lattice_read_buffer(const void *data, size_t len, struct lattice **out, struct err *e)
{
	char *copy;
	int rc;

	switch (lattice_file_probe_buffer(data, len)) {
	case LATTICE_FILE_TEXT:
		copy = mem_alloc(len + 1);
		if (!copy)
			return ERR_SET(e, ERR_NOMEM, "out of memory");
		memcpy(copy, data, len);
		copy[len] = 0;
		rc = read_text(copy, len, out, e);
		mem_free(copy);
		return rc;
	case LATTICE_FILE_BINARY:
		return latbin_read_mem(data, len, out, e);
	default:
		return ERR_PLACE(e, ERR_PARSE, 0, 1, -1,
				 "not a lattice file (expected the binary magic or '%s 1')",
				 LATTEXT_MAGIC);
	}
}

int lattice_read(const char *path, struct lattice **out, struct err *e)
{
	struct stat st;
	unsigned char head[64];
	ssize_t n;
	int fd = open(path, O_RDONLY | O_CLOEXEC), rc;

	if (fd < 0)
		return ERR_SET(e, ERR_IO, "cannot open %s: %s", path, strerror(errno));
	if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
		close(fd);
		return ERR_SET(e, ERR_IO, "%s is not a regular file", path);
	}
	n = pread(fd, head, sizeof head, 0);
	switch (n > 0 ? lattice_file_probe_buffer(head, (size_t)n) : LATTICE_FILE_NONE) {
	case LATTICE_FILE_BINARY:
		rc = latbin_read_fd(fd, (uint64_t)st.st_size, out, e);
		break;
	case LATTICE_FILE_TEXT: {
		size_t len = (size_t)st.st_size, done = 0;
		char *buf = mem_alloc(len + 1);

		if (!buf) {
			rc = ERR_SET(e, ERR_NOMEM, "out of memory reading %zu bytes", len);
			break;
		}
		rc = 0;
		while (done < len) {
			ssize_t got = pread(fd, buf + done, len - done, (off_t)done);
			if (got < 0 && errno == EINTR)
				continue;
			if (got <= 0) {
				rc = ERR_SET(e, ERR_IO, "read failed: %s",
					     got < 0 ? strerror(errno) : "file shrank");
				break;
			}
			done += (size_t)got;
		}
		if (!rc) {
			buf[len] = 0;
			rc = read_text(buf, len, out, e);
		}
		mem_free(buf);
		break;
	}
	default:
		rc = ERR_PLACE(e, ERR_PARSE, 0, 1, -1,
			       "not a lattice file (expected the binary magic or '%s 1')",
			       LATTEXT_MAGIC);
	}
	close(fd);
	if (rc)
		err_prefix(e, "reading %s", path);
	return rc;
}
