/* png_encode.c - PNG encoders (see image.h): a run-length deflate
 * coder for 8-bit gray layer images, libpng for the container and for
 * RGBA thumbnails.
 *
 * Deflate (RFC 1951) here: every run of n equal bytes becomes one
 * literal and then matches of distance 1 (lengths 3..258), coded with
 * per-block dynamic Huffman codes; zlib wrapper (RFC 1950) with an
 * Adler-32 computed per run in closed form.  Design: docs/formats.md.
 */
#include "engine/output/image/image.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"

#include <png.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#define TOK_CAP OUT_PNG_TOKENS
#define LITLEN_N 286    /* literal/length alphabet: 0..255, EOB 256, lengths 257..285 */
#define CLEN_N 19       /* code-length alphabet */
#define ADLER_MOD 65521u
#define MATCH_MAX 258

/* ---- Huffman code construction ---- */

struct sym_freq {
	uint32_t f;
	uint16_t s;
};

static int cmp_sym_freq(const void *a, const void *b)
{
	const struct sym_freq *x = a, *y = b;

	if (x->f != y->f)
		return x->f < y->f ? -1 : 1;
	return x->s < y->s ? -1 : x->s > y->s;
}

/* Minimum-redundancy code lengths for weights a[0..n-1] sorted
 * ascending, computed in place (Moffat and Katajainen, "In-place
 * calculation of minimum-redundancy codes", 1995): on return a[i] is the
 * code length of the i-th lightest symbol.  n >= 2.  O(n). */
static void code_lengths_in_place(uint32_t *a, int n)
{
	int root, leaf, next, avail, used, depth;

	/* Pass 1: build the tree left to right; internal nodes keep their
	 * parent's index once consumed. */
	a[0] += a[1];
	root = 0;
	leaf = 2;
	for (next = 1; next < n - 1; next++) {
		if (leaf >= n || a[root] < a[leaf]) {
			a[next] = a[root];
			a[root++] = (uint32_t)next;
		} else {
			a[next] = a[leaf++];
		}
		if (leaf >= n || (root < next && a[root] < a[leaf])) {
			a[next] += a[root];
			a[root++] = (uint32_t)next;
		} else {
			a[next] += a[leaf++];
		}
	}
	/* Pass 2: depths of the internal nodes, right to left. */
	a[n - 2] = 0;
	for (next = n - 3; next >= 0; next--)
		a[next] = a[a[next]] + 1;
	/* Pass 3: leaf depths from the count of internal nodes per level. */
	avail = 1;
	used = depth = 0;
	root = n - 2;
	next = n - 1;
	while (avail > 0) {
		while (root >= 0 && (int)a[root] == depth) {
			used++;
			root--;
		}
		while (avail > used) {
			a[next--] = (uint32_t)depth;
			avail--;
		}
		avail = 2 * used;
		depth++;
		used = 0;
	}
}

/* Code lengths (at most max_bits) for freq[0..n-1] into len.  At least two
 * symbols always get a code (a dummy one is added when fewer are used),
 * so every code is complete, as strict inflaters require.  When the
 * optimal code is too deep the weights are halved (rounding up) until it
 * fits: all-ones weights give a balanced tree of depth ceil(log2 n). */
static void huffman_lengths(const uint32_t *freq, int n, int max_bits, uint8_t *len)
{
	struct sym_freq sf[LITLEN_N];
	uint32_t w[LITLEN_N];
	uint32_t f[LITLEN_N];
	int cnt = 0;

	memcpy(f, freq, (size_t)n * sizeof *f);
	for (int i = 0; i < n; i++)
		cnt += f[i] != 0;
	for (int i = 0; i < n && cnt < 2; i++)
		if (!f[i]) {
			f[i] = 1;
			cnt++;
		}
	for (;;) {
		cnt = 0;
		for (int i = 0; i < n; i++)
			if (f[i]) {
				sf[cnt].f = f[i];
				sf[cnt].s = (uint16_t)i;
				cnt++;
			}
		qsort(sf, (size_t)cnt, sizeof sf[0], cmp_sym_freq);
		for (int i = 0; i < cnt; i++)
			w[i] = sf[i].f;
		code_lengths_in_place(w, cnt);
		if ((int)w[0] <= max_bits)
			break;
		for (int i = 0; i < n; i++)
			if (f[i])
				f[i] = (f[i] + 1) / 2;
	}
	memset(len, 0, (size_t)n);
	for (int i = 0; i < cnt; i++)
		len[sf[i].s] = (uint8_t)w[i];
}

