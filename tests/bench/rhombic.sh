#!/usr/bin/env bash
# rhombic.sh BUILD [normal|large] - the rhombic engine (paper 001) on the
# paper's beam (Fig. 12: 100 x 50 x 6.25 mm, three-point bending, 62 N):
# uniform refinement to about 0.6, then the stiffness optimisation at the
# uniform result's fraction; normalised compliances, their ratio (paper:
# 1.94 / 1.25 = 1.55), max displacements, iterations, time, peak RSS, and
# the bound on every refinement of the initial structure (bound=true).
# normal: 1 mm elements; large: also 0.5 mm (260k elements, ~3 min).
# Then the shared meshes at 50 mm (initial structure, SL1, time) and the
# letter P standing (Fig. 13).
set -uo pipefail
BUILD=${1:?usage: rhombic.sh BUILD [normal|large]}
MODE=${2:-normal}
BIN=${INFILLD_BIN:-$BUILD/infilld}
SHARED=${INFILLD_SHARED:-../shared}
TMP=${BENCH_TMP:-$BUILD/bench}/rhombic
mkdir -p "$TMP"
[ -x "$BIN" ] || { echo "rhombic.sh: $BIN not built (make build)" >&2; exit 1; }

python3 - "$TMP/beam.stl" <<'PY'
import struct, sys
x, y, z = 100, 6.25, 50
v = [(i * x, j * y, k * z) for k in (0, 1) for j in (0, 1) for i in (0, 1)]
f = [(0, 2, 1), (1, 2, 3), (4, 5, 6), (5, 7, 6), (0, 1, 4), (1, 5, 4),
     (2, 6, 3), (3, 6, 7), (0, 4, 2), (2, 4, 6), (1, 3, 5), (3, 7, 5)]
with open(sys.argv[1], "wb") as o:
    o.write(b"\0" * 80 + struct.pack("<I", len(f)))
    for t in f:
        o.write(struct.pack("<3f", 0, 0, 0))
        for i in t:
            o.write(struct.pack("<3f", *v[i]))
        o.write(b"\0\0")
PY
LOADS="fixed box=0,0,-0.5,2,6.25,0.5 axes=xyz; fixed box=98,0,-0.5,100,6.25,0.5 axes=z; force box=48,0,49.5,52,6.25,50.5 n=0,0,-62"
COMMON=(--engine rhombic --printer generic-fdm --set orient_deg=0 --set wall_mm=0.5
	--set skin_mm=0.5 --threads 2 --quiet)

beam() { # element edge (mm)
	local h=$1 u="$TMP/beam_u_$1" a="$TMP/beam_a_$1" vf
	/usr/bin/time -f '%e %M' -o "$u.time" "$BIN" run "$TMP/beam.stl" -o "$u.stl" "${COMMON[@]}" \
		--set fea_voxel_mm="$h" --set "loads=$LOADS" --set refine=uniform \
		--set volume_fraction=0.6 --metrics "$u.json" || return 1
	vf=$(python3 -c "import json,sys; print(repr(json.load(open(sys.argv[1]))['rhombic']['volume_fraction']))" "$u.json")
	/usr/bin/time -f '%e %M' -o "$a.time" "$BIN" run "$TMP/beam.stl" -o "$a.stl" "${COMMON[@]}" \
		--set fea_voxel_mm="$h" --set "loads=$LOADS" --set volume_fraction="$vf" \
		--set bound=true --metrics "$a.json" || return 1
	python3 - "$h" "$u" "$a" <<'PY'
import json, sys
h, u, a = sys.argv[1:]
U, A = (json.load(open(p + ".json"))["rhombic"] for p in (u, a))
tu, ta = (open(p + ".time").read().split() for p in (u, a))
print(f"beam h={h} mm ({A['fea_elements']} elements): initial {U['volume_fraction_initial']:.3f}; "
      f"uniform {U['volume_fraction']:.4f}: C/C_solid {U['compliance_normalized']:.3f}, "
      f"max |u| {U['max_displacement_mm']:.4f} mm, {tu[0]} s; adaptive "
      f"{A['volume_fraction']:.4f}: C/C_solid {A['compliance_normalized']:.3f}, max |u| "
      f"{A['max_displacement_mm']:.4f} mm, {A['iterations']} iterations, "
      f"{A['fea_solve_s']:.1f} s of solves, {ta[0]} s, {int(ta[1]) // 1024} MB; "
      f"ratio {U['compliance_normalized'] / A['compliance_normalized']:.3f} (paper 1.55), "
      f"displacement ratio {U['max_displacement_mm'] / A['max_displacement_mm']:.3f} "
      f"(paper physical 4.08 / 2.11 = 1.93); bound: no refinement of the initial structure "
      f"with this material below {A['compliance_bound_normalized']:.3f} x solid (gap "
      f"{A['bound_gap']:.4f}, {A['bound_iterations']} solves, {A['bound_s']:.1f} s), so the "
      f"ratio is at most {U['compliance_normalized'] / A['compliance_bound_normalized']:.3f}")
PY
}

