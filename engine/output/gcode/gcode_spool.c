/* gcode_spool.c - the G-code body store (see gcode_int.h; why it exists:
 * docs/gcode.md, "header strategy").
 *
 * The spool is a sequence of records: TEXT (length + bytes) and MARK
 * (elapsed seconds).  It lives in memory until mem_max bytes, then moves
 * to an unlinked temporary file, so memory stays bounded whatever the
 * layer count.  Replay streams it to the sink in 64 KiB pieces, turning
 * marks into M73 progress lines.
 */
#include "engine/output/gcode/gcode_int.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { REC_TEXT = 1, REC_MARK = 2 };

struct rec {
	uint32_t kind;
	uint32_t len;     /* REC_TEXT: bytes that follow */
	double elapsed_s; /* REC_MARK */
};

void gc_spool_init(struct gc_spool *s, const char *dir, size_t mem_max)
{
	memset(s, 0, sizeof *s);
	buf_init(&s->mem);
	s->dir = dir && dir[0] ? dir : "/tmp";
	s->mem_max = mem_max;
}

void gc_spool_fini(struct gc_spool *s)
{
	if (s->file)
		fclose(s->file);
	buf_fini(&s->mem);
	memset(s, 0, sizeof *s);
}

/* Move the memory part to a temporary file (created and unlinked at once,
 * so nothing is left behind whatever happens to the process). */
static int spill(struct gc_spool *s, struct err *e)
{
	char path[4096];
	int fd;

	if ((size_t)snprintf(path, sizeof path, "%s/infilld-gcode-XXXXXX", s->dir) >= sizeof path)
		return ERR_SET(e, ERR_IO, "spool directory name too long");
	fd = mkstemp(path);
	if (fd < 0)
		return ERR_SET(e, ERR_IO, "cannot create a spool file in %s: %s", s->dir,
			       strerror(errno));
	unlink(path);
	s->file = fdopen(fd, "w+b");
	if (!s->file) {
		close(fd);
		return ERR_SET(e, ERR_IO, "cannot open the spool file: %s", strerror(errno));
	}
	if (s->mem.len && fwrite(s->mem.data, 1, s->mem.len, s->file) != s->mem.len)
		return ERR_SET(e, ERR_IO, "writing the G-code spool failed: %s", strerror(errno));
	buf_fini(&s->mem);
	buf_init(&s->mem);
	return 0;
}

static int put(struct gc_spool *s, const void *p, size_t n, struct err *e)
{
	if (!s->file && s->mem.len + n > s->mem_max) {
		int rc = spill(s, e);
		if (rc)
			return rc;
	}
	if (s->file) {
		if (fwrite(p, 1, n, s->file) != n)
			return ERR_SET(e, ERR_IO, "writing the G-code spool failed: %s",
				       strerror(errno));
		return 0;
	}
	if (buf_append(&s->mem, p, n))
		return ERR_SET(e, ERR_NOMEM, "out of memory spooling G-code");
	return 0;
}

int gc_spool_text(struct gc_spool *s, const void *p, size_t n, struct err *e)
{
	const unsigned char *b = p;

	while (n) {
		size_t k = n > 0x40000000u ? 0x40000000u : n;
		struct rec r = {REC_TEXT, (uint32_t)k, 0};
		int rc = put(s, &r, sizeof r, e);
		if (!rc)
			rc = put(s, b, k, e);
		if (rc)
			return rc;
		s->bytes += k;
		b += k;
		n -= k;
	}
	return 0;
}

int gc_spool_mark(struct gc_spool *s, double elapsed_s, struct err *e)
{
	struct rec r = {REC_MARK, 0, elapsed_s};

	return put(s, &r, sizeof r, e);
}

size_t gc_m73(char *dst, double elapsed_s, double total_s)
{
	double frac = total_s > 0 ? elapsed_s / total_s : 1;
	long pct, rem;

	if (frac < 0)
		frac = 0;
	if (frac > 1)
		frac = 1;
	pct = (long)floor(100 * frac);
	rem = (long)ceil((total_s - elapsed_s) / 60 - 1e-9);
	if (rem < 0)
		rem = 0;
	return (size_t)snprintf(dst, 32, "M73 P%ld R%ld\n", pct, rem);
}

/* Records from memory or file, through one reader. */
struct reader {
	struct gc_spool *s;
	size_t off; /* memory */
};

static int rd(struct reader *r, void *p, size_t n, struct err *e)
{
	if (r->s->file) {
		if (fread(p, 1, n, r->s->file) != n)
			return ERR_SET(e, ERR_IO, "reading the G-code spool failed");
		return 0;
	}
	if (r->off + n > r->s->mem.len)
		return ERR_SET(e, ERR_INTERNAL, "G-code spool truncated");
	memcpy(p, r->s->mem.data + r->off, n);
	r->off += n;
	return 0;
}

int gc_spool_replay(struct gc_spool *s, struct sink *out, double offset_s, double total_s,
		    struct err *e)
{
	struct reader r = {s, 0};
	unsigned char *chunk = NULL;
	const size_t chunk_max = 65536;
	int rc = 0;

	if (s->file) {
		if (fflush(s->file) != 0 || fseek(s->file, 0, SEEK_SET) != 0)
			return ERR_SET(e, ERR_IO, "rewinding the G-code spool failed: %s",
				       strerror(errno));
		chunk = mem_alloc(chunk_max);
		if (!chunk)
			return ERR_SET(e, ERR_NOMEM, "out of memory replaying the G-code spool");
	}
	for (;;) {
		struct rec h;
		if (s->file) {
			size_t got = fread(&h, 1, sizeof h, s->file);
			if (got == 0 && feof(s->file))
				break;
			if (got != sizeof h) {
				rc = ERR_SET(e, ERR_IO, "reading the G-code spool failed");
				break;
			}
		} else {
			if (r.off >= s->mem.len)
				break;
			rc = rd(&r, &h, sizeof h, e);
			if (rc)
				break;
		}
		if (h.kind == REC_MARK) {
			char line[32];
			size_t n = gc_m73(line, offset_s + h.elapsed_s, total_s);
			rc = sink_write(out, line, n, e);
		} else if (h.kind == REC_TEXT && !s->file) {
			if (r.off + h.len > s->mem.len) {
				rc = ERR_SET(e, ERR_INTERNAL, "G-code spool truncated");
				break;
			}
			rc = sink_write(out, s->mem.data + r.off, h.len, e);
			r.off += h.len;
		} else if (h.kind == REC_TEXT) {
			for (size_t left = h.len; !rc && left;) {
				size_t k = left < chunk_max ? left : chunk_max;
				rc = rd(&r, chunk, k, e);
				if (!rc)
					rc = sink_write(out, chunk, k, e);
				left -= k;
			}
		} else {
			rc = ERR_SET(e, ERR_INTERNAL, "G-code spool corrupt");
		}
		if (rc)
			break;
	}
	mem_free(chunk);
	return rc;
}
