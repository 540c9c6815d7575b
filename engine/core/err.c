/* err.c - the error record (see err.h). */
#include "engine/core/err.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void err_clear(struct err *e)
{
	if (!e)
		return;
	memset(e, 0, sizeof *e);
	e->offset = -1;
	e->item = -1;
}

static void set_msg(struct err *e, int code, const char *src_file, int src_line,
		    const char *fmt, va_list ap)
{
	e->code = code;
	e->src_file = src_file;
	e->src_line = src_line;
	vsnprintf(e->msg, sizeof e->msg, fmt, ap);
}

int err_set_at(struct err *e, int code, const char *src_file, int src_line,
	       const char *fmt, ...)
{
	va_list ap;

	if (!e)
		return code;
	va_start(ap, fmt);
	set_msg(e, code, src_file, src_line, fmt, ap);
	va_end(ap);
	return code;
}

int err_set_place_at(struct err *e, int code, const char *src_file, int src_line,
		     long long offset, long line, long long item, const char *fmt, ...)
{
	va_list ap;

	if (!e)
		return code;
	va_start(ap, fmt);
	set_msg(e, code, src_file, src_line, fmt, ap);
	va_end(ap);
	e->offset = offset;
	e->line = line;
	e->item = item;
	return code;
}

int err_set_field_at(struct err *e, const char *src_file, int src_line,
		     const char *field, const char *fmt, ...)
{
	va_list ap;

	if (!e)
		return ERR_PARAM;
	va_start(ap, fmt);
	set_msg(e, ERR_PARAM, src_file, src_line, fmt, ap);
	va_end(ap);
	snprintf(e->field, sizeof e->field, "%s", field ? field : "");
	return ERR_PARAM;
}

void err_prefix(struct err *e, const char *fmt, ...)
{
	char head[ERR_MSG_MAX], old[ERR_MSG_MAX];
	va_list ap;

	if (!e)
		return;
	va_start(ap, fmt);
	vsnprintf(head, sizeof head, fmt, ap);
	va_end(ap);
	memcpy(old, e->msg, sizeof old);
	snprintf(e->msg, sizeof e->msg, "%s: %s", head, old);
}

const char *err_code_name(int code)
{
	switch (code) {
	case ERR_OK: return "ok";
	case ERR_NOMEM: return "nomem";
	case ERR_IO: return "io";
	case ERR_PARSE: return "parse";
	case ERR_PARAM: return "param";
	case ERR_GEOMETRY: return "geometry";
	case ERR_UNSUPPORTED: return "unsupported";
	case ERR_LIMIT: return "limit";
	case ERR_FIT: return "fit";
	case ERR_CANCELLED: return "cancelled";
	case ERR_INTERNAL: return "internal";
	case ERR_NOTFOUND: return "notfound";
	}
	return "unknown";
}

const char *err_format(const struct err *e, char *buf, size_t buf_len)
{
	char place[160] = "";
	size_t n = 0;

	if (!buf || buf_len == 0)
		return "";
	if (e->line > 0)
		n += (size_t)snprintf(place + n, sizeof place - n, " at line %ld", e->line);
	else if (e->offset >= 0)
		n += (size_t)snprintf(place + n, sizeof place - n, " at byte %lld", e->offset);
	if (e->item >= 0 && n < sizeof place)
		n += (size_t)snprintf(place + n, sizeof place - n, "%s(record %lld)",
				      n ? " " : " at ", e->item);
	if (e->field[0] && n < sizeof place)
		snprintf(place + n, sizeof place - n, " (parameter %s)", e->field);
	snprintf(buf, buf_len, "%s error%s: %s", err_code_name(e->code), place, e->msg);
	return buf;
}
