#!/usr/bin/env bash
# run.sh BUILD [large] - every benchmark script tests/bench/*.sh (but this
# one), each printing its own figures.  `make bench` / `make bench-large`.
set -uo pipefail
BUILD=${1:?usage: run.sh BUILD [large]}
MODE=${2:-normal}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
if [ -z "${INFILLD_SHARED-}" ]; then
	for d in ../shared "$ROOT/../shared" /work/shared; do
		[ -d "$d/meshes" ] && { INFILLD_SHARED=$(cd "$d" && pwd); break; }
	done
fi
export INFILLD_SHARED INFILLD_BIN="$ROOT/$BUILD/infilld" INFILLD_BUILD="$ROOT/$BUILD"
export BENCH_TMP=${BENCH_TMP:-$ROOT/$BUILD/bench}
mkdir -p "$BENCH_TMP"
# GNU time measures peak RSS of whole commands.
command -v /usr/bin/time >/dev/null || { export DEBIAN_FRONTEND=noninteractive; apt-get install -y -qq time >/dev/null; }
status=0
for s in tests/bench/*.sh; do
	[ "$(basename "$s")" = run.sh ] && continue
	echo "==== $(basename "$s" .sh) ($MODE)"
	bash "$s" "$BUILD" "$MODE" || { echo "!!!! $s failed"; status=1; }
done
exit $status
