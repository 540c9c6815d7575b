#!/usr/bin/env bash
# service.sh BUILD - service benchmarks (printed figures):
#   submissions/s and status reads/s (wrk over loopback keep-alive),
#   the queue straight on libdb (bench_queue.c): submissions/s, claim
#   latency and claims/s of 4 claimers at 10k and 100k queued jobs on
#   SQLite, and at 100k on PostgreSQL (started here, pgserver.py),
#   status reads/s through 2 API servers on one PostgreSQL (cluster_http.py),
#   1 GB artifact download throughput with the server's RSS growth.
set -euo pipefail
BUILD=${1:?usage: service.sh BUILD}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
BIN="$ROOT/$BUILD/infilld"
TMP=${BENCH_TMP:-$ROOT/$BUILD/bench}/service
rm -rf "$TMP" && mkdir -p "$TMP"

# -- the queue (C, straight on libdb), both backends --
for n in 10000 100000; do "$BUILD/tests/bench/bench_queue" "sqlite:$TMP/queue.db" "$n"; done
python3 tests/bench/cluster_http.py "$BIN" "$TMP" "$BUILD/tests/bench/bench_queue"

# -- HTTP figures --
python3 tests/bench/service_http.py "$BIN" "$TMP"
