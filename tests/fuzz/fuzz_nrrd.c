/* fuzz_nrrd.c - libFuzzer target: NRRD density grids (lattice engine's
 * density_file) through lattice_density_load_buffer(). */
#include <stddef.h>
#include <stdint.h>

#include "engine/core/err.h"
#include "engine/lattice/density.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct lattice_density d;
	struct err e;
	struct box3 b = {{0, 0, 0}, {10, 10, 10}};

	if (lattice_density_load_buffer(&d, b, data, size, &e) == 0) {
		double v = lattice_density_at(&d, v3(5, 5, 5));
		if (!(v >= 0 && v <= 1))
			__builtin_trap();
		lattice_density_fini(&d);
	}
	return 0;
}
