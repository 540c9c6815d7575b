#!/usr/bin/env bash
# hybrid.sh BUILD [normal|large] - the hybrid engine (paper 003: muscle
# fibres in the verified columns, the diamond crystal elsewhere) against one
# structure everywhere at the same weight, on the cow and the elephant at
# 60 mm (up=y):
# 1. the hybrid at its defaults: weight fraction W_h (material / solid), time,
#    peak RSS, per-stage seconds, the components (class, area, axis);
# 2. structure=tcs tuned to W_h within TOL_PCT (2 %) by bisection on
#    tcs_stick_mm (tcs_cell_mm at its default; the stick stays below
#    sqrt(3)/4 cell, a stick's length), structure=mfs by bisection on wall_mm
#    (below mfs_cell_mm), or on mfs_cell_mm where no wall reaches W_h; at most
#    MAX_STEPS (6) runs each, compliance=false, the first at the default;
# 3. the three final designs (the tuned ones rerun with compliance on):
#    compliance by `infilld fea ARCHIVE` (1 mm elements, the default load:
#    plate fixed, 1000 N down on the top 1 mm) and by the engine's own
#    measure; C x W (lower = stiffer for the weight) and which wins.
# normal: 0.1 mm layers (about 10 runs of 1-1.5 min a mesh on 2 cores);
# large: the default 0.05 mm.  HYBRID_MESHES="cow elephant" picks meshes.
set -uo pipefail
BUILD=${1:?usage: hybrid.sh BUILD [normal|large]}
MODE=${2:-normal}
BIN=${INFILLD_BIN:-$BUILD/infilld}
SHARED=${INFILLD_SHARED:-../shared}
TMP=${BENCH_TMP:-$BUILD/bench}/hybrid
mkdir -p "$TMP"
[ -x "$BIN" ] || { echo "hybrid.sh: $BIN not built (make build)" >&2; exit 1; }

MESHES=${HYBRID_MESHES:-cow elephant}
TOL_PCT=${TOL_PCT:-2}
MAX_STEPS=${MAX_STEPS:-6}
COMMON=(--engine hybrid --set height_mm=60 --set up=y --threads 2 --quiet)
LAYERS="0.05 mm (default)"
[ "$MODE" = large ] || { COMMON+=(--set layer_mm=0.1); LAYERS="0.1 mm"; }
FEA=(--set fea_voxel_mm=1 --threads 2 --quiet)

# The engine's defaults, from `infilld engines`.
def() {
	"$BIN" engines | python3 -c "
import json, sys
d = json.load(sys.stdin); es = d if isinstance(d, list) else d.get('engines', d)
print(next(p for e in es if e['name'] == 'hybrid' for p in e['params'] if p['name'] == sys.argv[1])['default'])" "$1"
}
TCS_CELL=$(def tcs_cell_mm) TCS_STICK=$(def tcs_stick_mm)
MFS_CELL=$(def mfs_cell_mm) MFS_WALL=$(def wall_mm)

jget() { # file key.path -> value
	python3 -c "
import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2].split('.'):
    v = v[k]
print(repr(v) if isinstance(v, float) else v)" "$1" "$2"
}

design() { # out mesh [--set ...]: one run, $out.{sl1,json,time,err}
	local out=$1 mesh=$2
	shift 2
	/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$mesh" -o "$out.sl1" "${COMMON[@]}" "$@" \
		--metrics "$out.json" 2>"$out.err"
}

