/* vec.c - the CG's level-0 vector operations over the active rows only.
 *
 * Level-0 vectors span the padded box, but only nodes with a free axis
 * (not absent, not held) ever hold a nonzero entry: every writer leaves
 * the others 0 (fea_int.h).  On a bulky part most of the box is outside
 * it (the bunny at 50 mm: 24 % of a 128 x 128 x 96 box present), so the
 * CG's dot products and updates walk one span per grid row, from the
 * row's first active node to its last, instead of the whole box.  Spans
 * are grouped into chunks of about FEA_SPAN_CHUNK nodes fixed by the
 * geometry alone, and sums are added chunk by chunk in order, so results
 * do not depend on the thread count.  docs/fea.md, "Solver".
 */
#include "engine/fea/fea_int.h"

#include "engine/core/err.h"
#include "engine/core/mem.h"

#define FEA_SPAN_CHUNK 1024

void fea_spans_fini(struct fea_solver *s)
{
	mem_free(s->span);
	mem_free(s->span_chunk);
	mem_free(s->span_part);
	mem_free(s->row_span);
	s->row_span = NULL;
	s->span = NULL;
	s->span_chunk = NULL;
	s->span_part = NULL;
	s->nspan = s->nchunk = 0;
}

int fea_spans_build(struct fea_solver *s, struct err *e)
{
	const struct fea_level *l = &s->lv[0];
	size_t rows = (size_t)(l->ny + 1) * (size_t)(l->nz + 1), acc = 0;

	fea_spans_fini(s);
	s->span = mem_alloc(rows * sizeof *s->span);
	s->span_chunk = mem_alloc((rows + 1) * sizeof *s->span_chunk);
	s->span_part = mem_alloc(2 * (rows + 1) * sizeof *s->span_part);
	s->row_span = mem_alloc(2 * rows * sizeof *s->row_span);
	if (!s->span || !s->span_chunk || !s->span_part || !s->row_span) {
		fea_spans_fini(s);
		return ERR_SET(e, ERR_NOMEM, "out of memory for the fea solver's row spans");
	}
	for (int k = 0; k <= l->nz; k++)
		for (int j = 0; j <= l->ny; j++) {
			ptrdiff_t row = fea_nl(l, 0, j, k);
			int lo = -1, hi = -1;
			for (int i = 0; i <= l->nx; i++)
				if ((s->mask0[row + i] & FEA_NODE_ALL) != FEA_NODE_ALL) {
					if (lo < 0)
						lo = i;
					hi = i;
				}
			int *rs = s->row_span + 2 * ((size_t)k * (size_t)(l->ny + 1) + (size_t)j);
			rs[0] = lo < 0 ? 0 : lo;
			rs[1] = hi;
			if (lo < 0)
				continue;
			if (acc == 0)
				s->span_chunk[s->nchunk++] = s->nspan;
			s->span[s->nspan].n = row + lo;
			s->span[s->nspan].len = hi - lo + 1;
			acc += (size_t)(hi - lo + 1);
			s->nspan++;
			if (acc >= FEA_SPAN_CHUNK)
				acc = 0;
		}
	s->span_chunk[s->nchunk] = s->nspan;
	return 0;
}

enum vec_op { VEC_DOT_RR, VEC_SUB_Q, VEC_DOT_DF, VEC_UPDATE, VEC_PUPDATE, VEC_COPY_F, VEC_FIRST };

struct vec_ctx {
	struct fea_solver *s;
	enum vec_op op;
	double alpha;
	const double *in; /* VEC_FIRST: the residual */
};

/* One chunk of the operation, all three axes. */
static void vec_chunk(void *vctx, size_t ch, int tid)
{
	const struct vec_ctx *c = vctx;
	struct fea_solver *s = c->s;
	const ptrdiff_t cs = s->cs;
	const double a = c->alpha;
	double s0 = 0, s1 = 0;

	(void)tid;
	for (size_t sp = s->span_chunk[ch]; sp < s->span_chunk[ch + 1]; sp++)
		for (int q = 0; q < 3; q++) {
			const ptrdiff_t lo = q * cs + s->span[sp].n, hi = lo + s->span[sp].len;
			double *u = s->u, *r = s->r, *p = s->p;
			const double *qv = s->q;
			const float *z = s->x0;
			switch (c->op) {
			case VEC_DOT_RR:
				for (ptrdiff_t i = lo; i < hi; i++)
					s0 += r[i] * r[i];
				break;
			case VEC_SUB_Q:
				for (ptrdiff_t i = lo; i < hi; i++) {
					r[i] -= qv[i];
					s0 += r[i] * r[i];
				}
				break;
			case VEC_DOT_DF:
				for (ptrdiff_t i = lo; i < hi; i++)
					s0 += r[i] * (double)z[i];
				break;
			case VEC_UPDATE:
				for (ptrdiff_t i = lo; i < hi; i++) {
					double ri = r[i] - a * qv[i];
					u[i] += a * p[i];
					r[i] = ri;
					s0 += ri * ri;
					s1 += ri * (double)z[i];
				}
				break;
			case VEC_PUPDATE:
				for (ptrdiff_t i = lo; i < hi; i++)
					p[i] = (double)z[i] + a * p[i];
				break;
			case VEC_COPY_F:
				for (ptrdiff_t i = lo; i < hi; i++)
					p[i] = (double)z[i];
				break;
			case VEC_FIRST:
				for (ptrdiff_t i = lo; i < hi; i++) {
					float bf = (float)c->in[i];
					s->b0[i] = bf;
					s->x0[i] = s->invd0[i] * bf;
				}
				break;
			}
		}
	s->span_part[2 * ch] = s0;
	s->span_part[2 * ch + 1] = s1;
}

static void vec_run(struct fea_solver *s, enum vec_op op, double alpha, const double *in,
		    double *sum0, double *sum1)
{
	struct vec_ctx c = {s, op, alpha, in};
	double a0 = 0, a1 = 0;

	fea_par(s, s->nchunk, 1, vec_chunk, &c);
	for (size_t ch = 0; ch < s->nchunk; ch++) {
		a0 += s->span_part[2 * ch];
		a1 += s->span_part[2 * ch + 1];
	}
	if (sum0)
		*sum0 = a0;
	if (sum1)
		*sum1 = a1;
}

double fea_vec_rr(struct fea_solver *s)
{
	double d;

	vec_run(s, VEC_DOT_RR, 0, NULL, &d, NULL);
	return d;
}

double fea_vec_sub_q(struct fea_solver *s)
{
	double d;

	vec_run(s, VEC_SUB_Q, 0, NULL, &d, NULL);
	return d;
}

double fea_vec_rz(struct fea_solver *s)
{
	double d;

	vec_run(s, VEC_DOT_DF, 0, NULL, &d, NULL);
	return d;
}

void fea_vec_update(struct fea_solver *s, double alpha, double *rr, double *rz)
{
	vec_run(s, VEC_UPDATE, alpha, NULL, rr, rz);
}

void fea_vec_p(struct fea_solver *s, double beta)
{
	vec_run(s, VEC_PUPDATE, beta, NULL, NULL, NULL);
}

void fea_vec_p_copy(struct fea_solver *s)
{
	vec_run(s, VEC_COPY_F, 0, NULL, NULL, NULL);
}

void fea_first_sweep0(struct fea_solver *s, const double *r)
{
	vec_run(s, VEC_FIRST, 0, r, NULL, NULL);
}