/* Canonical codes (RFC 1951 3.2.2), bit-reversed for LSB-first output. */
static void canonical_codes(const uint8_t *len, int n, uint16_t *code)
{
	uint16_t count[16] = {0}, next[16];
	uint16_t c = 0;

	for (int i = 0; i < n; i++)
		count[len[i]]++;
	count[0] = 0;
	for (int b = 1; b < 16; b++) {
		c = (uint16_t)((c + count[b - 1]) << 1);
		next[b] = c;
	}
	for (int i = 0; i < n; i++) {
		uint16_t v, r = 0;
		if (!len[i]) {
			code[i] = 0;
			continue;
		}
		v = next[len[i]]++;
		for (int b = 0; b < len[i]; b++)
			r = (uint16_t)(r | (((v >> b) & 1u) << (len[i] - 1 - b)));
		code[i] = r;
	}
}

/* Length 3..258 -> symbol 257..285 with its extra bits. */
static void length_symbol(int length, int *sym, int *nbits, int *extra)
{
	int n = length - 3, b;

	if (length == MATCH_MAX) {
		*sym = 285;
		*nbits = *extra = 0;
		return;
	}
	if (n < 8) {
		*sym = 257 + n;
		*nbits = *extra = 0;
		return;
	}
	b = 29 - __builtin_clz((unsigned)n); /* floor(log2 n) - 2 */
	*sym = 257 + 4 * (b + 1) + ((n >> b) - 4);
	*nbits = b;
	*extra = n & ((1 << b) - 1);
}

/* ---- The run-length coder ---- */

struct rle {
	uint32_t *tok; /* symbol (bits 0-8) | extra bit count (9-11) | extra
			  bits (12-16); matches are at distance 1 */
	size_t ntok;
	struct buf *out;
	uint64_t acc; /* pending output bits, LSB first */
	int nacc;     /* < 32 between calls */
	uint32_t s1, s2;
	int cur;      /* value of the pending run, -1 before the first byte */
	uint64_t run; /* its length */
	int failed;   /* ERR_NOMEM while growing out */
};

static inline void put_bits(struct rle *z, uint8_t **p, uint32_t v, int n)
{
	z->acc |= (uint64_t)v << z->nacc;
	z->nacc += n;
	if (z->nacc >= 32) {
		uint8_t *q = *p;
		q[0] = (uint8_t)z->acc;
		q[1] = (uint8_t)(z->acc >> 8);
		q[2] = (uint8_t)(z->acc >> 16);
		q[3] = (uint8_t)(z->acc >> 24);
		*p = q + 4;
		z->acc >>= 32;
		z->nacc -= 32;
	}
}

/* Code-length sequence run-length coded with symbols 16/17/18 (RFC 1951
 * 3.2.7).  Returns the count of entries in sym/extra. */
static int rle_code_lengths(const uint8_t *lens, int n, uint8_t *sym, uint8_t *extra)
{
	int k = 0;

	for (int i = 0; i < n;) {
		int v = lens[i], r = 1;
		while (i + r < n && lens[i + r] == v)
			r++;
		i += r;
		if (v == 0) {
			while (r >= 11) {
				int m = r < 138 ? r : 138;
				sym[k] = 18;
				extra[k++] = (uint8_t)(m - 11);
				r -= m;
			}
			if (r >= 3) {
				sym[k] = 17;
				extra[k++] = (uint8_t)(r - 3);
				r = 0;
			}
		} else {
			sym[k] = (uint8_t)v;
			extra[k++] = 0;
			r--;
			while (r >= 3) {
				int m = r < 6 ? r : 6;
				sym[k] = 16;
				extra[k++] = (uint8_t)(m - 3);
				r -= m;
			}
		}
		while (r-- > 0) {
			sym[k] = (uint8_t)v;
			extra[k++] = 0;
		}
	}
	return k;
}