# tune NAME MESH STRUCTURE PARAM START LO HI DIR TARGET [--set ...]: bisection
# of PARAM in (LO, HI) for weight_fraction = TARGET; DIR "+" when the weight
# grows with PARAM, "-" when it falls.  The first probe is START.  Prints each
# step; sets TUNED (the value closest to TARGET, empty if none ran), TUNED_W
# and TUNED_OK (1 within TOL_PCT), REACHED (0 when every probe fell on one
# side of TARGET: the range may not hold it).
tune() {
	local name=$1 mesh=$2 st=$3 par=$4 x=$5 lo=$6 hi=$7 dir=$8 target=$9 start=$5
	shift 9
	local step out w below=0 above=0 best_err=
	TUNED= TUNED_W= TUNED_OK=0 REACHED=0
	for ((step = 1; step <= MAX_STEPS; step++)); do
		out="$TMP/${name}_${st}_${par}_s$step"
		if design "$out" "$mesh" --set structure="$st" --set compliance=false "$@" \
			--set "$par=$x"; then
			w=$(jget "$out.json" hybrid.weight_fraction)
			read -r err side <<<"$(python3 -c "
import sys
w, t = float(sys.argv[1]), float(sys.argv[2])
print(f'{abs(w / t - 1) * 100:.3f}', 'below' if w < t else 'above')" "$w" "$target")"
			[ "$side" = below ] && below=1 || above=1
			printf '  %s %s step %d: %s=%.4f -> weight %.4f (target %.4f, off %.2f %%), %s s\n' \
				"$name" "$st" "$step" "$par" "$x" "$w" "$target" "$err" "$(cut -d' ' -f1 "$out.time")"
			if [ -z "$best_err" ] || python3 -c "import sys; sys.exit(float(sys.argv[1]) >= float(sys.argv[2]))" "$err" "$best_err"; then
				best_err=$err TUNED=$x TUNED_W=$w
			fi
			python3 -c "import sys; sys.exit(float(sys.argv[1]) > float(sys.argv[2]))" "$err" "$TOL_PCT" &&
				{ TUNED_OK=1; break; }
			# the new bound: below the target, a "+" parameter must grow
			if [ "$side$dir" = "below+" ] || [ "$side$dir" = "above-" ]; then lo=$x; else hi=$x; fi
		else
			printf '  %s %s step %d: %s=%.4f failed: %s\n' "$name" "$st" "$step" "$par" "$x" \
				"$(tail -n 1 "$out.err")"
			# a failed value bounds the search on its side of the first probe
			if python3 -c "import sys; sys.exit(float(sys.argv[1]) >= float(sys.argv[2]))" "$x" "$start"; then
				lo=$x
			else
				hi=$x
			fi
		fi
		x=$(python3 -c "import sys; print(f'{(float(sys.argv[1]) + float(sys.argv[2])) / 2:.4f}')" "$lo" "$hi")
	done
	[ $((below + above)) = 2 ] && REACHED=1
	[ "$TUNED_OK" = 1 ] || [ -z "$TUNED" ] ||
		echo "  $name $st: not within $TOL_PCT % after $MAX_STEPS steps; closest $par=$TUNED (weight $TUNED_W)"
}

status=0
for name in $MESHES; do
	mesh="$SHARED/meshes/$name.off"
	echo "== $name 60 mm up=y, $LAYERS layers"
	# 1. the hybrid at its defaults
	h="$TMP/${name}_hybrid"
	design "$h" "$mesh" || { echo "!! $name hybrid failed: $(tail -n 1 "$h.err")"; status=1; continue; }
	WH=$(jget "$h.json" hybrid.weight_fraction)
	python3 - "$name" "$h" <<'PY'
import json, sys
name, h = sys.argv[1:]
H = json.load(open(h + ".json"))["hybrid"]; t = open(h + ".time").read().split()
print(f"  {name} hybrid defaults: weight {H['weight_fraction']:.4f} (skin {H.get('shell_mm', '?')} mm), {t[0]} s, "
      f"{int(t[1]) // 1024} MB; {H.get('vcol_components', '?')} VCol, "
      f"{H.get('extended_columns', '?')} extended columns, {H.get('tcs_capsules', '?')} capsules, "
      f"islands {H.get('islands', '?')}")
print("  stages (s): " + ", ".join(f"{k} {v:.2f}" for k, v in H["seconds"].items()))
print("  components: " + "; ".join(
    f"{c['class']} {c['area_mm2']:.0f} mm2 axis ({c['axis']})" for c in H["components"]))
