/* text.h - the byte scanner shared by the text readers (STL, OBJ, OFF, PLY).
 *
 * Works on a mapped file that is not NUL-terminated: every step checks
 * against `end`.  Tracks the 1-based line of the read position for error
 * places.  Numbers are parsed without the C library's locale (a service
 * may run under any LC_NUMERIC): mesh_text_number() is exact (correctly
 * rounded) for up to 19 significant digits with Clinger's fast path and
 * falls back to strtod on a canonical "<digits>e<exp>" copy otherwise.
 */
#ifndef INFILLD_MESH_TEXT_H
#define INFILLD_MESH_TEXT_H

#include <stddef.h>
#include <string.h>

struct mesh_text {
	const char *p, *end, *base;
	long line; /* line of p, 1-based */
};

static inline void mesh_text_init(struct mesh_text *t, const void *data, size_t len)
{
	t->base = t->p = data;
	t->end = t->p + len;
	t->line = 1;
}

static inline int mesh_text_blank_char(char c)
{
	return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/* Skip blanks on the current line (not the newline). */
static inline void mesh_text_skip_blank(struct mesh_text *t)
{
	while (t->p < t->end && mesh_text_blank_char(*t->p))
		t->p++;
}

/* Skip all whitespace, counting newlines. */
static inline void mesh_text_skip_ws(struct mesh_text *t)
{
	while (t->p < t->end) {
		char c = *t->p;
		if (c == '\n')
			t->line++;
		else if (!mesh_text_blank_char(c))
			break;
		t->p++;
	}
}

/* Move to the start of the next line (or the end). */
static inline void mesh_text_next_line(struct mesh_text *t)
{
	const char *nl = memchr(t->p, '\n', (size_t)(t->end - t->p));

	if (nl) {
		t->p = nl + 1;
		t->line++;
	} else {
		t->p = t->end;
	}
}

/* After skipping blanks: at the end of the line or of the input? */
static inline int mesh_text_at_eol(const struct mesh_text *t)
{
	return t->p >= t->end || *t->p == '\n';
}

/* The whitespace-delimited word at p (after the caller skipped blanks);
 * does not move.  Returns its length (0 at a blank, newline or end). */
static inline size_t mesh_text_word(const struct mesh_text *t, const char **w)
{
	const char *q = t->p;

	while (q < t->end && *q != '\n' && !mesh_text_blank_char(*q))
		q++;
	*w = t->p;
	return (size_t)(q - t->p);
}

/* Case-insensitive: is w[0, n) the keyword kw (lower case)? */
static inline int mesh_text_word_is(const char *w, size_t n, const char *kw)
{
	size_t i;

	for (i = 0; i < n; i++) {
		char c = w[i];
		if (c >= 'A' && c <= 'Z')
			c = (char)(c - 'A' + 'a');
		if (kw[i] == '\0' || kw[i] != c) /* input may hold NUL bytes */
			return 0;
	}
	return kw[n] == '\0';
}

/* Is the byte at p a delimiter after a number (blank, newline, end)? */
static inline int mesh_text_delim(const struct mesh_text *t)
{
	return t->p >= t->end || *t->p == '\n' || mesh_text_blank_char(*t->p);
}

/* Parse a decimal number at p ([+-]digits[.digits][(e|E)[+-]digits],
 * also nan/inf/infinity in any case) into *out and advance; does not
 * check what follows.  0, or -1 with p unmoved when there is no number. */
int mesh_text_number(struct mesh_text *t, double *out);

/* Parse [+-]digits into *out (saturating at +-2^62) and advance.
 * 0, or -1 with p unmoved. */
int mesh_text_int(struct mesh_text *t, long long *out);

/* Printable excerpt of the word at p for messages ("..." if cut). */
void mesh_text_excerpt(const struct mesh_text *t, char *buf, size_t n);

#endif
