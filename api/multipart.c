/* multipart.c - streaming multipart/form-data parser (see multipart.h).
 *
 * The body is scanned for the delimiter "\r\n--boundary"; a virtual
 * "\r\n" is fed first so the opening delimiter needs no special case.
 * Boundaries contain no CR, so on a mismatch the bytes matched so far are
 * plain data and matching restarts at the current byte: linear time, and
 * memchr() skips to the next CR while nothing is matched.
 */
#define _GNU_SOURCE /* pipe2, strcasestr */
#include "api/multipart.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

enum { MP_PREAMBLE, MP_AFTER_DELIM, MP_HEADERS, MP_BODY, MP_DONE, MP_ERROR };

static int fail(struct multipart *m, const char *msg)
{
	snprintf(m->error, sizeof m->error, "%s", msg);
	m->state = MP_ERROR;
	return -1;
}

int multipart_init(struct multipart *m, const char *ct, const struct multipart_cb *cb)
{
	const char *b;
	size_t n;

	memset(m, 0, sizeof *m);
	m->cb = *cb;
	if (!ct || strncasecmp(ct, "multipart/form-data", 19) != 0)
		return -1;
	b = strcasestr(ct, "boundary=");
	if (!b)
		return -1;
	b += 9;
	if (*b == '"') {
		b++;
		n = strcspn(b, "\"");
	} else {
		n = strcspn(b, "; \t");
	}
	if (n == 0 || n > MULTIPART_BOUNDARY_MAX)
		return -1;
	for (size_t i = 0; i < n; i++)
		if (b[i] == '\r' || b[i] == '\n' || !isprint((unsigned char)b[i]))
			return -1;
	memcpy(m->delim, "\r\n--", 4);
	memcpy(m->delim + 4, b, n);
	m->dlen = n + 4;
	m->state = MP_PREAMBLE;
	return multipart_feed(m, "\r\n", 2);
}

/* Value of param (name= or filename=) in a Content-Disposition line. */
static void disposition_param(const char *line, const char *param, char *out, size_t len)
{
	const char *p = line;
	size_t pl = strlen(param);

	out[0] = '\0';
	while ((p = strcasestr(p, param)) != NULL) {
		if ((p == line || p[-1] == ' ' || p[-1] == ';' || p[-1] == '\t') && p[pl] == '=') {
			size_t n;
			p += pl + 1;
			if (*p == '"') {
				p++;
				n = strcspn(p, "\"");
			} else {
				n = strcspn(p, "; \t\r");
			}
			if (n >= len)
				n = len - 1;
			memcpy(out, p, n);
			out[n] = '\0';
			return;
		}
		p += pl;
	}
}

static int headers_done(struct multipart *m)
{
	char name[128] = "", filename[256] = "";
	char *line = m->hdr;

	m->hdr[m->hlen] = '\0';
	while (line && *line) {
		char *end = strstr(line, "\r\n");
		if (end)
			*end = '\0';
		if (!strncasecmp(line, "Content-Disposition:", 20)) {
			disposition_param(line + 20, "name", name, sizeof name);
			disposition_param(line + 20, "filename", filename, sizeof filename);
		}
		line = end ? end + 2 : NULL;
	}
	if (!name[0])
		return fail(m, "a multipart part has no Content-Disposition name");
	if (m->cb.begin(m->cb.ctx, name, filename))
		return fail(m, "upload stopped");
	m->state = MP_BODY;
	return 0;
}

static int emit(struct multipart *m, const void *p, size_t len)
{
	if (len == 0 || m->state != MP_BODY)
		return 0; /* preamble bytes are dropped */
	if (m->cb.data(m->cb.ctx, p, len))
		return fail(m, "upload stopped");
	return 0;
}

int multipart_feed(struct multipart *m, const void *data, size_t len)
{
	const unsigned char *p = data, *end = p + len;

	while (p < end) {
		switch (m->state) {
		case MP_PREAMBLE:
		case MP_BODY:
			if (m->matched == 0) {
				const unsigned char *cr = memchr(p, '\r', (size_t)(end - p));
				if (!cr)
					return emit(m, p, (size_t)(end - p));
				if (emit(m, p, (size_t)(cr - p)))
					return -1;
				p = cr;
			}
			if (*p == (unsigned char)m->delim[m->matched]) {
				p++;
				if (++m->matched == m->dlen) {
					m->matched = 0;
					m->state = MP_AFTER_DELIM;
					m->after = 0;
				}
			} else {
				/* Matched bytes were data; retry this byte fresh. */
				size_t k = m->matched;
				m->matched = 0;
				if (emit(m, m->delim, k))
					return -1;
			}
			break;
		case MP_AFTER_DELIM:
			/* "--" closes the body; "\r\n" opens a part (LWS allowed). */
			if (m->after == 0 && *p == '-') {
				m->after = 1;
			} else if (m->after == 1) {
				if (*p != '-')
					return fail(m, "malformed multipart delimiter");
				m->state = MP_DONE;
			} else if (*p == ' ' || *p == '\t') {
				/* transport padding */
			} else if (*p == '\r' && m->after == 0) {
				m->after = 2;
			} else if (*p == '\n' && m->after == 2) {
				m->state = MP_HEADERS;
				m->hlen = 0;
			} else {
				return fail(m, "malformed multipart delimiter");
			}
			p++;
			break;
		case MP_HEADERS:
			if (m->hlen + 1 >= sizeof m->hdr)
				return fail(m, "multipart part headers longer than 2 KiB");
			m->hdr[m->hlen++] = (char)*p++;
			if (m->hlen >= 4 && !memcmp(m->hdr + m->hlen - 4, "\r\n\r\n", 4)) {
				m->hlen -= 2;
				if (headers_done(m))
					return -1;
			} else if (m->hlen == 2 && !memcmp(m->hdr, "\r\n", 2)) {
				m->hlen = 0; /* part without headers */
				if (headers_done(m))
					return -1;
			}
			break;
		case MP_DONE:
			return 0; /* epilogue is ignored */
		default:
			return -1;
		}
	}
	return 0;
}

int multipart_finish(struct multipart *m)
{
	if (m->state == MP_DONE)
		return 0;
	if (m->state != MP_ERROR)
		fail(m, "the multipart body ends before its closing delimiter");
	return -1;
}
