#!/usr/bin/env bash
# run.sh SECONDS - run every built fuzz target (build-fuzz/fuzz_*) for SECONDS
# each, on a scratch copy of its seed corpus (tests/fuzz/corpus/<target>/).
# Fails on any crash, leak, timeout or sanitizer report; the reproducer is
# left in build-fuzz/findings/<target>/ (keep it as a regression case in
# tests/data/mesh/).
set -uo pipefail
SECONDS_EACH=${1:-10}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
cd "$ROOT"
shopt -s nullglob
targets=(build-fuzz/fuzz_*)
[ ${#targets[@]} -gt 0 ] || { echo "run.sh: no fuzz targets in build-fuzz/ (make fuzz-build)" >&2; exit 2; }
fail=0
for t in "${targets[@]}"; do
	[ -x "$t" ] || continue
	name=$(basename "$t")
	seeds="tests/fuzz/corpus/${name#fuzz_}"
	work="build-fuzz/corpus/$name"
	findings="build-fuzz/findings/$name"
	mkdir -p "$work" "$findings"
	[ -d "$seeds" ] && cp -n "$seeds"/* "$work"/ 2>/dev/null
	# -max_len: big enough for multi-facet files, small enough to keep
	# iterations fast; -rss_limit_mb / -timeout turn blow-ups and hangs
	# into findings.
	if "$t" "$work" -max_total_time="$SECONDS_EACH" -max_len=8192 -timeout=10 \
		-rss_limit_mb=2048 -artifact_prefix="$findings/" -print_final_stats=1 \
		>"build-fuzz/$name.log" 2>&1; then
		echo "PASS $name ($(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "build-fuzz/$name.log" | grep -o '[0-9]*$') runs)"
	else
		echo "FAIL $name: see build-fuzz/$name.log and $findings/"
		tail -n 30 "build-fuzz/$name.log"
		fail=1
	fi
done
exit $fail
