/* fuzz_lattice.c - libFuzzer target: lattice files (binary and text) through
 * lattice_read_buffer(), the same parser `infilld run x.lat` uses. */
#include <stddef.h>
#include <stdint.h>

#include "engine/core/err.h"
#include "engine/lattice/lattice.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct lattice *q = NULL;
	struct err e;

	if (lattice_read_buffer(data, size, &q, &e) == 0) {
		/* a successful read obeys the format's invariants */
		for (size_t i = 0; i < q->nedges; i++)
			if (q->edge[i].a >= q->nnodes || q->edge[i].b >= q->nnodes ||
			    !(q->edge[i].radius_mm > 0))
				__builtin_trap();
		lattice_free(q);
	}
	return 0;
}
