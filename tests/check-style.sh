#!/usr/bin/env bash
# check-style.sh [BUILD] - the mechanical part of ../shared/STYLE.md
# (`make check-style`; also run by `make test`):
#  1. engine/ includes no HTTP, JSON or SQL headers; db/ includes nothing
#     from api/ or service/; api/ nothing from service/ (one-way layers);
#  2. every extern symbol of an object file carries a prefix of its module
#     (C++ mangled _Z* and reserved __* names, e.g. ASan's __odr_asan.*, skipped)
#     (table below, one line per directory; file-local helpers are static);
#  3. .c/.cpp files stay under 1,000 lines and headers under 300
#     (test fixtures under tests/ excepted).
set -uo pipefail
BUILD=${1:-build}
cd "$(dirname "$0")/.."
fail=0
say() { echo "check-style: $*"; fail=1; }

# 1. Layering.
bad=$(grep -rlE '#include[[:space:]]*[<"](microhttpd|jansson|sqlite3)\.h' engine 2>/dev/null)
[ -z "$bad" ] || say "engine/ must not include HTTP/JSON/SQL headers: $bad"
bad=$(grep -rlE '#include[[:space:]]*"(api|service)/' db engine 2>/dev/null)
[ -z "$bad" ] || say "db/ and engine/ must not include api/ or service/: $bad"
bad=$(grep -rlE '#include[[:space:]]*"service/' api 2>/dev/null)
[ -z "$bad" ] || say "api/ must not include service/: $bad"

# 2. Module prefixes of extern symbols (C symbols; C++ shims export C names).
declare -A PREFIX=(
	[api]="api_ log_ multipart_ problem_"
	[db]="db_ queue_ store_"
	[db/pg]="pgdb_ db_pg_ops"
	[db/sqlite]="sq_ db_sqlite_ops queue_claim_sql"
	[engine/core]="buf_ err_ mem_ metrics_ param_ parfor_ pipeline_ progress_ sink_ rng_"
	[engine/fea]="fea_"
	[engine/geom]="capsule_ clip_ delaunay_ edt_ edt3_ geom_ hull_ label_ path_ paths_ pointgrid_ poisson2_ polytri_ polytope_ raster_ v3_ box3_"
	[engine/hollow]="hollow_ hl_"
	[engine/hollow/opt]="hl_"
	[engine/hollow/fill]="hl_"
	[engine/hybrid]="hy_ hybrid_"
	[engine/job]="common_ engine_ job_"
	[engine/lattice]="lattice_ latbin_ strut_"
	[engine/mesh]="mesh_ tetra_"
	[engine/rhombic]="rh_ rhombic_"
	[engine/output]="out_"
	[engine/output/printer]="printer_"
	[engine/output/resin]="sl1_ zip_ out_zip_"
	[engine/output/image]="out_png_ png_ thumb_ thumbnail_"
	[engine/output/toolpath]="tp_"
	[engine/output/gcode]="gcode_ gc_"
	[engine/slice]="layer_ slice_"
	[engine/solid]="solid_"
	[engine/verify]="verify_"
	[service]="cmd_ config_ jobproc_ rlimit_ supervisor_ main"
)
if [ -d "$BUILD/obj" ]; then
	for dir in "${!PREFIX[@]}"; do
		[ -d "$BUILD/obj/$dir" ] || continue
		allowed=${PREFIX[$dir]}
		while read -r obj sym; do
			ok=0
			for p in $allowed; do
				case $sym in "$p"*) ok=1; break ;; esac
			done
			[ $ok = 1 ] || say "$obj exports '$sym' without a $dir prefix ($allowed)"
		done < <(for o in "$BUILD/obj/$dir"/*.o; do
			nm -g --defined-only "$o" | awk -v o="${o#$BUILD/obj/}" \
				'$2 ~ /^[TDRBC]$/ && $3 !~ /^_Z/ && $3 !~ /^__/ {print o, $3}'
		done)
	done
	for d in $(cd "$BUILD/obj" && find . -mindepth 1 -type d -printf '%P\n'); do
		ls "$BUILD/obj/$d"/*.o >/dev/null 2>&1 || continue
		case $d in tests*) continue ;; esac
		[ -n "${PREFIX[$d]-}" ] || say "no prefix rule for directory $d (add it to tests/check-style.sh)"
	done
else
	say "no $BUILD/obj: build first"
fi

# 3. File sizes.
while read -r n f; do
	case $f in
	tests/*) continue ;;
	*.h) [ "$n" -le 300 ] || say "$f has $n lines (headers: at most ~300; split by concern)" ;;
	*) [ "$n" -le 1000 ] || say "$f has $n lines (at most ~1,000; split by concern)" ;;
	esac
done < <(git ls-files '*.c' '*.h' '*.cpp' | xargs wc -l | grep -v ' total$')

[ $fail = 0 ] && echo "check-style: ok"
exit $fail
