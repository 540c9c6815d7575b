#!/usr/bin/env bash
# bench_mesh.sh BUILD [mode] - build and run tests/bench/bench_mesh.c (mesh
# input: read + weld + analyze of a generated 1M-triangle binary STL,
# armadillo.off and bunny.stl; repair; BVH build and query rates).
set -euo pipefail
BUILD=$1
make --no-print-directory -s "$BUILD/tests/bench/bench_mesh" >/dev/null
"$BUILD/tests/bench/bench_mesh" "$INFILLD_SHARED"
