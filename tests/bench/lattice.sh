#!/usr/bin/env bash
# lattice.sh BUILD [normal|large] - issue 4's lattice benchmarks (paper 000).
#  1. camel, as Table 3: Gamma/Psi of the raw tetrahedral lattice, after SO
#     and after SO+PO, and the time (through `infilld run ... --engine lattice`)
#  2. a ~120k-strut lattice generated in the bunny, sliced at 3648 x 1824 px
#     (the paper's Bunny: 26.47 s/slice, 146 MB), then the same lattice file
#     printed end to end as SL1 through the CLI (lattice-file input)
#  3. a >= 10M-strut streamed lattice in the bunny, SL1 end to end
#  large: a >= 100M-strut lattice streamed and sliced at 5728 x 2864 px
#     (the paper's Kitten-HR: 101M struts, 447 MB, 347 s/slice)
set -euo pipefail
BUILD=$1
MODE=${2:-normal}
BIN=$INFILLD_BIN
BENCH=$INFILLD_BUILD/tests/bench/bench_lattice
T=$BENCH_TMP/lattice
mkdir -p "$T"
M=$INFILLD_SHARED/meshes
export TMPDIR=$T

# timed NAME CMD... : runs CMD, keeps its stdout in $T/NAME.out, prints wall s and peak RSS MB
timed() {
	local name=$1; shift
	/usr/bin/time -f "%e %M" -o "$T/$name.time" "$@" >"$T/$name.out" 2>"$T/$name.err" || {
		echo "$name failed:"; tail -5 "$T/$name.err"; return 1; }
	read -r wall rss <"$T/$name.time"
	echo "$name: wall ${wall}s, peak RSS $((rss / 1024)) MB"
}
val() { awk -v k="$2" '$1 == k { print $2 }' "$T/$1.out"; }
json() { python3 -c "import json,sys; m=json.load(open('$1')); print(eval(sys.argv[1]))" "$2"; }

if [ "$MODE" != large ]; then
	echo "-- camel (Table 3: TetGen 63.1%, SO 50.0%, SO+PO 37.3%, 89 s; Psi 27.7% -> 45.5%)"
	timed camel "$BIN" run "$M/camel.off" -o "$T/camel.sl1" --engine lattice --set up=y \
		--set height_mm=60 --set min_radius_mm=0.1 --metrics "$T/camel.json" --threads 2 --quiet
	j=$T/camel.json
	echo "   struts $(json "$j" "m['lattice']['struts']") (paper 12,241), raw lattice $(json "$j" "m['lattice']['raw_struts']")"
	echo "   Gamma raw $(json "$j" "'%.1f%%' % (100*m['lattice']['gamma_raw'])"), SO $(json "$j" "'%.1f%%' % (100*m['lattice']['gamma_so'])"), SO+PO $(json "$j" "'%.1f%%' % (100*m['lattice']['gamma_so_po'])")  (eq. 13, one radius)"
	echo "   Psi   raw $(json "$j" "'%.1f%%' % (100*m['lattice']['psi_raw'])"), SO $(json "$j" "'%.1f%%' % (100*m['lattice']['psi_so'])"), SO+PO $(json "$j" "'%.1f%%' % (100*m['lattice']['psi_so_po'])")"
	echo "   Gamma reduction SO+PO vs raw: $(json "$j" "'%.0f%%' % (100*(1-m['lattice']['gamma_so_po']/m['lattice']['gamma_raw']))") (paper 41%)"
	echo "   time: SO+PO lattice $(json "$j" "'%.1f s' % (m['lattice']['seconds']['sample']+m['lattice']['seconds']['tetgen']+m['lattice']['seconds']['po'])"), whole design (incl. raw baseline, matching, measuring) $(json "$j" "'%.1f s' % m['lattice']['seconds']['prepare']") (goal < 60 s)"
	echo "   density error per voxel: mean $(json "$j" "'%.4f' % m['lattice']['density_error_mean']"), max $(json "$j" "'%.4f' % m['lattice']['density_error_max']") over $(json "$j" "m['lattice']['density_voxels']") voxels"

	echo "-- bunny lattice, 3648 x 1824 px (paper: 123,610 struts, 26.47 s/slice, 146 MB)"
	timed bunny_gen "$BENCH" gen "$M/bunny.stl" y 80 0.2 0.093 "$T/bunny.lat" 2
	echo "   generated $(val bunny_gen gen_struts) struts, density error mean $(val bunny_gen gen_density_error_mean) max $(val bunny_gen gen_density_error_max)"
	for aa in 0 1; do
		timed bunny_slice_aa$aa "$BENCH" slice "$T/bunny.lat" 3648 1824 100 2 $aa
		echo "   $([ $aa = 1 ] && echo antialiased || echo binary): $(val bunny_slice_aa$aa slice_seconds_per_slice) s/slice (goal <= 0.25), max active $(val bunny_slice_aa$aa slice_max_active), pixel $(val bunny_slice_aa$aa slice_pixel_um) um"
	done
	timed bunny_sl1 "$BIN" run "$T/bunny.lat" -o "$T/bunny.sl1" --engine lattice \
		--metrics "$T/bunny_sl1.json" --threads 2 --quiet
	echo "   lattice file -> SL1 end to end: $(json "$T/bunny_sl1.json" "m['layers']") layers, $(json "$T/bunny_sl1.json" "'%.4f' % m['lattice']['seconds_per_slice']") s/slice rendering"

	echo "-- >= 10M struts streamed (bunny, 80 mm), SL1 end to end (goal: peak RSS < 500 MB)"
	timed grid10 "$BENCH" grid "$M/bunny.stl" y 80 10500000 "$T/big10.lat" 2
	echo "   $(val grid10 grid_struts) struts, $(val grid10 grid_nodes) nodes, file $(( $(stat -c %s "$T/big10.lat") / 1048576 )) MB"
	timed big10_sl1 "$BIN" run "$T/big10.lat" -o "$T/big10.sl1" --engine lattice \
		--metrics "$T/big10.json" --threads 2 --quiet
	echo "   $(json "$T/big10.json" "m['layers']") layers, $(json "$T/big10.json" "'%.3f' % m['lattice']['seconds_per_slice']") s/slice rendering, max active $(json "$T/big10.json" "m['lattice']['max_active_struts']"), node window $(json "$T/big10.json" "m['lattice']['stream_window_nodes']")"
	rm -f "$T/big10.lat" "$T/big10.sl1" "$T/camel.sl1" "$T/bunny.sl1"
else
	echo "-- >= 100M struts streamed, 5728 x 2864 px (paper Kitten-HR: 101M, 447 MB, 347 s/slice)"
	timed grid100 "$BENCH" grid "$M/bunny.stl" y 100 101000000 "$T/big100.lat" 2
	echo "   $(val grid100 grid_struts) struts, $(val grid100 grid_nodes) nodes, file $(( $(stat -c %s "$T/big100.lat") / 1048576 )) MB, generation peak RSS $(val grid100 grid_rss_mb) MB"
	timed big100_slice "$BENCH" slice "$T/big100.lat" 5728 2864 100 2 0
	echo "   $(val big100_slice slice_struts_read) struts streamed, $(val big100_slice slice_seconds_per_slice) s/slice, max active $(val big100_slice slice_max_active), node window $(val big100_slice slice_window_nodes), slicing peak RSS $(val big100_slice slice_rss_mb) MB (goal < 1024)"
	rm -f "$T/big100.lat"
fi
