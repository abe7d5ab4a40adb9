#!/bin/bash
# slide-first-view.sh: how long a pathologist waits for the first complete
# view of a whole-slide image in the browser, the gigaview viewer against
# what a pathology service would serve: OpenSeadragon on a static IIIF
# JPEG pyramid that `vips dzsave` built from the same slide through
# OpenSlide, at equal level-0 PSNR, in the same run; and what each costs
# to build first (bench/slide-first-view.mjs says exactly what is timed).
#
#   bench/slide-first-view.sh [--gigaview PATH] [--gigaviewd PATH]
#
# The slide: tests/make_slide's Aperio-like tiled TIFF pyramid (JPEG
# tiles, 0.25 um/px, 40x; built with `make -C BUILD tests/make_slide`,
# BUILD being the gigaview binary's directory), SIZE_SLIDE at level 0.  The
# reference is its level 0 as OpenSlide reads it (`vips openslideload`,
# flattened on white), as in bench/slide-encode.sh.
#   measured: gigaview encode SLIDE -o slide.gv ($GV_ARGS, default none:
#             the encoder's defaults), served by gigaviewd, shown by the
#             browser viewer gigaviewd serves at /
#   anchor:   vips dzsave SLIDE DIR --layout iiif3 --tile-size 512
#             --overlap 0 --suffix .jpg[Q=J,optimize-coding], served as
#             static files, shown by OpenSeadragon (tests/browser/node_modules)
# J is the JPEG quality whose PSNR (the reference saved as one JPEG, vips'
# default chroma subsampling, as the tiles get it) is closest to the
# store's level-0 PSNR (bisection on 10..98, then the nearer neighbour;
# JPEG_Q=J forces it); the pyramid's own level 0, joined from its tiles,
# is measured too.  PSNR over RGB with bench/imgcompare.c.  Build times
# are wall clock, best of BUILD_REPS, each tool reading the .svs itself.
# Then, in headless Chromium (Debian's /usr/bin/chromium, playwright-core
# from tests/browser/node_modules; WebGL2 on SwiftShader, Chrome's CPU
# renderer, unless GPU=host) the time to the first complete view of the
# whole slide and of level 0 1:1 at its centre, from the navigation
# start, median of REPS; and the image bytes received by then.  Nothing is
# asserted: the script only reports.
#
# Environment:
#   GIGAVIEW, GIGAVIEWD  binaries (default: next to bench/, or on PATH)
#   SIZE_SLIDE=WxH  the slide's level 0 (default 8192x6144)
#   SIZE=WxH        browser viewport (default 1280x800)
#   REPS=N          browser runs per view and viewer (default 3), median
#   BUILD_REPS=N    runs of each build (default 2), best
#   GV_ARGS         gigaview encode options (default none)
#   JPEG_Q=J        the dzsave JPEG quality, instead of the equal-PSNR one
#   GPU=host        the machine's GPU instead of SwiftShader
#   TMPDIR=DIR      scratch space (default /tmp; about 1 GB at the default size)
# Needs vips (with OpenSlide), cc, node, chromium; 2 to 3 minutes on 2 cores.
set -euo pipefail

# shellcheck source=SCRIPTDIR/http-lib.sh disable=SC1091
. "$(dirname "${BASH_SOURCE[0]}")/http-lib.sh"

bench_args "$@"
bench_no_inputs
SIZE_SLIDE=${SIZE_SLIDE:-8192x6144}
SIZE=${SIZE:-1280x800}
REPS=${REPS:-3}
BUILD_REPS=${BUILD_REPS:-2}
GV_ARGS=${GV_ARGS:-}
[ -x /usr/bin/chromium ] || die "no /usr/bin/chromium (apt-get install chromium)"
for m in openseadragon playwright-core; do
	[ -d "$BENCH_DIR/../tests/browser/node_modules/$m" ] || die "no $m: cd tests/browser && npm ci"
done
command -v node >/dev/null 2>&1 || die "no node (apt-get install nodejs)"
need_cmd vips libvips-tools
need_cmd bc bc

GV=$(find_gigaview "$gv_arg")
GVD=$(find_gigaviewd "$gvd_arg")
build=$(dirname "$GV")
make -s -C "$build" tests/make_slide >&2 || die "cannot build $build/tests/make_slide"
WORK=$(mktemp -d "${TMPDIR:-/tmp}/gv-slide-view.XXXXXX")
trap 'http_cleanup; rm -rf "$WORK"' EXIT
# Copies, so that a rebuild during the run cannot change them half-way.
GV=$(snapshot_gigaview "$GV" "$WORK")
cp "$GVD" "$WORK/gigaviewd"
cp "$build/tests/make_slide" "$WORK/make_slide"
CMP=$(build_imgcompare "$WORK")
echo "# $(describe_build "$GV")"
echo "# $(machine_line); load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "# $(vips --version); chromium: $(/usr/bin/chromium --version 2>/dev/null | head -1);" \
	"openseadragon $(sed -n 's/^ *"version": "\(.*\)",*$/\1/p' \
	"$BENCH_DIR/../tests/browser/node_modules/openseadragon/package.json" | head -1)"

id=slide
"$WORK/make_slide" "$WORK/$id.svs" "${SIZE_SLIDE%x*}" "${SIZE_SLIDE#*x}" jpeg 0.25 40 >/dev/null
vips openslideload "$WORK/$id.svs" "$WORK/ref4.v"
vips flatten "$WORK/ref4.v" "$WORK/ref.v" --background "255 255 255"
rm -f "$WORK/ref4.v"
vips copy "$WORK/ref.v" "$WORK/ref.ppm"
echo "# slide: $SIZE_SLIDE, $(stat -c %s "$WORK/$id.svs") bytes (JPEG tiles, read by" \
	"$(vipsheader -f vips-loader "$WORK/$id.svs")); reference: OpenSlide's level 0 on white"

