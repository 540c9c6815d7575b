#!/usr/bin/env bash
# hollow.sh BUILD [normal|large] - support-free hollowing (paper 004) on the
# shared meshes at 50 mm, alpha 45, walls 1.0 / 0.8 mm, SL1 output checked by
# the layer verifier: volume reduction, interior overhang (must be 0), voids,
# rounds, time, peak RSS.  Paper's Table 1: 53-77 % reduction, 17-60 min.
# large: also alpha 30 and the standing objective on the letter P.
set -uo pipefail
BUILD=${1:?usage: hollow.sh BUILD [normal|large]}
MODE=${2:-normal}
BIN=${INFILLD_BIN:-$BUILD/infilld}
SHARED=${INFILLD_SHARED:-../shared}
TMP=${BENCH_TMP:-$BUILD/bench}/hollow
mkdir -p "$TMP"
[ -x "$BIN" ] || { echo "hollow.sh: $BIN not built (make build)" >&2; exit 1; }

run_one() { # name up alpha objective
	local name=$1 up=$2 alpha=$3 obj=$4 out="$TMP/$1_a$3_$4"
	/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$SHARED/meshes/$name.off" \
		-o "$out.sl1" --engine hollow --set height_mm=50 --set up="$up" \
		--set alpha_deg="$alpha" --set objective="$obj" --threads 2 --quiet \
		--metrics "$out.json" || { echo "$name: run failed"; return 1; }
	python3 - "$out.json" "$out.time" "$name" "$alpha" "$obj" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); h = m["hollow"]
wall, rss = open(sys.argv[2]).read().split()
extra = ""
if "com_before_mm" in h:
    extra = " com %+.2f -> %+.2f mm inside_hull %s" % (h["com_before_mm"], h["com_after_mm"], h["com_inside_hull"])
print("%-10s a=%-2s %-11s reduction %5.1f %%  interior overhang %.3f mm2  voids %3d  rounds %d"
      "  min wall %.2f mm  iters %5d  time %6.1f s (optimise %5.1f)  rss %4d MB%s%s"
      % (sys.argv[3], sys.argv[4], sys.argv[5], 100 * h["volume_reduction"],
         h["interior_overhang_mm2"], h["voids"], h["rounds"], h["min_wall_mm"],
         h["solver_iterations"], float(wall), h["seconds"]["optimise"], int(rss) // 1024,
         extra, ("  note: " + h["note"]) if "note" in h else ""))
PY
}

status=0
for m in "camel y" "cow z" "elephant z" "armadillo y" "femur z"; do
	set -- $m
	run_one "$1" "$2" 45 lightweight || status=1
done
if [ "$MODE" = large ]; then
	for m in "camel y" "armadillo y"; do
		set -- $m
		run_one "$1" "$2" 30 lightweight || status=1
	done
	run_one P y 45 stability || status=1
fi
exit $status
