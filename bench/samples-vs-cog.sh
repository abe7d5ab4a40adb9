#!/usr/bin/env bash
# samples-vs-cog.sh - bytes and encode time of a sample store (`gigaview
# encode --bits 16 --max-error E`, docs/FORMAT.md section 13) against
# GDAL's cloud-optimized GeoTIFF of the same 16-bit raster at the same
# maximum error, in the same run.
#
#   bench/samples-vs-cog.sh [--gigaview PATH]
#
# Inputs (../shared/data, real 16-bit data):
#   etopo5   elevation/etopo5-4320x2161-u16.png, one 16-bit channel;
#   golden   hdr/GoldenGate.exr (half-float RGB, 1262 x 860) as a 16-bit
#            sRGB-encoded RGB TIFF (oiiotool --colorconvert linear sRGB
#            -d uint16): a 16-bit photograph of three channels.
# Anchors, each with its overviews (average, 2 x 2, as ours), every
# overview within E as well:
#   lerc     gdal_translate -of COG -co COMPRESS=LERC_ZSTD -co MAX_Z_ERROR=E
#            -co OVERVIEWS=AUTO -co RESAMPLING=AVERAGE
#   zstd     (E = 0 only) -co COMPRESS=ZSTD -co PREDICTOR=2 -co LEVEL=19,
#            the lossless choice a user would make
# For E in ERRORS (default "0 4 32") it prints bytes, encode wall time
# and the largest level-0 error measured here (both must be <= E), and
# gigaview / anchor as ratios (below 1: gigaview is smaller / faster).
# Then, for Q in QS (default "45 50 60 70"), `--bits 16 -q Q` on each
# input: the PSNR reached (the summary's, over the full 16-bit range), the
# e the trial chose and the uniform rule's, and the bytes.  Asserts
# nothing.
set -euo pipefail
. "$(dirname "$0")/lib.sh"
gv_arg=
if [ "${1:-}" = --gigaview ]; then gv_arg=$2; shift 2; fi
GV=$(find_gigaview "$gv_arg")
need_cmd gdal_translate gdal-bin
need_cmd oiiotool openimageio-tools
DATA=${DATA:-$(cd "$(dirname "$0")/../../shared/data" && pwd)}
ERRORS=${ERRORS:-"0 4 32"}
W=$(mktemp -d "${TMPDIR:-/tmp}/gv-samples-cog.XXXXXX")
trap 'rm -rf "$W"' EXIT
GV=$(snapshot_gigaview "$GV" "$W")
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"
echo "# $(gdalinfo --version)"

cp "$DATA/elevation/etopo5-4320x2161-u16.png" "$W/etopo5.png"
oiiotool "$DATA/hdr/GoldenGate.exr" --ch R,G,B --colorconvert linear sRGB \
	-d uint16 -o "$W/golden.tif"

# toraw IN OUT: the samples of IN, pixel-interleaved u16.
toraw() { gdal_translate -q -of ENVI -co INTERLEAVE=BIP "$1" "$2" >/dev/null; }
# maxerr A B: the largest difference of two raw u16 files.
maxerr() {
	python3 - "$1" "$2" <<'PY'
import array, sys
a = array.array('H', open(sys.argv[1], 'rb').read())
b = array.array('H', open(sys.argv[2], 'rb').read())
assert len(a) == len(b)
print(max(abs(x - y) for x, y in zip(a, b)))
PY
}
# timed CMD...: wall seconds of CMD.
timed() {
	local t0 t1
	t0=$(date +%s.%N)
	"$@" >/dev/null 2>"$W/err" || { cat "$W/err" >&2; die "failed: $*"; }
	t1=$(date +%s.%N)
	echo "$t1 - $t0" | bc -l
}

printf '%-7s %-3s %-9s %12s %8s %7s %8s %8s\n' input E tool bytes wall_s maxerr bytes/gv time/gv
for name in etopo5 golden; do
	in=$W/$name.png
	[ -e "$in" ] || in=$W/$name.tif
	toraw "$in" "$W/$name.raw"
	for E in $ERRORS; do
		gt=$(timed "$GV" encode --quiet --bits 16 --max-error "$E" "$in" -o "$W/s.gv")
		"$GV" export --bits 16 "$W/s.gv" -o "$W/s.tif" >/dev/null
		toraw "$W/s.tif" "$W/s.raw"
		gb=$(stat -c %s "$W/s.gv")
		ge=$(maxerr "$W/$name.raw" "$W/s.raw")
		printf '%-7s %-3s %-9s %12d %8.2f %7s\n' "$name" "$E" gigaview "$gb" "$gt" "$ge"
		anchors="lerc"
		[ "$E" = 0 ] && anchors="lerc zstd"
		for a in $anchors; do
			rm -f "$W/c.tif"
			if [ "$a" = lerc ]; then
				at=$(timed gdal_translate -q -of COG -co COMPRESS=LERC_ZSTD \
					-co MAX_Z_ERROR="$E" -co OVERVIEWS=AUTO -co RESAMPLING=AVERAGE \
					"$in" "$W/c.tif")
			else
				at=$(timed gdal_translate -q -of COG -co COMPRESS=ZSTD \
					-co PREDICTOR=2 -co LEVEL=19 -co OVERVIEWS=AUTO \
					-co RESAMPLING=AVERAGE "$in" "$W/c.tif")
			fi
			toraw "$W/c.tif" "$W/c.raw"
			ab=$(stat -c %s "$W/c.tif")
			ae=$(maxerr "$W/$name.raw" "$W/c.raw")
			printf '%-7s %-3s %-9s %12d %8.2f %7s %8.3f %8.3f\n' "$name" "$E" "cog-$a" \
				"$ab" "$at" "$ae" "$(echo "$gb / $ab" | bc -l)" "$(echo "$gt / $at" | bc -l)"
		done
	done
done

QS=${QS:-"45 50 60 70"}
echo
printf '%-7s %4s %9s %7s %9s %10s\n' input q reached e uniform_e bytes
for name in etopo5 golden; do
	in=$W/$name.png
	[ -e "$in" ] || in=$W/$name.tif
	for Q in $QS; do
		"$GV" encode --bits 16 -q "$Q" "$in" -o "$W/q.gv" >"$W/sum"
		awk -v n="$name" -v q="$Q" -v b="$(stat -c %s "$W/q.gv")" '
			/^psnr/ { p = $2 }
			/^trial/ { e = $4; u = $NF; sub(/\)/, "", u) }
			END { printf "%-7s %4s %9s %7s %9s %10d\n", n, q, p, e, u, b }' "$W/sum"
	done
done