/* Emit the buffered tokens as one dynamic-Huffman block. */
static void emit_block(struct rle *z, int final)
{
	static const uint8_t clen_order[CLEN_N] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
						   11, 4,  12, 3, 13, 2, 14, 1, 15};
	uint32_t freq[LITLEN_N] = {0}, cfreq[CLEN_N] = {0};
	uint8_t lens[LITLEN_N + 2], clen[CLEN_N], sym[LITLEN_N + 2], extra[LITLEN_N + 2];
	uint16_t code[LITLEN_N], ccode[CLEN_N];
	int hlit, hclen, nsym, nb, ex;
	struct buf *o = z->out;
	void *data = o->data;
	uint8_t *p;

	if (z->failed)
		return;
	/* room: header <= 600 bytes, each token <= 21 bits */
	if (mem_grow(&data, &o->cap, o->len + z->ntok * 3 + 1024, 1)) {
		z->failed = ERR_NOMEM;
		return;
	}
	o->data = data;
	p = o->data + o->len;

	freq[256] = 1;
	for (size_t i = 0; i < z->ntok; i++)
		freq[z->tok[i] & 0x1ff]++;
	huffman_lengths(freq, LITLEN_N, 15, lens);
	canonical_codes(lens, LITLEN_N, code);
	for (hlit = LITLEN_N; hlit > 257 && !lens[hlit - 1]; hlit--)
		;
	/* Distance code: only distance 1 (symbol 0) is used; symbols 0 and 1
	 * both get one bit so the code is complete. */
	lens[hlit] = lens[hlit + 1] = 1;
	nsym = rle_code_lengths(lens, hlit + 2, sym, extra);
	for (int i = 0; i < nsym; i++)
		cfreq[sym[i]]++;
	huffman_lengths(cfreq, CLEN_N, 7, clen);
	canonical_codes(clen, CLEN_N, ccode);
	for (hclen = CLEN_N; hclen > 4 && !clen[clen_order[hclen - 1]]; hclen--)
		;

	put_bits(z, &p, final ? 1u : 0u, 1);
	put_bits(z, &p, 2, 2); /* BTYPE 10: dynamic Huffman */
	put_bits(z, &p, (uint32_t)(hlit - 257), 5);
	put_bits(z, &p, 2 - 1, 5); /* HDIST */
	put_bits(z, &p, (uint32_t)(hclen - 4), 4);
	for (int i = 0; i < hclen; i++)
		put_bits(z, &p, clen[clen_order[i]], 3);
	for (int i = 0; i < nsym; i++) {
		put_bits(z, &p, ccode[sym[i]], clen[sym[i]]);
		if (sym[i] == 16)
			put_bits(z, &p, extra[i], 2);
		else if (sym[i] == 17)
			put_bits(z, &p, extra[i], 3);
		else if (sym[i] == 18)
			put_bits(z, &p, extra[i], 7);
	}
	for (size_t i = 0; i < z->ntok; i++) {
		uint32_t t = z->tok[i], ts = t & 0x1ff;
		if (ts < 256) {
			put_bits(z, &p, code[ts], lens[ts]);
		} else {
			/* length code, its extra bits, then the one-bit distance
			 * code 0 (distance 1): at most 15 + 5 + 1 bits at once */
			nb = (int)((t >> 9) & 7);
			ex = (int)(t >> 12);
			put_bits(z, &p, code[ts] | (uint32_t)ex << lens[ts], lens[ts] + nb + 1);
		}
	}
	put_bits(z, &p, code[256], lens[256]);
	o->len = (size_t)(p - o->data);
	z->ntok = 0;
}

static inline void push_token(struct rle *z, uint32_t t)
{
	if (z->ntok == TOK_CAP)
		emit_block(z, 0);
	z->tok[z->ntok++] = t;
}