PY
	# 2. the one-structure designs at the hybrid's weight
	tcs_max=$(python3 -c "import math, sys; print(f'{math.sqrt(3) / 4 * float(sys.argv[1]):.4f}')" "$TCS_CELL")
	tune "$name" "$mesh" tcs tcs_stick_mm "$TCS_STICK" 0 "$tcs_max" + "$WH"
	TCS_SET=(--set tcs_stick_mm="$TUNED") TCS_OK=$TUNED_OK
	[ -n "$TUNED" ] || { echo "!! $name tcs: no run succeeded"; status=1; }
	tune "$name" "$mesh" mfs wall_mm "$MFS_WALL" 0 "$MFS_CELL" + "$WH"
	MFS_SET=(--set wall_mm="$TUNED") MFS_OK=$TUNED_OK
	if [ "$TUNED_OK" != 1 ] && [ "$REACHED" != 1 ]; then
		echo "  $name mfs: walls below $MFS_CELL mm do not reach $WH; bisecting mfs_cell_mm (wall $MFS_WALL)"
		tune "$name" "$mesh" mfs mfs_cell_mm "$MFS_CELL" "$MFS_WALL" \
			"$(python3 -c "import sys; print(float(sys.argv[1]) * 8)" "$MFS_CELL")" - "$WH" \
			--set wall_mm="$MFS_WALL"
		MFS_SET=(--set wall_mm="$MFS_WALL" --set mfs_cell_mm="$TUNED") MFS_OK=$TUNED_OK
	fi
	[ -n "$TUNED" ] || { echo "!! $name mfs: no run succeeded"; status=1; }
	# 3. the final designs with the engine's compliance, then infilld fea on each
	design "$TMP/${name}_tcs" "$mesh" --set structure=tcs "${TCS_SET[@]}" ||
		{ echo "!! $name tcs final failed: $(tail -n 1 "$TMP/${name}_tcs.err")"; status=1; }
	design "$TMP/${name}_mfs" "$mesh" --set structure=mfs "${MFS_SET[@]}" ||
		{ echo "!! $name mfs final failed: $(tail -n 1 "$TMP/${name}_mfs.err")"; status=1; }
	"$BIN" fea "$mesh" --set height_mm=60 --set up=y "${FEA[@]}" >"$TMP/${name}_solid.fea.json" \
		2>"$TMP/${name}_solid.fea.err" || echo "!! $name solid fea failed: $(tail -n 1 "$TMP/${name}_solid.fea.err")"
	for st in hybrid tcs mfs; do
		o="$TMP/${name}_$st"
		[ -s "$o.sl1" ] && [ -s "$o.json" ] || continue
		"$BIN" fea "$o.sl1" "${FEA[@]}" >"$o.fea.json" 2>"$o.fea.err" ||
			{ echo "!! $name $st fea failed: $(tail -n 1 "$o.fea.err")"; status=1; }
	done
	python3 - "$name" "$TMP" "${TCS_SET[*]}" "$TCS_OK" "${MFS_SET[*]}" "$MFS_OK" <<'PY' || status=1
import json, os, sys
name, tmp, tcs_set, tcs_ok, mfs_set, mfs_ok = sys.argv[1:]
def load(p):
    try:
        return json.load(open(p))
    except (OSError, ValueError):
        return None
solid = load(os.path.join(tmp, f"{name}_solid.fea.json"))
cs = solid["compliance_nmm"] if solid else None
note = {"hybrid": "defaults",
        "tcs": tcs_set.replace("--set ", "") + ("" if tcs_ok == "1" else " (not matched)"),
        "mfs": mfs_set.replace("--set ", "") + ("" if mfs_ok == "1" else " (not matched)")}
rows = []
for st in ("hybrid", "tcs", "mfs"):
    o = os.path.join(tmp, f"{name}_{st}")
    m, f = load(o + ".json"), load(o + ".fea.json")
    if not m:
        continue
    H = m["hybrid"]; t = open(o + ".time").read().split()
    w = H["weight_fraction"]; c = f["compliance_nmm"] if f else float("nan")
    rows.append((st, w, c, c * w, c / cs * w if cs else float("nan"),
                 H.get("compliance_x_weight", float("nan")), float(t[0]), int(t[1]) // 1024, note[st]))
    if st != "hybrid":
        print(f"  {name} {st} final stages (s): " + ", ".join(f"{k} {v:.2f}" for k, v in H["seconds"].items()))
print(f"  {name}: solid part C = {cs:.1f} N mm (infilld fea, 1 mm elements)" if cs else
      f"  {name}: solid part's fea failed")
hdr = (f"  {'mesh':8s} {'structure':9s} {'weight':>7s} {'C fea N mm':>11s} {'C x W':>9s} "
       f"{'C/Cs x W':>8s} {'engine CxW':>10s} {'seconds':>7s} {'peak MB':>7s}  parameters")
print(hdr); print("  " + "-" * (len(hdr) - 2))
for st, w, c, cw, cnw, ecw, s, mb, n in rows:
    print(f"  {name:8s} {st:9s} {w:7.4f} {c:11.1f} {cw:9.1f} {cnw:8.4f} {ecw:10.4f} {s:7.1f} {mb:7d}  {n}")
ok = [r for r in rows if r[3] == r[3]]
if ok:
    b = min(ok, key=lambda r: r[3]); e = min(rows, key=lambda r: r[5])
    rest = ", ".join(f"{r[0]} {r[3] / b[3]:.3f}x" for r in ok if r is not b)
    print(f"  {name}: {b[0]} wins on C x W by infilld fea ({rest} of it); "
          f"by the engine's compliance_x_weight {e[0]} wins")
PY
done
exit $status
