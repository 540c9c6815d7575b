#!/usr/bin/env bash
# service.sh BUILD - service benchmarks (printed figures):
#   submissions/s and status reads/s (wrk over loopback keep-alive),
#   claim latency at 10k and 100k queued jobs (bench_claim.c on libdb),
#   1 GB artifact download throughput with the server's RSS growth.
set -euo pipefail
BUILD=${1:?usage: service.sh BUILD}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
BIN="$ROOT/$BUILD/infilld"
TMP=${BENCH_TMP:-$ROOT/$BUILD/bench}/service
rm -rf "$TMP" && mkdir -p "$TMP"

# -- claim latency (C, straight on the queue) --
gcc -std=c11 -O2 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -I. $(pkg-config --cflags sqlite3) \
	-o "$TMP/bench_claim" tests/bench/bench_claim.c "$BUILD/libdb.a" "$BUILD/libengine.a" \
	$(pkg-config --libs sqlite3 nettle) -lm -lpthread
for n in 10000 100000; do "$TMP/bench_claim" "$TMP/claim.db" "$n"; done

# -- HTTP figures --
python3 tests/bench/service_http.py "$BIN" "$TMP"
