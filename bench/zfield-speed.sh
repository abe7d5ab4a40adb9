#!/bin/sh
# zfield-speed.sh [BUILD-DIR] - z-field simplification (lib/mesh/zfield.h):
# view-dependent refinement per frame on a 4097x4097 fractal, the GPU
# sweep (EGL: llvmpipe here, the vendor's driver on a GPU machine) against
# one CPU thread in the same run, and the triangle count at equal maximum
# error against greedy insertion on ETOPO5 (bench/zfield_bench.c).
# FRAMES=N (default 10) and SIDE=2^k+1 (default 4097) size the first part.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-$here/../build}
make -s -C "$build" bench/zfield_bench >&2
"$build/bench/zfield_bench" --frames "${FRAMES:-10}" --side "${SIDE:-4097}" \
    "$here/../../shared/data/elevation/etopo5-4320x2161-u16.png" 11000
