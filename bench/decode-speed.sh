#!/usr/bin/env bash
# decode-speed.sh - tile decoding speed in one run on the same store: the
# CPU reference decoder (1 thread, every core, and its prediction alone),
# the GPU decoder through EGL (llvmpipe here; the vendor driver on a GPU
# machine) one call per tile and batched per level, and libjpeg-turbo
# decoding the same level-0 tiles as JPEG at the quality of equal PSNR
# (bench/decode_bench.c).  Single-thread speeds also per CPU-second, for a
# loaded machine.  Prints figures and ratios; asserts nothing.
#
#   bench/decode-speed.sh [BUILD-DIR] [IMAGE...]
#
# BUILD-DIR (default: build) holds a configured, built gigaview tree.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
top=$(cd "$here/.." && pwd)
build=${1:-build}
shift || true
case $build in /*) ;; *) build=$top/$build ;; esac
[ -f "$build/lib/base/libgvbase.a" ] || { echo "decode-speed: build gigaview in $build first" >&2; exit 1; }
images=("$@")
# The benchmark images: shared/data beside the checkout, unless DATA_DIR says.
DATA_DIR=${DATA_DIR:-$top/../shared/data}
[ ${#images[@]} -gt 0 ] || images=("$DATA_DIR/photos/Dragonfly_by_Bolly.jpg"
                                     "$DATA_DIR/photos/picosdeeuropa_by_Aitzol_Berasategi.jpg")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Built by the tree's own rules (Makefile.am, bench section), with its flags.
make -s -C "$build" bench/decode_bench >&2
for img in "${images[@]}"; do
    "$build/gigaview" encode --rd -q 34 --quiet "$img" -o "$work/s.gv"
    echo "== $(basename "$img") (gigaview encode --rd -q 34)"
    "$build/bench/decode_bench" "$work/s.gv" "$img"
done
