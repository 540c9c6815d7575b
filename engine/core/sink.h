/* sink.h - where output bytes go, and a growable byte buffer.
 *
 * Engines and writers never open sockets or guess paths: they write
 * through a struct sink (a write callback).  The CLI binds a sink to a
 * file, the service to its artifact file; tests bind it to memory.
 */
#ifndef INFILLD_SINK_H
#define INFILLD_SINK_H

#include <stddef.h>
#include <stdint.h>

struct err;

struct sink {
	/* Write all len bytes or fail: returns 0 or a negative err_code and
	 * fills e.  Must not be NULL. */
	int (*write)(void *ctx, const void *buf, size_t len, struct err *e);
	void *ctx;
	uint64_t bytes; /* total written so far, maintained by sink_write() */
	uint64_t limit; /* 0 = none; writes past it fail with ERR_LIMIT */
};

/* Write through the sink, enforcing s->limit and counting s->bytes. */
int sink_write(struct sink *s, const void *buf, size_t len, struct err *e);
/* printf-style convenience for text formats (G-code, INI).  Lines longer
 * than 4 KiB are an ERR_INTERNAL (callers format small records). */
int sink_printf(struct sink *s, struct err *e, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 3, 4)))
#endif
	;

/* A sink writing to an open file descriptor (not closed by the sink). */
void sink_init_fd(struct sink *s, int fd);

/* Growable byte buffer; buf_fini() frees.  Also usable as a sink. */
struct buf {
	unsigned char *data;
	size_t len, cap;
};

void buf_init(struct buf *b);
void buf_fini(struct buf *b);
void buf_reset(struct buf *b); /* len = 0, memory kept */
int buf_append(struct buf *b, const void *p, size_t n); /* 0 or ERR_NOMEM */
/* A sink appending to b (b borrowed; must outlive the sink). */
void sink_init_buf(struct sink *s, struct buf *b);

#endif
