/* predicates.c - input range check for the exact predicates (predicates.h). */
#include "engine/geom/predicates.h"

int geom_pred_range_ok(const struct pt2 *p, size_t n)
{
	int64_t lox = INT64_MAX, loy = INT64_MAX, hix = INT64_MIN, hiy = INT64_MIN;

	for (size_t i = 0; i < n; i++) {
		lox = p[i].x < lox ? p[i].x : lox;
		loy = p[i].y < loy ? p[i].y : loy;
		hix = p[i].x > hix ? p[i].x : hix;
		hiy = p[i].y > hiy ? p[i].y : hiy;
	}
	if (n == 0)
		return 1;
	/* compare in __int128: hix - lox itself may overflow int64 */
	return (__int128)hix - lox <= GEOM_PRED_MAX_RANGE_NM &&
	       (__int128)hiy - loy <= GEOM_PRED_MAX_RANGE_NM;
}
