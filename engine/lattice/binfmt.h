/* binfmt.h - byte layout of the binary lattice format (internal to lattice/).
 *
 * Little-endian throughout; specification in docs/lattice.md section 5.1.
 * Header (128 bytes), then nnodes node records (3 x float32, z
 * non-decreasing), then nedges edge records (uint32 a, uint32 b, uint16
 * radius in units of the header's quantum; a < b, a non-decreasing).
 */
#ifndef INFILLD_LATTICE_BINFMT_H
#define INFILLD_LATTICE_BINFMT_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "engine/lattice/lattice.h"

#define LATBIN_MAGIC "INFILLDL"
#define LATBIN_VERSION 1u
#define LATBIN_HEADER_BYTES 128u
#define LATBIN_NODE_BYTES 12u
#define LATBIN_EDGE_BYTES 10u
#define LATBIN_QMAX 65535u

#define LATTEXT_MAGIC "infilld-lattice"

static inline void latbin_put_u16(unsigned char *p, uint16_t v)
{
	p[0] = (unsigned char)v;
	p[1] = (unsigned char)(v >> 8);
}
static inline void latbin_put_u32(unsigned char *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (unsigned char)(v >> (8 * i));
}
static inline void latbin_put_u64(unsigned char *p, uint64_t v)
{
	for (int i = 0; i < 8; i++)
		p[i] = (unsigned char)(v >> (8 * i));
}
static inline void latbin_put_f32(unsigned char *p, float f)
{
	uint32_t v;
	memcpy(&v, &f, 4);
	latbin_put_u32(p, v);
}
static inline void latbin_put_f64(unsigned char *p, double f)
{
	uint64_t v;
	memcpy(&v, &f, 8);
	latbin_put_u64(p, v);
}
static inline uint16_t latbin_get_u16(const unsigned char *p)
{
	return (uint16_t)(p[0] | (p[1] << 8));
}
static inline uint32_t latbin_get_u32(const unsigned char *p)
{
	return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
	       ((uint32_t)p[3] << 24);
}
static inline uint64_t latbin_get_u64(const unsigned char *p)
{
	return (uint64_t)latbin_get_u32(p) | ((uint64_t)latbin_get_u32(p + 4) << 32);
}
static inline float latbin_get_f32(const unsigned char *p)
{
	uint32_t v = latbin_get_u32(p);
	float f;
	memcpy(&f, &v, 4);
	return f;
}
static inline double latbin_get_f64(const unsigned char *p)
{
	uint64_t v = latbin_get_u64(p);
	double f;
	memcpy(&f, &v, 8);
	return f;
}

/* Encode / decode the 128-byte header.  decode validates the magic,
 * version, sizes and values (finite, positive where required) and the
 * total size against file_size; 0 or ERR_PARSE with e filled. */
void latbin_header_encode(unsigned char *buf, const struct lattice_file_header *h);
int latbin_header_decode(const unsigned char *buf, uint64_t file_size,
			 struct lattice_file_header *h, struct err *e);

/* Decode radius code q: 0 and *r set when the radius is a finite float
 * > 0, within the header's largest radius and below its support (if
 * set); -1 otherwise. */
static inline int latbin_radius(const struct lattice_file_header *h, uint16_t q, float *r)
{
	float v = (float)(q * h->radius_quantum_mm);

	if (!(v > 0) || !(v <= h->max_radius_mm + h->radius_quantum_mm) ||
	    (h->support_mm > 0 && !(v < h->support_mm)))
		return -1;
	*r = v;
	return 0;
}

/* Quantise a radius (mm) for the header's quantum: 1..65535. */
uint16_t latbin_quantise(double radius_mm, double quantum_mm);

/* Buffered sequential reader over a file descriptor using pread (several
 * may share one descriptor), or over memory (fd < 0). */
struct latbin_cursor {
	int fd;
	uint64_t off;      /* file offset of buf[0] */
	unsigned char *buf; /* owned (file mode) */
	size_t len, pos, cap;
	const unsigned char *mem; /* memory mode: the whole file */
	uint64_t mem_len;
};
int latbin_cursor_init(struct latbin_cursor *c, int fd, uint64_t off, size_t cap);
void latbin_cursor_init_mem(struct latbin_cursor *c, const void *data, uint64_t len,
			    uint64_t off);
void latbin_cursor_fini(struct latbin_cursor *c);
/* Pointer to the next n bytes (n <= cap), advancing; NULL at EOF/error
 * (then e says which). */
const unsigned char *latbin_cursor_take(struct latbin_cursor *c, size_t n, struct err *e);
/* File offset of the next byte to be taken. */
static inline uint64_t latbin_cursor_tell(const struct latbin_cursor *c)
{
	return c->off + c->pos;
}

/* Read a whole binary lattice of `size` bytes from fd (or from memory)
 * into memory (lattice_read() dispatches here after probing). */
int latbin_read_fd(int fd, uint64_t size, struct lattice **out, struct err *e);
int latbin_read_mem(const void *data, uint64_t size, struct lattice **out, struct err *e);

#endif
