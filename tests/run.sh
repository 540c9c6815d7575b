#!/usr/bin/env bash
# run.sh BUILD [sanitize] [SUITE...] - run the test suites, each test its own process.
#
# Suites: unit (tests/unit/*/test_* programs; test_*_pg ones need a
# PostgreSQL, so tests/service/test_db_pg.py starts one and runs them), py (tests/*/test_*.py: CLI,
# output-format and service tests that drive the real binary), fuzz (a
# short libFuzzer run per parser).  Default: all.  Tests run in parallel,
# one log each under BUILD/test-logs/; failures print the log's tail.
set -uo pipefail

BUILD=${1:?usage: run.sh BUILD [sanitize] [suite...]}
shift
SANITIZE=0
if [ "${1-}" = sanitize ]; then SANITIZE=1; shift; fi
SUITES=("$@")
[ ${#SUITES[@]} -eq 0 ] && SUITES=(unit py fuzz)

ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
if [ -z "${INFILLD_SHARED-}" ]; then
	for d in ../shared "$ROOT/../shared" /work/shared; do
		[ -d "$d/meshes" ] && { INFILLD_SHARED=$(cd "$d" && pwd); break; }
	done
fi
[ -d "${INFILLD_SHARED-}/meshes" ] || { echo "run.sh: ../shared/meshes not found (set INFILLD_SHARED)" >&2; exit 2; }
export INFILLD_SHARED
export INFILLD_BIN="$ROOT/$BUILD/infilld"
export INFILLD_BUILD="$ROOT/$BUILD"
export INFILLD_SANITIZE=$SANITIZE
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export PYTHONDONTWRITEBYTECODE=1
LOGS="$ROOT/$BUILD/test-logs"
rm -rf "$LOGS" && mkdir -p "$LOGS"
# per program; ASan + UBSan run the hollow engine 3-6x slower (its test
# program took over 900 s under SANITIZE=1 beside another build).  Without
# sanitizers tests/hollow/test_hollow.py took 896 s in a fresh Debian root
# on 2 loaded cores, so 900 s would cut it off: 1500 s.
if [ "$SANITIZE" = 1 ]; then TIMEOUT=${TEST_TIMEOUT:-2700}; else TIMEOUT=${TEST_TIMEOUT:-1500}; fi
JOBS=${TEST_JOBS:-$(nproc 2>/dev/null || echo 2)}

list=()
for s in "${SUITES[@]}"; do
	case $s in
	unit)
		while IFS= read -r f; do list+=("$f"); done < <(
			find "$BUILD/tests/unit" -type f -name 'test_*' -perm -u+x ! -name '*.o' ! -name '*.d' \
				! -name 'test_*_pg' 2>/dev/null | sort) ;;
	py)
		while IFS= read -r f; do list+=("$f"); done < <(
			find tests -path tests/unit -prune -o -type f -name 'test_*.py' -print | sort) ;;
	fuzz)
		[ "$SANITIZE" = 1 ] || list+=("tests/fuzz/run.sh") ;;
	*) echo "run.sh: unknown suite $s" >&2; exit 2 ;;
	esac
done
# Longest first, so the parallel slots finish together (measured in a fresh
# root: test_hollow 896 s, test_hollow_meshes 656 s, test_islands_added
# ~250 s, test_gcode_meshes 97 s; everything else under 70 s).
SLOW_FIRST=(tests/hollow/test_hollow.py tests/hollow/test_hollow_meshes.py
	tests/verify/test_islands_added.py tests/output/test_gcode_meshes.py)
ordered=()
for f in "${SLOW_FIRST[@]}"; do
	for t in "${list[@]}"; do [ "$t" = "$f" ] && ordered+=("$t"); done
done
for t in "${list[@]}"; do
	case " ${SLOW_FIRST[*]} " in *" $t "*) ;; *) ordered+=("$t") ;; esac
done
list=("${ordered[@]}")

run_one() {
	local t=$1 name log start rc
	name=$(echo "$t" | sed 's|^build[^/]*/tests/||; s|^tests/||; s|/|.|g')
	log="$LOGS/$name.log"
	start=$(date +%s.%N)
	case $t in
	*.py) timeout "$TIMEOUT" python3 "$t" >"$log" 2>&1 ;;
	tests/fuzz/run.sh) timeout "$TIMEOUT" "$t" "${FUZZ_SMOKE_SECONDS:-10}" >"$log" 2>&1 ;;
	*) timeout "$TIMEOUT" "$t" >"$log" 2>&1 ;;
	esac
	rc=$?
	printf '%s %-55s %6.1fs\n' "$([ $rc -eq 0 ] && echo PASS || echo "FAIL($rc)")" "$name" \
		"$(awk -v a="$(date +%s.%N)" -v b="$start" 'BEGIN { print a - b }')" |
		tee -a "$LOGS/results.txt"
	[ $rc -eq 0 ] || { echo "---- $log (tail)"; tail -n 40 "$log"; echo "----"; }
	return $rc
}
export -f run_one
export LOGS TIMEOUT

[ ${#list[@]} -gt 0 ] || { echo "run.sh: no tests found" >&2; exit 2; }
start=$(date +%s)
printf '%s\n' "${list[@]}" | xargs -P "$JOBS" -I{} bash -c 'run_one "$@"' _ {} | tee "$LOGS/summary.txt"
fails=$(grep -c '^FAIL(' "$LOGS/results.txt")
total=$(grep -cE '^(PASS|FAIL\()' "$LOGS/results.txt")
[ "$fails" -eq 0 ] || { echo "== failed:"; grep '^FAIL(' "$LOGS/results.txt"; }
echo "== $((total - fails))/$total test programs passed in $(( $(date +%s) - start ))s (logs: $LOGS)"
[ "$fails" -eq 0 ]
