/* rowkern.c - per-row strut accumulation kernels (rowkern.h): portable C and
 * an AVX2+FMA variant picked at run time on x86-64.  Formula: kernel.c. */
#include "engine/lattice/rowkern.h"

#include <math.h>

#define CLAMP_MAX 1073741824.0f /* 2^30: one strut adds at most this */

static inline float prim_g(float c, float y)
{
	float y2 = y * y;
	return y * (c * c - (2.0f / 3.0f) * c * y2 + 0.2f * y2 * y2);
}

static inline uint32_t sat_add(uint32_t a, uint32_t b)
{
	uint32_t s = a + b;
	return s < a ? UINT32_MAX : s;
}

void lattice_rowkern_scalar(const struct rowkern_args *a, uint32_t *acc, int n)
{
	for (int i = 0; i < n; i++) {
		float u = (float)i, c = a->c0 + u * (a->c1 + u * a->c2), h, sc, y0, y1, x;

		if (!(c > 0))
			continue;
		h = a->h0 + u * a->hs;
		sc = sqrtf(c);
		y0 = fmaxf(-h, -sc);
		y1 = fminf(a->l - h, sc);
		if (!(y1 > y0))
			continue;
		x = a->k * (prim_g(c, y1) - prim_g(c, y0));
		if (!(x > 0))
			continue;
		acc[i] = sat_add(acc[i], (uint32_t)fminf(x, CLAMP_MAX));
	}
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

__attribute__((target("avx2,fma"))) static inline __m256 g_avx(__m256 c, __m256 y)
{
	__m256 y2 = _mm256_mul_ps(y, y);
	/* c^2 - (2/3) c y^2 + y^4 / 5 */
	__m256 t = _mm256_fmadd_ps(_mm256_set1_ps(0.2f), _mm256_mul_ps(y2, y2),
				   _mm256_mul_ps(c, c));
	t = _mm256_fnmadd_ps(_mm256_mul_ps(_mm256_set1_ps(2.0f / 3.0f), c), y2, t);
	return _mm256_mul_ps(y, t);
}

__attribute__((target("avx2,fma"))) static void rowkern_avx2(const struct rowkern_args *a,
							     uint32_t *acc, int n)
{
	const __m256 c0 = _mm256_set1_ps(a->c0), c1 = _mm256_set1_ps(a->c1);
	const __m256 c2 = _mm256_set1_ps(a->c2), h0 = _mm256_set1_ps(a->h0);
	const __m256 hs = _mm256_set1_ps(a->hs), l = _mm256_set1_ps(a->l);
	const __m256 k = _mm256_set1_ps(a->k), zero = _mm256_setzero_ps();
	const __m256 cmax = _mm256_set1_ps(CLAMP_MAX);
	const __m256i ones = _mm256_set1_epi32(-1);
	const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
	__m256 u = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
	const __m256 eight = _mm256_set1_ps(8.0f);

	for (int i = 0; i < n; i += 8) {
		__m256 c = _mm256_fmadd_ps(u, _mm256_fmadd_ps(u, c2, c1), c0);
		__m256 h = _mm256_fmadd_ps(u, hs, h0);
		__m256 sc = _mm256_sqrt_ps(_mm256_max_ps(c, zero));
		__m256 y0 = _mm256_max_ps(_mm256_sub_ps(zero, h), _mm256_sub_ps(zero, sc));
		__m256 y1 = _mm256_min_ps(_mm256_sub_ps(l, h), sc);
		__m256 x = _mm256_mul_ps(k, _mm256_sub_ps(g_avx(c, y1), g_avx(c, y0)));
		__m256 ok = _mm256_and_ps(_mm256_cmp_ps(y1, y0, _CMP_GT_OQ),
					  _mm256_cmp_ps(c, zero, _CMP_GT_OQ));
		__m256i add, cur, s, nov;

		x = _mm256_and_ps(ok, _mm256_min_ps(_mm256_max_ps(x, zero), cmax));
		add = _mm256_cvttps_epi32(x);
		if (n - i >= 8) {
			cur = _mm256_loadu_si256((const __m256i *)(acc + i));
			s = _mm256_add_epi32(cur, add);
			nov = _mm256_cmpeq_epi32(_mm256_max_epu32(cur, s), s);
			s = _mm256_or_si256(s, _mm256_andnot_si256(nov, ones));
			_mm256_storeu_si256((__m256i *)(acc + i), s);
		} else {
			__m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
			cur = _mm256_maskload_epi32((const int *)(acc + i), m);
			s = _mm256_add_epi32(cur, add);
			nov = _mm256_cmpeq_epi32(_mm256_max_epu32(cur, s), s);
			s = _mm256_or_si256(s, _mm256_andnot_si256(nov, ones));
			_mm256_maskstore_epi32((int *)(acc + i), m, s);
		}
		u = _mm256_add_ps(u, eight);
	}
}

rowkern_fn lattice_rowkern_pick(void)
{
	__builtin_cpu_init();
	if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
		return rowkern_avx2;
	return lattice_rowkern_scalar;
}
#else
rowkern_fn lattice_rowkern_pick(void)
{
	return lattice_rowkern_scalar;
}
#endif
