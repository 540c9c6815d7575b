#!/usr/bin/env bash
# gcode.sh BUILD [normal|large] - G-code writer throughput (bench_gcode.c):
# 250-layer 50 mm parts (gear, dome, lattice); large: also 1000 layers.
set -uo pipefail
BUILD=${1:?usage: gcode.sh BUILD [normal|large]}
MODE=${2:-normal}
BIN="$BUILD/tests/bench/bench_gcode"
[ -x "$BIN" ] || { echo "gcode.sh: $BIN not built (make build)" >&2; exit 1; }
"$BIN" 2 250 || exit 1
if [ "$MODE" = large ]; then
	"$BIN" 2 1000 gear || exit 1
fi
