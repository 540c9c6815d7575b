#!/usr/bin/env bash
# run.sh BUILD [large] - run every benchmark program (BUILD/tests/bench/bench_*),
# printing their figures.  Benchmarks measure; they do not pass or fail.
set -uo pipefail
BUILD=${1:?usage: run.sh BUILD [large]}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
status=0
for b in "$BUILD"/tests/bench/bench_*; do
	[ -x "$b" ] && [ "${b%.o}" = "$b" ] && [ "${b%.d}" = "$b" ] || continue
	echo "== $(basename "$b")"
	"$b" || status=1
done
exit $status