status=0
beam 1 || status=1
[ "$MODE" = large ] && { beam 0.5 || status=1; }

for spec in femur:z camel:y armadillo:z; do
	name=${spec%%:*} up=${spec##*:} out="$TMP/$name"
	/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$SHARED/meshes/$name.off" -o "$out.sl1" \
		--engine rhombic --set height_mm=50 --set up="$up" --set wall_mm=0.5 --set skin_mm=0.5 \
		--set objective=stability --set refine=uniform --set volume_fraction=0.1 --threads 2 \
		--quiet --metrics "$out.json" || { status=1; continue; }
	python3 - "$name" "$out" <<'PY'
import json, sys
name, out = sys.argv[1:]
m = json.load(open(out + ".json")); r = m["rhombic"]; t = open(out + ".time").read().split()
print(f"{name:10s} 50 mm initial structure: orientation {r['orientation_deg']:.0f} of "
      f"{r['orientations_tried']}, {r['leaves']} cavities, {r['levels']} levels, fraction "
      f"{r['volume_fraction_initial']:.3f}; voxels {r['seconds']['voxels']:.2f} s, trees "
      f"{r['seconds']['initial']:.2f} s, {m['layers']} SL1 layers {m['seconds']['layers']:.2f} s; "
      f"{t[0]} s, {int(t[1]) // 1024} MB")
PY
done

out="$TMP/P"
/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$SHARED/meshes/P.off" -o "$out.sl1" \
	--engine rhombic --set up=y --set height_mm=100 --set wall_mm=0.6 --set skin_mm=0.6 \
	--set objective=stability --threads 2 --quiet --metrics "$out.json" || status=1
python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
r = json.load(open(out + ".json"))["rhombic"]; t = open(out + ".time").read().split()
print(f"P 100 mm stability: solid centre {r['com_before_mm']}, inside {r['com_solid_inside_hull']}; "
      f"after {r['com_after_mm']} inside {r['com_inside_hull']} ({r['com_hull_distance_mm']:.3f} mm); "
      f"fraction {r['volume_fraction_initial']:.3f} -> {r['volume_fraction']:.3f}, "
      f"{r['stability_splits']} splits; {t[0]} s")
PY
# Fig. 11 (right): compliance against volume fraction, adaptive and
# uniform refinement from the same initial structure, on one shared mesh
# at 50 mm under the default load case (plate fixed, 1000 N down on the
# top 1 mm).  The adaptive run to CURVE_VF records every iteration
# (rhombic.history: fraction, compliance, max |u|); the uniform curve is
# one run per refinement step (each run's target just above the last
# step's fraction).  The adaptive run is also the timing case: a 50 mm
# shared mesh to 0.7.  The bunny: bulky, so its initial structure is
# sparse (0.53; the femur's is 0.90), but its top 1 mm is its ears; the cow
# standing (its back on top) is the second curve.  Drawn by plot_xy.py into
# $TMP/curve.png and $TMP/cow.png (docs/rhombic.md shows them).
CURVE_MESH=${CURVE_MESH:-bunny.stl}
CURVE_VF=${CURVE_VF:-0.7}
# 1 mm elements (25k on the bunny); large mode also times the adaptive run
# at the automatic element size (0.54 mm, 372k elements: 8-10 min).
CURVE_FEA_MM=${CURVE_FEA_MM:-1}
if [ "$MODE" = large ]; then
	out="$TMP/auto_a"
	/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$SHARED/meshes/$CURVE_MESH" -o "$out.sl1" \
		--engine rhombic --set height_mm=50 --set wall_mm=0.5 --set skin_mm=0.5 --threads 2 \
		--quiet --set volume_fraction="$CURVE_VF" --metrics "$out.json" || status=1
	python3 - "$out" "$CURVE_MESH" <<'PY'
import json, sys
out, mesh = sys.argv[1:]
r = json.load(open(out + ".json"))["rhombic"]; t = open(out + ".time").read().split()
its = [int(x) for x in r["fea_iterations"]]
print(f"{mesh} 50 mm to {r['volume_fraction']:.3f} at the automatic elements "
      f"({r['fea_voxel_mm']:.3f} mm, {r['fea_elements']}): {r['iterations']} iterations, "
      f"{r['fea_solves']} solves, {sum(its)} CG iterations (fea_tol {r.get('fea_tol', '?')}), "
      f"{r['fea_solve_s']:.0f} s of solves, C/C_solid {r['compliance_normalized']:.4f}; "
      f"{t[0]} s, {int(t[1]) // 1024} MB")
PY
fi
# curve NAME MESH [--set ...]: the adaptive run to CURVE_VF and the uniform
# steps from the same initial structure, files $TMP/NAME_*, plot $TMP/NAME.png.
# Extra arguments (placement, printer, output extension via CURVE_EXT) go to
# every run.
curve() {
	local name=$1 mesh=$2 ext=${CURVE_EXT:-sl1} out vf target step
	shift 2
	local CURVE=(--engine rhombic --set height_mm=50 --set wall_mm=0.5 --set skin_mm=0.5
		--threads 2 --quiet --set fea_voxel_mm="$CURVE_FEA_MM" "$@")
	out="$TMP/${name}_a"
	/usr/bin/time -f '%e %M' -o "$out.time" "$BIN" run "$SHARED/meshes/$mesh" -o "$out.$ext" \
		"${CURVE[@]}" --set volume_fraction="$CURVE_VF" --metrics "$out.json" || return 1
	rm -f "$TMP/${name}"_u*.json
	vf=0
	for step in 1 2 3 4 5 6; do
		out="$TMP/${name}_u$step"
		target=$(python3 -c "import sys; print(min(1.0, float(sys.argv[1]) + 1e-3))" "$vf")
		"$BIN" run "$SHARED/meshes/$mesh" -o "$out.$ext" "${CURVE[@]}" --set refine=uniform \
			--set volume_fraction="$target" --metrics "$out.json" || return 1
		vf=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['rhombic']['volume_fraction'])" "$out.json")
		python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) < 0.999 else 1)" "$vf" || break
	done
	python3 - "$TMP" "$name" "$mesh" <<'PY'
