/* text.c - locale-independent number parsing for the text readers (text.h).
 *
 * Clinger's fast path: a decimal with at most 19 significant digits whose
 * mantissa is below 2^53 and whose decimal exponent is within +-22 is one
 * correctly rounded multiplication or division by an exact power of ten.
 * Everything else goes through strtod on a short canonical copy.
 */
#include "engine/mesh/text.h"

#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static const double pow10_exact[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
				       1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
				       1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

static int is_digit(char c)
{
	return (unsigned)(c - '0') < 10u;
}

/* Case-insensitive match of the lower-case word kw at [p, end). */
static size_t match_word(const char *p, const char *end, const char *kw)
{
	size_t i;

	for (i = 0; kw[i]; i++) {
		char c;
		if (p + i >= end)
			return 0;
		c = p[i];
		if (c >= 'A' && c <= 'Z')
			c = (char)(c - 'A' + 'a');
		if (c != kw[i])
			return 0;
	}
	return i;
}

int mesh_text_number(struct mesh_text *t, double *out)
{
	const char *p = t->p, *end = t->end;
	uint64_t mant = 0;
	int ndig = 0, exp10 = 0, any = 0, neg = 0;
	double v;

	if (p < end && (*p == '+' || *p == '-')) {
		neg = *p == '-';
		p++;
	}
	for (; p < end && is_digit(*p); p++) {
		any = 1;
		if (ndig < 19) {
			mant = mant * 10 + (uint64_t)(*p - '0');
			ndig += mant != 0;
		} else {
			exp10++;
		}
	}
	if (p < end && *p == '.') {
		p++;
		for (; p < end && is_digit(*p); p++) {
			any = 1;
			if (ndig < 19) {
				mant = mant * 10 + (uint64_t)(*p - '0');
				ndig += mant != 0;
				exp10--;
			}
		}
	}
	if (!any) {
		size_t n;
		if ((n = match_word(p, end, "nan")) != 0) {
			v = NAN;
		} else if ((n = match_word(p, end, "infinity")) != 0 ||
			   (n = match_word(p, end, "inf")) != 0) {
			v = INFINITY;
		} else {
			return -1;
		}
		t->p = p + n;
		*out = neg ? -v : v;
		return 0;
	}
	if (p < end && (*p == 'e' || *p == 'E')) {
		const char *q = p + 1;
		int eneg = 0, e = 0;
		if (q < end && (*q == '+' || *q == '-')) {
			eneg = *q == '-';
			q++;
		}
		if (q < end && is_digit(*q)) {
			for (; q < end && is_digit(*q); q++)
				if (e < 100000)
					e = e * 10 + (*q - '0');
			exp10 += eneg ? -e : e;
			p = q;
		}
	}
	t->p = p;
	if (mant == 0) {
		v = 0.0;
	} else if (mant <= (UINT64_C(1) << 53) && exp10 >= -22 && exp10 <= 22) {
		v = exp10 >= 0 ? (double)mant * pow10_exact[exp10] : (double)mant / pow10_exact[-exp10];
	} else {
		char buf[48];
		snprintf(buf, sizeof buf, "%" PRIu64 "e%d", mant, exp10);
		v = strtod(buf, NULL);
	}
	*out = neg ? -v : v;
	return 0;
}

int mesh_text_int(struct mesh_text *t, long long *out)
{
	const char *p = t->p, *end = t->end;
	long long v = 0;
	int neg = 0;

	if (p < end && (*p == '+' || *p == '-')) {
		neg = *p == '-';
		p++;
	}
	if (p >= end || !is_digit(*p))
		return -1;
	for (; p < end && is_digit(*p); p++) /* saturate without overflowing */
		v = v < (1LL << 62) / 10 ? v * 10 + (*p - '0') : 1LL << 62;
	t->p = p;
	*out = neg ? -v : v;
	return 0;
}

void mesh_text_excerpt(const struct mesh_text *t, char *buf, size_t n)
{
	const char *q = t->p;
	size_t i = 0;

	if (n == 0)
		return;
	while (q < t->end && *q != '\n' && *q != '\r' && i + 4 < n && i < 24) {
		unsigned char c = (unsigned char)*q++;
		buf[i++] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
	}
	if (q < t->end && *q != '\n' && *q != '\r' && i + 4 <= n) {
		memcpy(buf + i, "...", 3);
		i += 3;
	}
	buf[i] = '\0';
}