/* Adler-32 of n bytes of value c appended: s1 += n c, s2 += n s1 + c n(n+1)/2. */
static void adler_run(struct rle *z, uint32_t c, uint64_t n)
{
	uint64_t tri = (n % 2 == 0) ? ((n / 2) % ADLER_MOD) * ((n + 1) % ADLER_MOD)
				    : (n % ADLER_MOD) * (((n + 1) / 2) % ADLER_MOD);
	uint64_t nm = n % ADLER_MOD;

	z->s2 = (uint32_t)((z->s2 + nm * z->s1 + c * (tri % ADLER_MOD)) % ADLER_MOD);
	z->s1 = (uint32_t)((z->s1 + nm * c) % ADLER_MOD);
}

/* The token of a match of `length` at distance 1. */
static uint32_t match_token(int length)
{
	int sym, nb, ex;

	length_symbol(length, &sym, &nb, &ex);
	return (uint32_t)sym | (uint32_t)nb << 9 | (uint32_t)ex << 12;
}

/* Emit the pending run: a literal, then matches of distance 1. */
static void flush_run(struct rle *z)
{
	const uint32_t max_tok = 285; /* length 258: no extra bits */
	uint64_t rem;

	if (z->cur < 0 || z->run == 0)
		return;
	adler_run(z, (uint32_t)z->cur, z->run);
	push_token(z, (uint32_t)z->cur);
	rem = z->run - 1;
	/* full-length matches, leaving a tail of 3..258 or 0..2 */
	while (rem > MATCH_MAX + 2) {
		push_token(z, max_tok);
		rem -= MATCH_MAX;
	}
	if (rem > MATCH_MAX) { /* 259 or 260: split so both halves are >= 3 */
		push_token(z, match_token((int)rem - 3));
		rem = 3;
	}
	if (rem >= 3)
		push_token(z, match_token((int)rem));
	else
		while (rem-- > 0)
			push_token(z, (uint32_t)z->cur);
	z->run = 0;
}

static inline void add_run(struct rle *z, int c, uint64_t n)
{
	if (n == 0)
		return;
	if (c == z->cur) {
		z->run += n;
		return;
	}
	flush_run(z);
	z->cur = c;
	z->run = n;
}

/* Blocks of 0 and 255, the values of long runs, for memcmp() (which the
 * C library vectorises). */
#define BLOCK_BYTES 256
static const uint8_t zero_block[BLOCK_BYTES];
static const uint8_t full_block[BLOCK_BYTES] = {
#define X16 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255, 255
	X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16, X16
#undef X16
};

/* First index in [i, end) whose byte differs from c, or end. */
static inline int run_end(const uint8_t *row, int i, int end, uint8_t c)
{
	const uint64_t pat = 0x0101010101010101ull * c;

	if (c == 0 || c == 255) {
		const uint8_t *blk = c ? full_block : zero_block;
		while (i + BLOCK_BYTES <= end && memcmp(row + i, blk, BLOCK_BYTES) == 0)
			i += BLOCK_BYTES;
	}

	/* long runs (black margins, solid interiors): 32 bytes a step */
	while (i + 32 <= end) {
		uint64_t a, b, d, f;
		memcpy(&a, row + i, 8);
		memcpy(&b, row + i + 8, 8);
		memcpy(&d, row + i + 16, 8);
		memcpy(&f, row + i + 24, 8);
		if ((a ^ pat) | (b ^ pat) | (d ^ pat) | (f ^ pat))
			break;
		i += 32;
	}
	while (i + 8 <= end) {
		uint64_t v;
		memcpy(&v, row + i, 8);
		v ^= pat;
		if (v) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
			return i + (__builtin_clzll(v) >> 3);
#else
			return i + (__builtin_ctzll(v) >> 3);
#endif
		}
		i += 8;
	}
	while (i < end && row[i] == c)
		i++;
	return i;
}

/* Encode the filtered scanlines of r as a zlib stream appended to out,
 * with tok (TOK_CAP entries) for the tokens. */
static int zlib_stream(const struct raster *r, const struct out_px_rect *content, uint32_t *tok,
		       struct buf *out, struct out_png_stats *st, struct err *e)
{
	struct rle z;
	int cx0 = 0, cy0 = 0, cx1 = r->w - 1, cy1 = r->h - 1;
	uint8_t *p;
	void *data;

