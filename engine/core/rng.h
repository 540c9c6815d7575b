/* rng.h - a small seeded pseudo-random generator (SplitMix64).
 *
 * Reentrant (state in caller storage) and reproducible across platforms,
 * so every randomised algorithm (sampling, visiting orders, Monte-Carlo
 * estimates) gives the same result for the same seed.  Not for secrets.
 */
#ifndef INFILLD_RNG_H
#define INFILLD_RNG_H

#include <stdint.h>

struct rng {
	uint64_t s;
};

static inline void rng_seed(struct rng *r, uint64_t seed)
{
	r->s = seed * 0xD1B54A32D192ED03ull + 0x9E3779B97F4A7C15ull;
}

static inline uint64_t rng_next(struct rng *r)
{
	uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);

	z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
	z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
	return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double rng_uniform(struct rng *r)
{
	return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0);
}

/* Uniform integer in [0, n), n >= 1 (Lemire's multiply-shift; the bias is
 * below 2^-32 for n < 2^32). */
static inline uint64_t rng_below(struct rng *r, uint64_t n)
{
	return (uint64_t)(((unsigned __int128)rng_next(r) * n) >> 64);
}

#endif
