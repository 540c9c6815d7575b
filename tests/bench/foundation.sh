#!/usr/bin/env bash
# foundation.sh BUILD [mode] - issue 2's benchmark: slice armadillo (50 mm
# tall) to SL1 at 0.05 mm on the sl1 profile and to G-code at 0.2 mm, with
# infilld and with PrusaSlicer 2.5 (Debian's prusa-slicer, installed here if
# missing) on the same placed mesh and settings, and print wall time,
# layers/s and peak RSS of both.
set -euo pipefail
BUILD=$1
BIN=$INFILLD_BIN
T=$BENCH_TMP/foundation
mkdir -p "$T"
MESH=$INFILLD_SHARED/meshes/armadillo.off

if ! command -v prusa-slicer >/dev/null; then
	echo "installing prusa-slicer (Debian) for the comparison..."
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends prusa-slicer >/dev/null
fi

# The same placed part for both: armadillo is stored +y up.
"$BIN" run "$MESH" -o "$T/arma50.stl" --set height_mm=50 --set up=y --quiet

# measure NAME CMD...: prints "NAME wall_s rss_mb" (GNU time)
measure() {
	local name=$1; shift
	/usr/bin/time -f "%e %M" -o "$T/time.txt" "$@" >/dev/null 2>"$T/$name.err" || {
		echo "$name failed:"; tail -5 "$T/$name.err"; return 1; }
	read -r wall rss <"$T/time.txt"
	echo "$name $wall $((rss / 1024))"
}

cat >"$T/sl1.ini" <<'INI'
printer_technology = SLA
printer_model = SL1
supports_enable = 0
pad_enable = 0
hollowing_enable = 0
layer_height = 0.05
initial_layer_height = 0.05
display_width = 120.96
display_height = 68.04
display_pixels_x = 2560
display_pixels_y = 1440
display_orientation = portrait
display_mirror_x = 1
INI
cat >"$T/fdm.ini" <<'INI'
printer_technology = FFF
nozzle_diameter = 0.4
filament_diameter = 1.75
layer_height = 0.2
first_layer_height = 0.2
fill_density = 15%
fill_pattern = rectilinear
perimeters = 2
top_solid_layers = 4
bottom_solid_layers = 3
bed_shape = 0x0,220x0,220x220,0x220
max_print_height = 250
skirts = 1
gcode_flavor = marlin2
INI

rows=()
rows+=("$(measure infilld-sl1 "$BIN" run "$T/arma50.stl" -o "$T/i.sl1" --quiet --metrics "$T/i-sl1.json")")
rows+=("$(measure prusa-sl1 prusa-slicer --loglevel 1 --export-sla --load "$T/sl1.ini" -o "$T/p.sl1" "$T/arma50.stl")")
rows+=("$(measure infilld-gcode "$BIN" run "$T/arma50.stl" -o "$T/i.gcode" --quiet --metrics "$T/i-gcode.json")")
rows+=("$(measure prusa-gcode prusa-slicer --loglevel 1 --export-gcode --load "$T/fdm.ini" --center 110,110 -o "$T/p.gcode" "$T/arma50.stl")")

layers_sl1=$(python3 -c "import json;print(json.load(open('$T/i-sl1.json'))['layers'])")
layers_gc=$(python3 -c "import json;print(json.load(open('$T/i-gcode.json'))['layers'])")
printf '%-14s %8s %9s %8s\n' run wall_s layers/s rss_mb
for r in "${rows[@]}"; do
	set -- $r
	case $1 in *sl1) n=$layers_sl1 ;; *) n=$layers_gc ;; esac
	printf '%-14s %8.2f %9.1f %8d\n' "$1" "$2" "$(awk -v n="$n" -v t="$2" 'BEGIN{print n/t}')" "$3"
done
python3 - "$T" <<'PY'
import sys, json
t = sys.argv[1]
for f in ("i-sl1.json", "i-gcode.json"):
    m = json.load(open(f"{t}/{f}"))
    print(f"{f}: layers={m['layers']} part={m['part_volume_mm3']:.1f} mm3 "
          f"material={m['material_volume_mm3']:.1f} mm3 peak_rss={m['peak_rss_mb']:.0f} MB")
PY
