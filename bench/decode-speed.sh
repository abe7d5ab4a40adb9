#!/usr/bin/env bash
# decode-speed.sh - tile decoding speed in one run on the same store: the
# CPU reference decoder (1 thread, every core), the GPU decoder through EGL
# (llvmpipe here; the vendor driver on a GPU machine) and libjpeg-turbo
# decoding the same level-0 tiles as JPEG at the quality of equal PSNR
# (bench/decode_bench.c).  Prints figures and ratios; asserts nothing.
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
# shellcheck disable=SC2046 # pkg-config prints several flags
cc -std=c11 -D_GNU_SOURCE -O2 -pthread -I"$top/lib" -I"$build" -I"$build/shaders" \
    "$here/decode_bench.c" "$build"/lib/gpu/libgvgpu.a "$build"/lib/encode/libgvencode.a "$build"/lib/render/libgvrender.a "$build"/lib/store/libgvstore.a "$build"/lib/codec/libgvcodec.a "$build"/lib/imageio/libgvimageio.a "$build"/lib/base/libgvbase.a \
    $(pkg-config --libs OpenImageIO zlib libwebp egl glesv2) -ljpeg -lstdc++ -lm \
    -o "$work/decode_bench"
for img in "${images[@]}"; do
    "$build/gigaview" encode --rd -q 34 --quiet "$img" -o "$work/s.gv"
    echo "== $(basename "$img") (gigaview encode --rd -q 34)"
    "$work/decode_bench" "$work/s.gv" "$img"
done
