#!/bin/bash
# browser-bytes.sh: bytes transferred for a scripted pan and zoom path in
# the browser, the gigaview viewer against OpenSeadragon on IIIF JPEG tiles
# of equal PSNR, and the native window client (`gigaview view`, under
# SDL's offscreen driver: llvmpipe where there is no GPU) along the same
# path, in the same run (bench/browser-bytes.mjs has the path and what is
# counted; the native viewer is left out, with a note, when this gigaview
# was built without SDL2 or NATIVE=0).
#
#   bench/browser-bytes.sh [--gigaview PATH] [--gigaviewd PATH] [IMAGE]
#
# The image (default: Picos de Europa, 3264x2448, from $DATA_DIR)
# is copied to a metadata-free PNG and encoded with gigaview ($GV_ARGS,
# default --rd, its best rate-distortion mode; GV_ARGS="" for the default
# per-tile target); the store's level 0 is exported and its PSNR against the
# source measured with bench/imgcompare.c.  The JPEG quality whose PSNR
# (cjpeg -optimize, 4:2:0, the whole image) is closest to it is then used
# for a static IIIF Image API 3 tile pyramid (vips dzsave --layout iiif3,
# 512-pixel tiles, no overlap), which OpenSeadragon (from
# tests/browser/node_modules) reads; gigaviewd serves the store to the
# viewer.  Both run in headless Chromium (/usr/bin/chromium) at the same
# viewport.  Nothing is asserted: the script only reports.
#
# Environment: GIGAVIEW, GIGAVIEWD; GV_ARGS (encoder options, default
# --rd); SIZE=WxH (default 1280x800); NATIVE=0 (no native viewer);
# TMPDIR (scratch, default /tmp).  Needs vips, cjpeg/djpeg, cc, node.
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
img=${inputs[0]:-}
[ -n "$img" ] || img="$DATA_DIR/photos/picosdeeuropa_by_Aitzol_Berasategi.jpg"
GV_ARGS=${GV_ARGS---rd}
[ -x /usr/bin/chromium ] || die "no /usr/bin/chromium (apt-get install chromium)"
[ -d "$BENCH_DIR/../tests/browser/node_modules/openseadragon" ] ||
	die "no openseadragon/playwright-core: cd tests/browser && npm ci"
need_cmd vips libvips-tools
need_cmd cjpeg libjpeg-turbo-progs

GV=$(find_gigaview "$gv_arg")
GVD=$(find_gigaviewd "$gvd_arg")
WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-browser-bytes.XXXXXX")
trap 'http_cleanup; rm -rf "$WORK"' EXIT
CMP=$(build_imgcompare "$WORK")
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"

id=image
mkdir "$WORK/stores"
vips copy "$img" "$WORK/src.png[strip,compression=1]"
to_pnm "$WORK/src.png" "$WORK/ref.ppm"
# shellcheck disable=SC2086 # GV_ARGS is a list of options
"$GV" encode "$WORK/src.png" -o "$WORK/stores/$id.gv" $GV_ARGS >/dev/null
"$GV" export "$WORK/stores/$id.gv" --level 0 -o "$WORK/gv0.png" >/dev/null
to_pnm "$WORK/gv0.png" "$WORK/gv0.ppm"
gv_psnr=$("$CMP" "$WORK/ref.ppm" "$WORK/gv0.ppm" | sed 's/psnr=\([0-9.]*\).*/\1/')
echo "# $(basename "$img"): $(img_w "$WORK/src.png")x$(img_h "$WORK/src.png"); gigaview encode ${GV_ARGS:-(defaults)}: store $(stat -c %s "$WORK/stores/$id.gv") bytes, level-0 PSNR $gv_psnr dB"

# The JPEG quality of the closest PSNR: every 5 from 5 to 95, then the
# neighbours of the best one.
best_q="" best_d=""
try_q() {
	cjpeg -quality "$1" -optimize -outfile "$WORK/q.jpg" "$WORK/ref.ppm" 2>/dev/null
	djpeg -pnm -outfile "$WORK/q.ppm" "$WORK/q.jpg"
	p=$("$CMP" "$WORK/ref.ppm" "$WORK/q.ppm" | sed 's/psnr=\([0-9.]*\).*/\1/')
	d=$(awk -v a="$p" -v b="$gv_psnr" 'BEGIN { d = a - b; if (d < 0) d = -d; print d }')
	if [ -z "$best_d" ] || awk -v a="$d" -v b="$best_d" 'BEGIN { exit !(a < b) }'; then
		best_q=$1 best_d=$d best_p=$p
	fi
}
for q in $(seq 5 5 95); do try_q "$q"; done
c=$best_q
for q in $(seq $((c > 9 ? c - 4 : 1)) $((c < 95 ? c + 4 : 99))); do
	[ "$q" = "$c" ] || try_q "$q"
done
echo "# JPEG of equal PSNR: Q $best_q, $best_p dB (cjpeg -optimize, 4:2:0, the whole image)"
mkdir "$WORK/iiif"
vips dzsave "$WORK/src.png" "$WORK/iiif/$id" --layout iiif3 --tile-size 512 --overlap 0 \
	--suffix ".jpg[Q=$best_q,optimize-coding,subsample-mode=on]" --id "http://127.0.0.1" >/dev/null
echo "# IIIF tiles: $(find "$WORK/iiif/$id" -name '*.jpg' | wc -l) JPEG files, $(find "$WORK/iiif/$id" -name '*.jpg' -printf '%s\n' | awk '{ s += $1 } END { print s }') bytes"

# The native viewer, when this gigaview has its window (SDL2).
native=()
if [ "${NATIVE:-1}" = 0 ]; then
	echo "# native viewer: left out (NATIVE=0)"
elif "$GV" view --help >/dev/null 2>&1; then
	native=(--gigaview "$GV" --access-log "$WORK/access.log")
else
	echo "# native viewer: left out ($("$GV" view --help 2>&1 | head -n 1))"
fi
start_browser_gigaviewd "$GVD" "$WORK" "$WORK/access.log"
node "$BENCH_DIR/browser-bytes.mjs" --base "http://127.0.0.1:$GVD_PORT" --id "$id" \
	--iiif "$WORK/iiif/$id" --size "${SIZE:-1280x800}" "${native[@]}"