import glob, json, os, sys
tmp, name, mesh = sys.argv[1:]
A = json.load(open(os.path.join(tmp, name + "_a.json")))["rhombic"]
cs = A["compliance_solid_nmm"]
ad = []
for h in A["history"]:
    vf, c = (float(x) for x in h.split()[:2])
    if vf < 0.999:
        ad.append((vf, c / cs))
un = []
for p in sorted(glob.glob(os.path.join(tmp, name + "_u*.json"))):
    r = json.load(open(p))["rhombic"]
    un.append((r["volume_fraction"], r["compliance_normalized"]))
un = sorted(set(un))
# the uniform curve starts where the adaptive one does (the same initial structure)
if ad and (not un or un[0][0] > ad[0][0] + 1e-9):
    un.insert(0, ad[0])
with open(os.path.join(tmp, name + "_adaptive.csv"), "w") as f:
    f.write("volume_fraction,compliance_normalized\n")
    f.writelines(f"{v:.4f},{c:.4f}\n" for v, c in ad)
with open(os.path.join(tmp, name + "_uniform.csv"), "w") as f:
    f.write("volume_fraction,compliance_normalized\n")
    f.writelines(f"{v:.4f},{c:.4f}\n" for v, c in un)
def at(curve, v):  # linear interpolation, None outside
    for (v0, c0), (v1, c1) in zip(curve, curve[1:]):
        if v0 <= v <= v1 and v1 > v0:
            return c0 + (c1 - c0) * (v - v0) / (v1 - v0)
    return None
worse = [(v, c, at(un, v)) for v, c in ad if at(un, v) is not None and c > at(un, v) + 1e-9]
t = open(os.path.join(tmp, name + "_a.time")).read().split()
print(f"{mesh} 50 mm compliance vs volume: adaptive {len(ad)} points "
      f"{ad[0][0]:.3f}..{ad[-1][0]:.3f} (C/C_solid {ad[0][1]:.3f} -> {ad[-1][1]:.3f}, "
      f"{A['iterations']} iterations, {A['fea_solve_s']:.0f} s of solves, {t[0]} s, "
      f"{int(t[1]) // 1024} MB); uniform steps "
      + ", ".join(f"{v:.3f}: {c:.3f}" for v, c in un)
      + f"; adaptive above uniform at {len(worse)} of {len(ad)} points")
print(f"{mesh} 50 mm adaptive to volume_fraction {A['volume_fraction']:.3f}: C/C_solid "
      f"{A['compliance_normalized']:.3f}, {t[0]} s, {int(t[1]) // 1024} MB peak")
PY
	/usr/bin/python3 tests/bench/plot_xy.py "$TMP/$name.png" "$TMP/${name}_adaptive.csv:adaptive" \
		"$TMP/${name}_uniform.csv:uniform" --title "rhombic, $mesh 50 mm (default load: plate fixed, 1000 N on the top 1 mm): compliance vs volume" \
		--xlabel "V / V_solid" --ylabel "C / C_solid" && echo "plot: $TMP/$name.png"
}
curve curve "$CURVE_MESH" || status=1
# the cow standing (up = y): the top 1 mm is its back, so the load runs
# through the body and the interior carries it (the bunny's is its ears);
# 50 mm tall it is wider than the SL1's display, so G-code
CURVE_EXT=gcode curve cow cow.off --set up=y --printer generic-fdm || status=1
exit $status
