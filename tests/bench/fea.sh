#!/usr/bin/env bash
# fea.sh BUILD [normal|large] - tests/bench/bench_fea.c: the voxel FEA
# solver (docs/fea.md) on 100^3 = 1M elements, a solid block and a
# thin-walled lattice with rho_min voids, default load case, relative
# residual 1e-6, 2 threads.  Goal: each under 10 s and 1 GB.
# large: 160^3 = 4.1M elements.
set -euo pipefail
BUILD=$1
MODE=${2:-normal}
make --no-print-directory -s "$BUILD/tests/bench/bench_fea" >/dev/null
N=100
[ "$MODE" = large ] && N=160
"$BUILD/tests/bench/bench_fea" "$N" 2 both
