/* err.h - status codes and the caller-owned error record.
 *
 * Every fallible function in engine/ returns 0 (ERR_OK) or a negative
 * enum err_code and, on failure, fills a struct err the caller owns.
 * ERR_SET() records where in our source the error was raised (SQLite's
 * *_BKPT idea) so a failed job can be traced to one line.  Parsers also
 * record the place in the input (byte offset, line, facet index).
 */
#ifndef INFILLD_ERR_H
#define INFILLD_ERR_H

#include <stddef.h>

enum err_code {
	ERR_OK = 0,
	ERR_NOMEM = -1,       /* allocation failed */
	ERR_IO = -2,          /* read/write/open failed (errno text in msg) */
	ERR_PARSE = -3,       /* malformed input file (place in offset/line/item) */
	ERR_PARAM = -4,       /* bad parameter value (name in field) */
	ERR_GEOMETRY = -5,    /* input readable but geometrically unusable */
	ERR_UNSUPPORTED = -6, /* valid request we do not implement */
	ERR_LIMIT = -7,       /* a size/count/resource limit was hit */
	ERR_FIT = -8,         /* part does not fit the printer's build volume */
	ERR_CANCELLED = -9,   /* cooperative cancellation was requested */
	ERR_INTERNAL = -10,   /* invariant broken: a bug, not bad input */
	ERR_NOTFOUND = -11    /* named engine/printer/file does not exist */
};

#define ERR_MSG_MAX 512
#define ERR_FIELD_MAX 64

struct err {
	int code;                  /* enum err_code */
	char msg[ERR_MSG_MAX];     /* one line, no trailing newline */
	const char *src_file;      /* where raised in our code (static string) */
	int src_line;
	long long offset;          /* byte offset in the input, -1 if unknown */
	long line;                 /* 1-based line in a text input, 0 if unknown */
	long long item;            /* facet/vertex/record index, -1 if unknown */
	char field[ERR_FIELD_MAX]; /* offending parameter name, "" if none */
};

/* Reset to "no error". */
void err_clear(struct err *e);

/* Fill *e (may be NULL: then only the code is returned) with code and a
 * printf-style message; returns code so callers can `return ERR_SET(...)`.
 * Keeps offset/line/item/field untouched: set them with the helpers below
 * before or after. */
int err_set_at(struct err *e, int code, const char *src_file, int src_line,
	       const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 5, 6)))
#endif
	;

#define ERR_SET(e, code, ...) err_set_at((e), (code), __FILE__, __LINE__, __VA_ARGS__)

/* Same, recording the place in the input. Pass -1/0/-1 for unknown parts. */
int err_set_place_at(struct err *e, int code, const char *src_file, int src_line,
		     long long offset, long line, long long item, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 8, 9)))
#endif
	;

#define ERR_PLACE(e, code, offset, line, item, ...) \
	err_set_place_at((e), (code), __FILE__, __LINE__, (offset), (line), (item), __VA_ARGS__)

/* ERR_PARAM naming the parameter: `return ERR_FIELD(e, "layer_mm", "...")`. */
int err_set_field_at(struct err *e, const char *src_file, int src_line,
		     const char *field, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 5, 6)))
#endif
	;

#define ERR_FIELD(e, field, ...) err_set_field_at((e), __FILE__, __LINE__, (field), __VA_ARGS__)

/* Prefix the existing message with context: "reading x.stl: <old msg>". */
void err_prefix(struct err *e, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 2, 3)))
#endif
	;

/* Stable lower-case name of a code ("parse", "param", ...), for logs and APIs. */
const char *err_code_name(int code);

/* One-line human text including the input place when known:
 * "parse error at byte 84 (facet 0): NaN coordinate". Returns buf. */
const char *err_format(const struct err *e, char *buf, size_t buf_len);

#endif