	memset(&z, 0, sizeof z);
	z.out = out;
	z.s1 = 1;
	z.cur = -1;
	z.tok = tok;
	if (buf_append(out, (const uint8_t[]){0x78, 0x01}, 2))
		return ERR_SET(e, ERR_NOMEM, "out of memory encoding a %d x %d PNG", r->w, r->h);
	if (content) {
		cx0 = content->x0 > 0 ? content->x0 : 0;
		cy0 = content->y0 > 0 ? content->y0 : 0;
		cx1 = content->x1 < r->w - 1 ? content->x1 : r->w - 1;
		cy1 = content->y1 < r->h - 1 ? content->y1 : r->h - 1;
		if (cx0 > cx1)
			cy0 = cy1 + 1; /* nothing to read */
	}
	st->sum = 0;
	st->nz.x0 = st->nz.y0 = 0x7fffffff;
	st->nz.x1 = st->nz.y1 = -1;
	for (int y = 0; y < r->h; y++) {
		const uint8_t *row = r->px + (size_t)y * r->stride;
		int x, row_nz = 0;

		if (y < cy0 || y > cy1) {
			add_run(&z, 0, (uint64_t)r->w + 1);
			continue;
		}
		add_run(&z, 0, 1 + (uint64_t)cx0); /* filter byte, known zeros */
		for (x = cx0; x <= cx1;) {
			uint8_t c = row[x];
			int end = run_end(row, x + 1, cx1 + 1, c);
			if (c) {
				st->sum += (uint64_t)c * (uint64_t)(end - x);
				if (x < st->nz.x0)
					st->nz.x0 = x;
				if (end - 1 > st->nz.x1)
					st->nz.x1 = end - 1;
				row_nz = 1;
			}
			add_run(&z, c, (uint64_t)(end - x));
			x = end;
		}
		add_run(&z, 0, (uint64_t)(r->w - 1 - cx1));
		if (row_nz) {
			if (y < st->nz.y0)
				st->nz.y0 = y;
			st->nz.y1 = y;
		}
	}
	flush_run(&z);
	emit_block(&z, 1);
	if (z.failed)
		return ERR_SET(e, ERR_NOMEM, "out of memory encoding a %d x %d PNG", r->w, r->h);
	/* pad the last byte, then the Adler-32, big-endian */
	data = out->data;
	if (mem_grow(&data, &out->cap, out->len + 12, 1))
		return ERR_SET(e, ERR_NOMEM, "out of memory encoding a %d x %d PNG", r->w, r->h);
	out->data = data;
	p = out->data + out->len;
	while (z.nacc > 0) {
		*p++ = (uint8_t)z.acc;
		z.acc >>= 8;
		z.nacc -= 8;
	}
	p[0] = (uint8_t)(z.s2 >> 8);
	p[1] = (uint8_t)z.s2;
	p[2] = (uint8_t)(z.s1 >> 8);
	p[3] = (uint8_t)z.s1;
	out->len = (size_t)(p + 4 - out->data);
	if (st->nz.x1 < 0)
		st->nz.x0 = st->nz.y0 = 0;
	return 0;
}

/* ---- libpng glue ---- */

struct png_job {
	struct buf *out;
	int oom;
	char msg[160];
};

static void png_write_cb(png_structp p, png_bytep data, size_t len)
{
	struct png_job *job = png_get_io_ptr(p);

	if (buf_append(job->out, data, len)) {
		job->oom = 1;
		png_error(p, "out of memory");
	}
}

static void png_flush_cb(png_structp p)
{
	(void)p;
}

static void png_error_cb(png_structp p, png_const_charp msg)
{
	struct png_job *job = png_get_error_ptr(p);

	snprintf(job->msg, sizeof job->msg, "%s", msg ? msg : "libpng error");
	png_longjmp(p, 1);
}

static void png_warning_cb(png_structp p, png_const_charp msg)
{
	/* engine code never prints; libpng warnings change nothing we write */
	(void)p;
	(void)msg;
}

static png_voidp png_alloc_cb(png_structp p, png_alloc_size_t n)
{
	struct png_job *job = png_get_mem_ptr(p);
	png_voidp r = mem_alloc(n);

	if (!r && job)
		job->oom = 1; /* libpng then reports it in its own words */
	return r;
}

