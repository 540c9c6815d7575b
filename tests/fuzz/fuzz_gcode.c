/* fuzz_gcode.c - libFuzzer target: the G-code layer preview reader
 * (engine/output/gcode/gcode_preview.c) on arbitrary text, drawing layers
 * 0 and 1 of whatever it reads.  Run by tests/fuzz/run.sh. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/output/gcode/gcode_preview.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static char path[64];
	static int fd = -1;
	struct buf png;
	struct err e;
	int n;

	if (fd < 0) {
		snprintf(path, sizeof path, "/tmp/fuzz_gcode_XXXXXX");
		if ((fd = mkstemp(path)) < 0)
			abort();
	}
	if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != (ssize_t)size)
		abort();
	buf_init(&png);
	for (int k = 0; k < 2; k++) {
		err_clear(&e);
		buf_reset(&png);
		if (gcode_preview_layer(path, k, &png, &n, &e) == 0 && png.len < 8)
			abort(); /* success must give a PNG */
	}
	buf_fini(&png);
	return 0;
}
