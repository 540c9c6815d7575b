/* sort.c - stable LSD radix sort of 64-bit keys (mesh_int.h).
 *
 * Used where a comparison sort would dominate: welding millions of STL
 * soup vertices sorts 32-bit hashes in at most 4 byte passes.
 */
#include "engine/mesh/mesh_int.h"

#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"

int mesh_sort_u64(uint64_t *a, size_t n, int lo_byte, int hi_byte)
{
	uint64_t *tmp, *src = a, *dst;
	size_t count[256];
	int b;

	if (n < 2)
		return 0;
	tmp = mem_alloc(n * sizeof *tmp);
	if (!tmp)
		return ERR_NOMEM;
	dst = tmp;
	for (b = lo_byte; b <= hi_byte; b++) {
		int shift = 8 * b;
		size_t i, sum = 0;
		memset(count, 0, sizeof count);
		for (i = 0; i < n; i++)
			count[(src[i] >> shift) & 0xff]++;
		if (count[(src[0] >> shift) & 0xff] == n)
			continue; /* every key has this byte: nothing to reorder */
		for (i = 0; i < 256; i++) {
			size_t c = count[i];
			count[i] = sum;
			sum += c;
		}
		for (i = 0; i < n; i++)
			dst[count[(src[i] >> shift) & 0xff]++] = src[i];
		{
			uint64_t *t = src;
			src = dst;
			dst = t;
		}
	}
	if (src != a)
		memcpy(a, src, n * sizeof *a);
	mem_free(tmp);
	return 0;
}
