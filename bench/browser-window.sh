#!/bin/bash
# browser-window.sh: the browser viewer's redraw when a sample store's
# display window or channel colours change, in headless Chromium: WebGL2
# (the viewer's display shader over the tiles it decoded, no request)
# against the same viewer drawing the server's regions (renderer=region,
# each change fetched again), in the same run on the same stores
# (bench/browser-window.mjs says exactly what is timed).
#
#   bench/browser-window.sh [--gigaview PATH] [--gigaviewd PATH]
#
# Stores (gigaview encode --bits 16, lossless): ETOPO5 (4320 x 2161, one
# channel of 16-bit elevations) and GoldenGate (hdr/GoldenGate.exr, 1262 x
# 860, three channels, sRGB-encoded to 16 bits as bench/samples-vs-cog.sh
# makes it), and for reference an 8-bit image store (Picos de Europa,
# 3264 x 2448), from $DATA_DIR (default: shared/data beside the checkout).
# Nothing is asserted: the script only reports.
#
# Environment:
#   GIGAVIEW, GIGAVIEWD  binaries (default: next to bench/, or on PATH)
#   CHANGES=N     window and colour changes timed per view (default 20)
#   SIZE=WxH      browser viewport (default 1280x800)
#   GPU=host      use the machine's GPU instead of SwiftShader
#   TMPDIR=DIR    scratch space (default /tmp)
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
bench_no_inputs
[ -x /usr/bin/chromium ] || die "no /usr/bin/chromium (apt-get install chromium)"
[ -d "$BENCH_DIR/../tests/browser/node_modules/playwright-core" ] ||
	die "no playwright-core: cd tests/browser && npm ci"
command -v node >/dev/null 2>&1 || die "no node (apt-get install nodejs)"
command -v oiiotool >/dev/null 2>&1 || die "no oiiotool (apt-get install openimageio-tools)"

GV=$(find_gigaview "$gv_arg")
GVD=$(find_gigaviewd "$gvd_arg")
WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-window-bench.XXXXXX")
trap 'http_cleanup; rm -rf "$WORK"' EXIT
cp "$GV" "$WORK/gigaview"
cp "$GVD" "$WORK/gigaviewd"
snapshot_module "$GVD" "$WORK"
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"
echo "# chromium: $(/usr/bin/chromium --version 2>/dev/null | head -1)"

mkdir "$WORK/stores"
oiiotool "$DATA_DIR/hdr/GoldenGate.exr" --ch R,G,B --colorconvert linear sRGB \
	-d uint16 -o "$WORK/golden.tif" >/dev/null
"$WORK/gigaview" encode --bits 16 "$DATA_DIR/elevation/etopo5-4320x2161-u16.png" \
	-o "$WORK/stores/etopo5.gv" >/dev/null || die "encode etopo5 failed"
"$WORK/gigaview" encode --bits 16 "$WORK/golden.tif" -o "$WORK/stores/golden.gv" >/dev/null ||
	die "encode golden failed"
# The 8-bit reference: an image store (its window on 8-bit samples).
"$WORK/gigaview" encode "$DATA_DIR/photos/picosdeeuropa_by_Aitzol_Berasategi.jpg" \
	-o "$WORK/stores/picos.gv" >/dev/null || die "encode picos failed"
for id in etopo5 golden picos; do
	echo "# $id: $("$WORK/gigaview" info "$WORK/stores/$id.gv" | sed -n 's/^\(samples\|image\) *//p'), \
$(stat -c %s "$WORK/stores/$id.gv") bytes"
done

start_browser_gigaviewd "$WORK/gigaviewd" "$WORK"
echo "# gigaviewd on port $GVD_PORT; CHANGES=${CHANGES:-20} SIZE=${SIZE:-1280x800} GPU=${GPU:-swiftshader}"
node "$BENCH_DIR/browser-window.mjs" --base "http://127.0.0.1:$GVD_PORT" \
	--images etopo5,golden,picos --changes "${CHANGES:-20}" --size "${SIZE:-1280x800}" \
	--gpu "$(browser_gpu)"
