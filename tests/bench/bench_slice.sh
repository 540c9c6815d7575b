#!/usr/bin/env bash
# bench_slice.sh BUILD [mode] - build and run tests/bench/bench_slice.c
# (slicing core figures: contours, rasterisation, erosion).
set -euo pipefail
BUILD=$1
OUT=$BUILD/tests/bench/bench_slice
mkdir -p "$(dirname "$OUT")"
make --no-print-directory -s "$BUILD/libengine.a" >/dev/null
# Same flags as the unit tests (Makefile CFLAGS), linked against the engine.
gcc -std=c11 -O2 -g -Wall -Wextra -Werror -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -pthread \
	-I. -Itests -o "$OUT" tests/bench/bench_slice.c "$BUILD/libengine.a" \
	-lpolyclipping -lstdc++ -lm
"$OUT" "$INFILLD_SHARED/meshes/armadillo.off" 1
