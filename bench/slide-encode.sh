#!/usr/bin/env bash
# slide-encode.sh - a whole-slide image into gigaview against the pyramid
# a pathology service builds with libvips: `vips dzsave` reading the same
# slide through OpenSlide, at equal level-0 PSNR, in the same run.
#
#   bench/slide-encode.sh [--gigaview PATH]
#
# The slide: tests/make_slide's Aperio-like tiled TIFF pyramid (stained-
# tissue-like blobs with fine noise, JPEG tiles, 0.25 um/px, 40x),
# SIZE (default 8192x6144) at level 0.  The reference is the slide's level 0
# as OpenSlide reads it (`vips openslideload`, flattened on white): what
# both tools encode.
#   measured: gigaview encode SLIDE -q Q -o S.gv (Q in QS, default "36 40")
#   anchor:   vips dzsave SLIDE OUT.zip --container zip --suffix .jpg[Q=J],
#             at the two JPEG qualities J whose level-0 PSNR brackets the
#             store's (found on the reference saved as one JPEG at J, which
#             is what each 254-pixel dzsave tile gets, up to tile edges)
# PSNR over RGB against the reference (bench/imgcompare.c).  It prints wall
# time (best of REPS, default 2), bytes (the store; the .zip of every
# dzsave level) and gigaview / vips as ratios.  Asserts nothing.  The
# first-view time of a viewer is measured by bench/slide-first-view.sh
# (bench/browser-bytes.sh measures the bytes a viewer moves).
set -euo pipefail
. "$(dirname "$0")/lib.sh"
gv_arg=
if [ "${1:-}" = --gigaview ]; then gv_arg=$2; shift 2; fi
GV=$(find_gigaview "$gv_arg")
need_cmd vips libvips-tools
SIZE=${SIZE:-8192x6144}
QS=${QS:-"36 40"}
REPS=${REPS:-2}
build=$(dirname "$GV")
make -s -C "$build" tests/make_slide >&2
W=$(mktemp -d "${TMPDIR:-/tmp}/gv-slide.XXXXXX")
trap 'rm -rf "$W"' EXIT
GV=$(snapshot_gigaview "$GV" "$W")
CMP=$(build_imgcompare "$W")
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"
echo "# $(vips --version)"
"$build/tests/make_slide" "$W/slide.svs" "${SIZE%x*}" "${SIZE#*x}" jpeg 0.25 40
vips openslideload "$W/slide.svs" "$W/ref4.v"
vips flatten "$W/ref4.v" "$W/ref.v" --background "255 255 255"
vips copy "$W/ref.v" "$W/ref.ppm"
echo "# slide: $SIZE, $(stat -c %s "$W/slide.svs") bytes (JPEG tiles); reference: OpenSlide's level 0"

# psnr_of PPM: its PSNR against the reference.
psnr_of() { "$CMP" "$W/ref.ppm" "$1" | sed -n 's/.*psnr=\([0-9.]*\).*/\1/p'; }
# jpeg_psnr J: the reference as one JPEG at quality J, its PSNR.
jpeg_psnr() {
	vips copy "$W/ref.v" "$W/j.jpg[Q=$1]"
	vips copy "$W/j.jpg" "$W/j.ppm"
	psnr_of "$W/j.ppm"
}

printf '%-4s %-9s %8s %12s %8s %8s %8s\n' q tool psnr bytes wall_s bytes/vips time/vips
for Q in $QS; do
	gt=$(best_wall "$REPS" : "$GV" encode --quiet -q "$Q" "$W/slide.svs" -o "$W/s.gv")
	"$GV" export "$W/s.gv" -o "$W/s.png" >/dev/null
	vips copy "$W/s.png" "$W/s.ppm"
	gp=$(psnr_of "$W/s.ppm")
	gb=$(stat -c %s "$W/s.gv")
	# The JPEG quality of equal PSNR: bisection on 10 .. 98.
	lo=10 hi=98
	while [ $((hi - lo)) -gt 1 ]; do
		mid=$(((lo + hi) / 2))
		if [ "$(echo "$(jpeg_psnr "$mid") < $gp" | bc)" = 1 ]; then lo=$mid; else hi=$mid; fi
	done
	printf '%-4s %-9s %8s %12d %8.2f\n' "$Q" gigaview "$gp" "$gb" "$gt"
	# The two qualities around it: the JPEG steps are coarse up there.
	for J in "$lo" "$hi"; do
		jp=$(jpeg_psnr "$J")
		rm -f "$W/d.zip"
		vt=$(best_wall "$REPS" : vips dzsave "$W/slide.svs" "$W/d.zip" --container zip --suffix ".jpg[Q=$J]")
		vb=$(stat -c %s "$W/d.zip")
		printf '%-4s %-9s %8s %12d %8.2f %8.3f %8.3f\n' "$Q" "dzsave-Q$J" "$jp" "$vb" "$vt" \
			"$(echo "$gb / $vb" | bc -l)" "$(echo "$gt / $vt" | bc -l)"
	done
done
