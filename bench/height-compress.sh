#!/usr/bin/env bash
# height-compress.sh - bytes of a height store against GDAL's GeoTIFF
# compressors on the same DEM at the same maximum error (docs/FORMAT.md
# section 12; the height stores' compression anchors).
#
#   bench/height-compress.sh [--gigaview PATH] [DEM.png]
#
# Default input: ETOPO5 (shared/data/elevation/etopo5-4320x2161-u16.png,
# metres + 11000).  For E = 0, 0.5 and 2 m it writes
#   - a gigaview height store (`encode --height --max-error E`): the whole
#     pyramid, every level within E of its box-filtered exact heights;
#   - GeoTIFF COMPRESS=LERC_ZSTD MAX_Z_ERROR=E (256x256 tiles): level 0
#     only, as LERC tiles hold one level, and with overviews (gdaladdo -r
#     average, 2 4 8 16, LERC_ZSTD with MAX_Z_ERROR_OVERVIEW=E);
#   - at E = 0, GeoTIFF COMPRESS=DEFLATE PREDICTOR=2 ZLEVEL=9, likewise.
# and prints the bytes and gigaview / anchor as a ratio (below 1: gigaview
# is smaller), plus LERC's measured maximum error on level 0 (oiiotool).
# PLOT=FILE.png also draws the bytes as bars (gnuplot).  Needs gdal-bin
# and openimageio-tools; asserts nothing.
set -euo pipefail
. "$(dirname "$0")/lib.sh"
gv_arg=
if [ "${1:-}" = --gigaview ]; then gv_arg=$2; shift 2; fi
GV=$(find_gigaview "$gv_arg")
need_cmd gdal_translate gdal-bin
need_cmd oiiotool openimageio-tools
DEM=${1:-$DATA_DIR/elevation/etopo5-4320x2161-u16.png}
[ -f "$DEM" ] || die "no input $DEM"
W=$(mktemp -d "${TMPDIR:-/tmp}/gv-height-bench.XXXXXX")
trap 'rm -rf "$W"' EXIT
GV=$(snapshot_gigaview "$GV" "$W")
echo "# $(describe_build "$GV")"
echo "# $(machine_line)"
echo "# $(gdalinfo --version)"
echo "# input: $DEM ($(oiiotool --info "$DEM" | sed 's/.*: *//'))"
size() { stat -c %s "$1"; }
lerc() {   # lerc OUT ERROR COMPRESS [extra -co...]
	local out=$1 e=$2 c=$3
	shift 3
	gdal_translate -q -of GTiff -co TILED=YES -co COMPRESS="$c" "$@" "$DEM" "$out"
}
overviews() {   # overviews FILE COMPRESS ERROR
	cp "$1" "$1.ovr.tif"
	gdaladdo -q -r average --config COMPRESS_OVERVIEW "$2" \
		--config MAX_Z_ERROR_OVERVIEW "$3" --config PREDICTOR_OVERVIEW 2 \
		--config ZLEVEL_OVERVIEW 9 "$1.ovr.tif" 2 4 8 16
	size "$1.ovr.tif"
}
maxerr() {   # maxerr FILE: max |FILE - DEM| in codes (metres here)
	oiiotool "$DEM" "$1" --diff 2>/dev/null |
		awk '/Max error/ { m = $4 * 65535 } END { printf "%.2f", m }'
}
printf '%-6s %12s %12s %8s %14s %8s %10s %s\n' "E" "gigaview" "LERC L0" "ratio" \
	"LERC pyramid" "ratio" "LERC err" "(gigaview: whole pyramid, bound from the header)"
for E in 0 0.5 2; do
	"$GV" encode --quiet --height --offset -11000 --unit m --max-error "$E" "$DEM" \
		-o "$W/g.gv"
	g=$(size "$W/g.gv")
	bound=$("$GV" info "$W/g.gv" | sed -n 's/^max error *//p')
	lerc "$W/l.tif" "$E" LERC_ZSTD -co MAX_Z_ERROR="$E"
	l=$(size "$W/l.tif")
	lo=$(overviews "$W/l.tif" LERC_ZSTD "$E")
	echo "$E $g $l $lo" >>"$W/plot.dat"
	printf '%-6s %12d %12d %8.3f %14d %8.3f %10s %s\n' "$E" "$g" "$l" \
		"$(echo "$g / $l" | bc -l)" "$lo" "$(echo "$g / $lo" | bc -l)" \
		"$(maxerr "$W/l.tif")" "bound $bound"
	if [ "$E" = 0 ]; then
		lerc "$W/d.tif" 0 DEFLATE -co PREDICTOR=2 -co ZLEVEL=9
		d=$(size "$W/d.tif")
		do=$(overviews "$W/d.tif" DEFLATE 0)
		printf '%-6s %12d %12d %8.3f %14d %8.3f %10s %s\n' "0" "$g" "$d" \
			"$(echo "$g / $d" | bc -l)" "$do" "$(echo "$g / $do" | bc -l)" \
			"$(maxerr "$W/d.tif")" "anchor: DEFLATE PREDICTOR=2 ZLEVEL=9"
	fi
done
if [ -n "${PLOT:-}" ]; then
	need_cmd gnuplot gnuplot-nox
	gnuplot <<EOF2
set terminal pngcairo size 800,450
set output "$PLOT"
set title "ETOPO5 4320x2161: bytes at maximum error E (whole pyramid unless L0)"
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set ylabel "MB"
set xlabel "E (metres)"
set key top right
set yrange [0:*]
plot "$W/plot.dat" using (\$2/1e6):xtic(1) title "gigaview (pyramid)", \
     "" using (\$3/1e6) title "LERC-ZSTD level 0", \
     "" using (\$4/1e6) title "LERC-ZSTD + overviews"
EOF2
	echo "# plot: $PLOT"
fi
