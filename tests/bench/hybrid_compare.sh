#!/usr/bin/env bash
# hybrid_compare.sh BUILD [normal|large] - paper 003's Fig. 12 with our own
# engines: the weight of hollow, lattice and rhombic interiors at the hybrid's
# stiffness on the cow (tests/bench/hybrid_compare.py says how).  About 10
# minutes on 2 cores (hollow's runs take 2 min each).
set -uo pipefail
BUILD=${1:?usage: hybrid_compare.sh BUILD [normal|large]}
MODE=${2:-normal}
SHARED=${INFILLD_SHARED:-../shared}
TMP=${BENCH_TMP:-$BUILD/bench}/hybrid_compare
[ -x "${INFILLD_BIN:-$BUILD/infilld}" ] || { echo "hybrid_compare.sh: not built (make build)" >&2; exit 1; }
exec python3 "$(dirname "$0")/hybrid_compare.py" "$BUILD" "$TMP" "$SHARED" "$MODE"
