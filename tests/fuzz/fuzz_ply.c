/* fuzz_ply.c - libFuzzer target: the PLY reader (format fixed), then analysis,
 * repair and a BVH query on whatever it accepts.  Run by tests/fuzz/run.sh. */
#include "tests/fuzz/fuzz_mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	return fuzz_mesh_one(data, size, MESH_FMT_PLY);
}
