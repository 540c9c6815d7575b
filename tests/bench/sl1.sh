#!/usr/bin/env bash
# sl1.sh BUILD [MODE] - SL1 writer throughput (tests/bench/bench_sl1.c):
# 1000 frames of a 50 mm disk at 1440 x 2560, 1 and 2 encoder threads,
# and the layer PNG encoder against libpng/zlib.  Figures only.
set -euo pipefail
BUILD=${1:?usage: sl1.sh BUILD [normal|large]}
MODE=${2:-normal}
FRAMES=1000
[ "$MODE" = large ] && FRAMES=5000
"$BUILD/tests/bench/bench_sl1" "$FRAMES" "${BENCH_TMP:-/tmp}"