static void png_free_cb(png_structp p, png_voidp ptr)
{
	(void)p;
	mem_free(ptr);
}

/* Write a PNG: IHDR, then either the ready zlib stream idat (gray) or the
 * rows of rgba compressed by libpng, then IEND. */
static int png_write(struct buf *out, int w, int h, int color_type, const struct buf *idat,
		     const uint8_t *rgba, struct err *e)
{
	struct png_job job;
	size_t len0 = out->len;
	png_structp p;
	png_infop info;

	memset(&job, 0, sizeof job);
	job.out = out;
	p = png_create_write_struct_2(PNG_LIBPNG_VER_STRING, &job, png_error_cb, png_warning_cb,
				      &job, png_alloc_cb, png_free_cb);
	if (!p)
		return ERR_SET(e, ERR_NOMEM, "out of memory starting libpng");
	info = png_create_info_struct(p);
	if (!info) {
		png_destroy_write_struct(&p, NULL);
		return ERR_SET(e, ERR_NOMEM, "out of memory starting libpng");
	}
	if (setjmp(png_jmpbuf(p))) {
		png_destroy_write_struct(&p, &info);
		out->len = len0;
		if (job.oom)
			return ERR_SET(e, ERR_NOMEM, "out of memory writing a %d x %d PNG", w, h);
		return ERR_SET(e, ERR_INTERNAL, "libpng: %s", job.msg);
	}
	png_set_write_fn(p, &job, png_write_cb, png_flush_cb);
	png_set_IHDR(p, info, (png_uint_32)w, (png_uint_32)h, 8, color_type, PNG_INTERLACE_NONE,
		     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
	if (idat) {
		png_write_info(p, info);
		png_write_chunk(p, (png_const_bytep) "IDAT", idat->data, idat->len);
		png_write_chunk(p, (png_const_bytep) "IEND", NULL, 0);
	} else {
		/* no row filters: rendered previews are mostly flat colour and
		 * alpha runs, and every reader (and tests/support/sl1check.py's
		 * decoder) takes them fastest */
		png_set_filter(p, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
		png_write_info(p, info);
		for (int y = 0; y < h; y++)
			png_write_row(p, rgba + (size_t)y * (size_t)w * 4);
		png_write_end(p, NULL);
	}
	png_destroy_write_struct(&p, &info);
	return 0;
}

void out_png_scratch_fini(struct out_png_scratch *s)
{
	mem_free(s->tok);
	buf_fini(&s->idat);
	s->tok = NULL;
}

int out_png_gray(const struct raster *r, const struct out_px_rect *content,
		 struct out_png_scratch *scratch, struct buf *png, struct out_png_stats *stats,
		 struct err *e)
{
	struct out_png_scratch own;
	struct out_png_scratch *sc = scratch ? scratch : &own;
	struct out_png_stats st;
	int rc = 0;

	if (!scratch)
		memset(&own, 0, sizeof own);
	if (!sc->tok) {
		sc->tok = mem_alloc(TOK_CAP * sizeof *sc->tok);
		if (!sc->tok)
			rc = ERR_SET(e, ERR_NOMEM, "out of memory encoding a %d x %d PNG", r->w,
				     r->h);
	}
	buf_reset(&sc->idat);
	if (!rc)
		rc = zlib_stream(r, content, sc->tok, &sc->idat, &st, e);
	if (!rc)
		rc = png_write(png, r->w, r->h, PNG_COLOR_TYPE_GRAY, &sc->idat, NULL, e);
	if (!scratch)
		out_png_scratch_fini(&own);
	if (!rc && stats)
		*stats = st;
	return rc;
}

int out_png_rgba(const uint8_t *rgba, int w, int h, struct buf *png, struct err *e)
{
	if (w < 1 || h < 1 || w > 65535 || h > 65535)
		return ERR_SET(e, ERR_INTERNAL, "PNG size %d x %d outside 1..65535", w, h);
	return png_write(png, w, h, PNG_COLOR_TYPE_RGB_ALPHA, NULL, rgba, e);
}