# fresh_iiif: an empty directory for the next dzsave (untimed).
fresh_iiif() { rm -rf "$WORK/iiif"; mkdir "$WORK/iiif"; }
psnr_of() { "$CMP" "$WORK/ref.ppm" "$1" | sed -n 's/.*psnr=\([0-9.]*\).*/\1/p'; }
# jpeg_psnr J: the reference as one JPEG at quality J, its PSNR.
jpeg_psnr() {
	vips copy "$WORK/ref.v" "$WORK/j.jpg[Q=$1,optimize-coding]"
	vips copy "$WORK/j.jpg" "$WORK/j.ppm"
	psnr_of "$WORK/j.ppm"
}

# The store.
mkdir "$WORK/stores"
# shellcheck disable=SC2086 # GV_ARGS is a list of options
gv_s=$(best_wall "$BUILD_REPS" : "$GV" encode --quiet $GV_ARGS "$WORK/$id.svs" -o "$WORK/stores/$id.gv")
"$GV" export "$WORK/stores/$id.gv" -o "$WORK/gv0.tif" >/dev/null
vips copy "$WORK/gv0.tif" "$WORK/gv0.ppm"
gv_psnr=$(psnr_of "$WORK/gv0.ppm")
rm -f "$WORK/gv0.tif" "$WORK/gv0.ppm"
gv_bytes=$(stat -c %s "$WORK/stores/$id.gv")

# The JPEG quality of equal PSNR.
if [ -n "${JPEG_Q:-}" ]; then
	J=$JPEG_Q
	jq_note="forced by JPEG_Q"
else
	lo=10 hi=98
	while [ $((hi - lo)) -gt 1 ]; do
		mid=$(((lo + hi) / 2))
		if [ "$(echo "$(jpeg_psnr "$mid") < $gv_psnr" | bc)" = 1 ]; then lo=$mid; else hi=$mid; fi
	done
	plo=$(jpeg_psnr "$lo") phi=$(jpeg_psnr "$hi")
	if [ "$(echo "$gv_psnr - $plo <= $phi - $gv_psnr" | bc)" = 1 ]; then J=$lo; else J=$hi; fi
	jq_note="the nearer of Q$lo ($plo dB) and Q$hi ($phi dB) to the store's $gv_psnr dB"
fi
rm -f "$WORK/j.jpg" "$WORK/j.ppm"

# The IIIF pyramid.
vt_s=$(best_wall "$BUILD_REPS" fresh_iiif vips dzsave "$WORK/$id.svs" "$WORK/iiif/$id" --layout iiif3 --tile-size 512 --overlap 0 \
	--suffix ".jpg[Q=$J,optimize-coding]" --id "http://127.0.0.1")
iiif_files=$(find "$WORK/iiif/$id" -name '*.jpg' | wc -l)
iiif_bytes=$(find "$WORK/iiif/$id" -type f -printf '%s\n' | awk '{ s += $1 } END { print s }')
# Its level 0: the tiles whose size is their region's, joined row by row.
(
	cd "$WORK/iiif/$id"
	for d in */; do
		IFS=, read -r x y w h <<<"${d%/}"
		[ -f "$d$w,$h/0/default.jpg" ] && echo "$y $x $d$w,$h/0/default.jpg"
	done
) | sort -n -k1,1 -k2,2 | awk '{ print $3 }' >"$WORK/l0.txt"
across=$(awk -F'[,/]' '$2 == 0' "$WORK/l0.txt" | wc -l)
(cd "$WORK/iiif/$id" && vips arrayjoin "$(tr '\n' ' ' <"$WORK/l0.txt")" "$WORK/l0.ppm" --across "$across")
iiif_psnr=$(psnr_of "$WORK/l0.ppm")
rm -f "$WORK/l0.ppm" "$WORK/ref.ppm" "$WORK/ref.v"

echo "# JPEG quality: Q$J, $jq_note"
echo
echo "build from the slide (wall clock, best of $BUILD_REPS), level-0 PSNR against OpenSlide's level 0:"
printf '%-44s %8s %9s %14s\n' what psnr_dB wall_s bytes
printf '%-44s %8s %9.2f %14d\n' "gigaview encode ${GV_ARGS:-(defaults)}" "$gv_psnr" "$gv_s" "$gv_bytes"
printf '%-44s %8s %9.2f %14d\n' "vips dzsave iiif3 512 Q$J ($iiif_files tiles)" "$iiif_psnr" "$vt_s" "$iiif_bytes"
awk -v g="$gv_s" -v v="$vt_s" 'BEGIN { r = g / v
	printf "RESULT build: gigaview encode %.2f s, vips dzsave %.2f s; gigaview/dzsave %.2f (gigaview %.2fx %s)\n",
		g, v, r, (r <= 1 ? 1 / r : r), (r <= 1 ? "faster" : "slower") }'
echo

start_browser_gigaviewd "$WORK/gigaviewd" "$WORK"
echo "# gigaviewd on port $GVD_PORT; REPS=$REPS SIZE=$SIZE GPU=${GPU:-swiftshader};" \
	"load average $(cut -d' ' -f1-3 /proc/loadavg)"
node "$BENCH_DIR/slide-first-view.mjs" --base "http://127.0.0.1:$GVD_PORT" --id "$id" \
	--iiif "$WORK/iiif/$id" --reps "$REPS" --size "$SIZE" \
	--gpu "$(browser_gpu)"
