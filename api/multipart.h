/* multipart.h - a streaming multipart/form-data parser (RFC 7578) for
 * uploads: bytes go in as they arrive, part data comes out through
 * callbacks, memory is a fixed struct (no part is ever held whole).
 */
#ifndef INFILLD_API_MULTIPART_H
#define INFILLD_API_MULTIPART_H

#include <stddef.h>

#define MULTIPART_BOUNDARY_MAX 70 /* RFC 2046 */

struct multipart_cb {
	/* A part starts: its form name and file name ("" if none). */
	int (*begin)(void *ctx, const char *name, const char *filename);
	/* Part data, in order, in pieces of any size. */
	int (*data)(void *ctx, const void *p, size_t len);
	/* Callbacks return 0, or nonzero to stop the parser (error). */
	void *ctx;
};

struct multipart {
	struct multipart_cb cb;
	char delim[MULTIPART_BOUNDARY_MAX + 5]; /* "\r\n--" boundary */
	size_t dlen;
	size_t matched;   /* delimiter bytes matched so far */
	int state;        /* see multipart.c */
	int after;        /* bytes seen after a delimiter */
	char hdr[2048];   /* headers of the current part */
	size_t hlen;
	char error[128];  /* set when multipart_feed fails */
};

/* From a Content-Type value "multipart/form-data; boundary=...": 0, or -1
 * when it is not one or the boundary is missing/invalid. */
int multipart_init(struct multipart *m, const char *content_type, const struct multipart_cb *cb);
/* Feed body bytes; 0, or -1 with m->error set (malformed, or a callback
 * stopped it). */
int multipart_feed(struct multipart *m, const void *data, size_t len);
/* After the last byte: 0 when the closing delimiter was seen. */
int multipart_finish(struct multipart *m);

#endif
