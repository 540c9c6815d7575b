/* void.c - one void: a chain of loops, their shifting directions and
 * bounds, and the strips that join them (paper 004, sections 3 and 6).
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/opt_int.h"

void hl_loop_fini(struct hl_loop *l)
{
	mem_free(l->xy);
	memset(l, 0, sizeof *l);
}

void hl_loop_move(struct hl_loop *dst, struct hl_loop *src)
{
	*dst = *src;
	memset(src, 0, sizeof *src);
}

void hl_void_init(struct hl_void *v)
{
	memset(v, 0, sizeof *v);
}

void hl_void_fini(struct hl_void *v)
{
	mem_free(v->slice);
	mem_free(v->z);
	mem_free(v->off);
	mem_free(v->p);
	mem_free(v->vz);
	mem_free(v->dir);
	mem_free(v->ub);
	mem_free(v->tri);
	mem_free(v->xe);
	mem_free(v->l);
	mem_free(v->start);
	memset(v, 0, sizeof *v);
}

int hl_void_build(const struct hl_loop *const *loops, size_t n, const struct hl_block *block,
		  struct hl_void *out, size_t *used, struct err *e)
{
	struct hl_void v;
	size_t nv = 0, k, tcap = 0, xcap = 0;
	int rc = 0;

	hl_void_init(&v);
	*used = 0;
	if (n < 2)
		return 1;
	for (k = 0; k < n; k++)
		nv += loops[k]->n;
	v.slice = mem_alloc(n * sizeof *v.slice);
	v.z = mem_alloc(n * sizeof *v.z);
	v.off = mem_alloc((n + 1) * sizeof *v.off);
	v.p = mem_alloc(2 * nv * sizeof *v.p);
	v.vz = mem_alloc(nv * sizeof *v.vz);
	v.dir = mem_alloc(2 * nv * sizeof *v.dir);
	v.ub = mem_alloc(nv * sizeof *v.ub);
	if (!v.slice || !v.z || !v.off || !v.p || !v.vz || !v.dir || !v.ub)
		goto nomem;
	v.off[0] = 0;
	for (k = 0; k < n; k++) {
		const struct hl_loop *L = loops[k];
		size_t o = v.off[k];
		v.slice[k] = L->slice;
		v.z[k] = L->z_mm;
		v.off[k + 1] = o + L->n;
		memcpy(v.p + 2 * o, L->xy, 2 * L->n * sizeof *v.p);
		for (size_t j = 0; j < L->n; j++)
			v.vz[o + j] = L->z_mm;
		rc = hl_poles(L->xy, L->n, v.dir + 2 * o, v.ub + o, e);
		if (rc)
			goto out;
	}
	/* strips bottom-up; stop at the first pair with no admissible strip */
	for (k = 0; k + 1 < n; k++) {
		const struct hl_loop *A = loops[k], *B = loops[k + 1];
		rc = hl_strip(A->xy, A->z_mm, A->n, (uint32_t)v.off[k], B->xy, B->z_mm, B->n,
			      (uint32_t)v.off[k + 1], block, &v.tri, &v.nt, &tcap, &v.xe, &v.nxe,
			      &xcap, e);
		if (rc < 0)
			goto out;
		if (rc == 1)
			break;
	}
	rc = 0;
	v.nloops = k + 1;
	*used = v.nloops;
	if (v.nloops < 2) {
		rc = 1; /* nothing usable: the caller drops loops[0] */
		goto out;
	}
	v.nv = v.off[v.nloops];
	/* eq. 10 on every loop but the top one, whose vertices must be able
	 * to reach their poles so the ceiling can collapse (eq. 6) */
	{
		double *tmp = mem_alloc((v.nv + 1) * sizeof *tmp);
		if (!tmp)
			goto nomem;
		for (k = 0; k + 1 < v.nloops; k++)
			hl_bounds_smooth(v.ub + v.off[k], v.off[k + 1] - v.off[k], tmp);
		mem_free(tmp);
	}
	hl_void_fini(out);
	*out = v;
	return 0;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory building a void of %zu loops", n);
out:
	hl_void_fini(&v);
	return rc;
}
