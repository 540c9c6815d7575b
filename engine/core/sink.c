/* sink.c - output sinks and byte buffers (see sink.h). */
#include "engine/core/sink.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <errno.h>
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

int sink_write(struct sink *s, const void *buf, size_t len, struct err *e)
{
	int rc;

	if (len == 0)
		return 0;
	if (s->limit && s->bytes + len > s->limit)
		return ERR_SET(e, ERR_LIMIT, "output exceeds the limit of %llu bytes",
			       (unsigned long long)s->limit);
	rc = s->write(s->ctx, buf, len, e);
	if (rc == 0)
		s->bytes += len;
	return rc;
}

int sink_printf(struct sink *s, struct err *e, const char *fmt, ...)
{
	char line[4096];
	va_list ap;
	int n;

	va_start(ap, fmt);
	n = vsnprintf(line, sizeof line, fmt, ap);
	va_end(ap);
	if (n < 0 || (size_t)n >= sizeof line)
		return ERR_SET(e, ERR_INTERNAL, "formatted record longer than %zu bytes",
			       sizeof line);
	return sink_write(s, line, (size_t)n, e);
}

static int fd_write(void *ctx, const void *buf, size_t len, struct err *e)
{
	int fd = (int)(intptr_t)ctx;
	const unsigned char *p = buf;

	while (len > 0) {
		ssize_t w = write(fd, p, len);
		if (w < 0) {
			if (errno == EINTR)
				continue;
			return ERR_SET(e, ERR_IO, "write failed: %s", strerror(errno));
		}
		p += w;
		len -= (size_t)w;
	}
	return 0;
}

void sink_init_fd(struct sink *s, int fd)
{
	memset(s, 0, sizeof *s);
	s->write = fd_write;
	s->ctx = (void *)(intptr_t)fd;
}

void buf_init(struct buf *b)
{
	memset(b, 0, sizeof *b);
}

void buf_fini(struct buf *b)
{
	mem_free(b->data);
	memset(b, 0, sizeof *b);
}

void buf_reset(struct buf *b)
{
	b->len = 0;
}

int buf_append(struct buf *b, const void *p, size_t n)
{
	void *data = b->data;

	if (n == 0)
		return 0;
	if (b->len + n < b->len)
		return ERR_NOMEM;
	if (mem_grow(&data, &b->cap, b->len + n, 1))
		return ERR_NOMEM;
	b->data = data;
	memcpy(b->data + b->len, p, n);
	b->len += n;
	return 0;
}

static int buf_write(void *ctx, const void *p, size_t n, struct err *e)
{
	if (buf_append(ctx, p, n))
		return ERR_SET(e, ERR_NOMEM, "out of memory buffering %zu bytes", n);
	return 0;
}

void sink_init_buf(struct sink *s, struct buf *b)
{
	memset(s, 0, sizeof *s);
	s->write = buf_write;
	s->ctx = b;
}
