/* group.c - grouping of loops into genus-0 voids (paper 004, section 7.1).
 *
 * Rules: (1) two loops of one slice never share a group; (2) loops of
 * neighbouring slices may share a group only if their projections overlap
 * by at least `ratio` (50 %) of BOTH areas; (3) a loop overlapping several
 * loops of the neighbouring slice joins the one with the largest overlap.
 * Rule (3) is applied in both directions (a link is kept only when each
 * end is the other's best), so every loop has at most one link up and one
 * down and the groups are chains: the paper's flooding over neighbouring
 * slices reduces to following the links.  Rule (2) with 50 % also keeps
 * consecutive areas within a factor of two, so no strip spans a large
 * overhang.  Overlaps by polygon intersection, only for pairs whose
 * bounding boxes meet: O(sum over slices of pairs).
 */
#include <math.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/hollow/opt/opt_int.h"

static void loop_box(const struct hl_loop *l, double b[4])
{
	b[0] = b[1] = INFINITY;
	b[2] = b[3] = -INFINITY;
	for (size_t i = 0; i < l->n; i++) {
		b[0] = fmin(b[0], l->xy[2 * i]);
		b[1] = fmin(b[1], l->xy[2 * i + 1]);
		b[2] = fmax(b[2], l->xy[2 * i]);
		b[3] = fmax(b[3], l->xy[2 * i + 1]);
	}
}

void hl_links_free(int **up, size_t nslices)
{
	if (!up)
		return;
	for (size_t k = 0; k < nslices; k++)
		mem_free(up[k]);
	mem_free(up);
}

int hl_group_links(const struct hl_slice *sl, size_t nslices, double ratio, int ***out,
		   struct err *e)
{
	int **up = mem_calloc(nslices + 1, sizeof *up);
	double *bu = NULL, *bd = NULL;
	int *iu = NULL, *id = NULL;
	int rc = 0;

	if (!up)
		return ERR_SET(e, ERR_NOMEM, "hollow: out of memory");
	for (size_t k = 0; k < nslices; k++) {
		up[k] = mem_alloc((sl[k].n + 1) * sizeof **up);
		if (!up[k])
			goto nomem;
		for (size_t a = 0; a < sl[k].n; a++)
			up[k][a] = -1;
	}
	for (size_t k = 0; k + 1 < nslices; k++) {
		const struct hl_slice *A = &sl[k], *B = &sl[k + 1];
		mem_free(bu);
		mem_free(bd);
		mem_free(iu);
		mem_free(id);
		bu = mem_calloc(A->n + 1, sizeof *bu);
		iu = mem_alloc((A->n + 1) * sizeof *iu);
		bd = mem_calloc(B->n + 1, sizeof *bd);
		id = mem_alloc((B->n + 1) * sizeof *id);
		if (!bu || !iu || !bd || !id)
			goto nomem;
		for (size_t a = 0; a < A->n; a++)
			iu[a] = -1;
		for (size_t b = 0; b < B->n; b++)
			id[b] = -1;
		for (size_t a = 0; a < A->n; a++) {
			double ba[4];
			loop_box(&A->loop[a], ba);
			for (size_t b = 0; b < B->n; b++) {
				double bb[4], ov;
				loop_box(&B->loop[b], bb);
				if (ba[0] > bb[2] || bb[0] > ba[2] || ba[1] > bb[3] || bb[1] > ba[3])
					continue;
				rc = hl_loop_overlap_mm2(&A->loop[a], &B->loop[b], &ov, e);
				if (rc)
					goto out;
				/* rule 2: enough of both */
				if (ov < ratio * A->loop[a].area_mm2 || ov < ratio * B->loop[b].area_mm2)
					continue;
				/* rule 3: best partner on each side */
				if (ov > bu[a]) {
					bu[a] = ov;
					iu[a] = (int)b;
				}
				if (ov > bd[b]) {
					bd[b] = ov;
					id[b] = (int)a;
				}
			}
		}
		for (size_t a = 0; a < A->n; a++)
			if (iu[a] >= 0 && id[iu[a]] == (int)a)
				up[k][a] = iu[a];
	}
	*out = up;
	up = NULL;
	goto out;
nomem:
	rc = ERR_SET(e, ERR_NOMEM, "hollow: out of memory grouping loops");
out:
	hl_links_free(up, nslices);
	mem_free(bu);
	mem_free(bd);
	mem_free(iu);
	mem_free(id);
	return rc;
}
