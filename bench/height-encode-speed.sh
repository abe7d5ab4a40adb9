#!/usr/bin/env bash
# height-encode-speed.sh - time and peak memory of `gigaview encode
# --height` against GDAL's LERC_ZSTD cloud-optimized GeoTIFF with
# overviews, on the same DEM at the same maximum error, in the same run.
#
#   bench/height-encode-speed.sh [--gigaview PATH]
#
# Input: the synth-height terrain as a mosaic of TILE x TILE 16-bit TIFF
# tiles (bench/height_tiles, built with `make bench`), SIZE x SIZE in all
# (default 16384 x 16384 in 4096 tiles: 268 M samples).  Both tools read
# the same tiles: gigaview as --mosaic, GDAL through a VRT of them
# (written here: the tiles carry no georeference).
#   anchor:   gdal_translate -of COG -co COMPRESS=LERC_ZSTD
#             -co MAX_Z_ERROR=E -co OVERVIEWS=AUTO -co RESAMPLING=AVERAGE
#             -co NUM_THREADS=$THREADS   (level 0 and every overview
#             within E; the overviews are GDAL's average, 2x2 like ours)
#   measured: gigaview encode --height --max-error E -j $THREADS --mosaic
# For E in ERRORS (default "0 2") it prints wall time, CPU time, peak RSS
# (GNU time) and output bytes of each, and gigaview / anchor as ratios
# (time below 1: gigaview is faster; RSS below 1: gigaview uses less).
# Best wall time of REPS runs (default 1), RSS the largest.  Asserts
# nothing.
#
# Environment: SIZE, TILE, ERRORS, REPS, THREADS (default: every core),
# TMPDIR (scratch: the tiles, 2 bytes a sample, and both outputs).
set -euo pipefail
. "$(dirname "$0")/lib.sh"
gv_arg=
if [ "${1:-}" = --gigaview ]; then gv_arg=$2; shift 2; fi
GV=$(find_gigaview "$gv_arg")
need_cmd gdal_translate gdal-bin
[ -x /usr/bin/time ] || die "needs GNU time (apt-get install time)"
SIZE=${SIZE:-16384}
TILE=${TILE:-4096}
ERRORS=${ERRORS:-"0 2"}
REPS=${REPS:-1}
THREADS=${THREADS:-$(nproc)}
[ $((SIZE % TILE)) -eq 0 ] || die "SIZE must be a multiple of TILE"
N=$((SIZE / TILE))
build=$(dirname "$GV")
make -s -C "$build" bench/height_tiles >&2
W=$(mktemp -d "${TMPDIR:-/tmp}/gv-height-speed.XXXXXX")
trap 'rm -rf "$W"' EXIT
GV=$(snapshot_gigaview "$GV" "$W")
echo "# $(describe_build "$GV")"
echo "# $(machine_line), $(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)"
echo "# $(gdalinfo --version)"
mkdir "$W/tiles"
"$build/bench/height_tiles" "$N" "$N" "$TILE" "$W/tiles"
tiles=()
for r in $(seq 0 $((N - 1))); do
	for c in $(seq 0 $((N - 1))); do
		tiles+=("$W/tiles/$(printf 't-%03d-%03d.tif' "$r" "$c")")
	done
done
# The VRT by hand: gdalbuildvrt wants georeferenced tiles.
{
	echo "<VRTDataset rasterXSize=\"$SIZE\" rasterYSize=\"$SIZE\">"
	echo '<VRTRasterBand dataType="UInt16" band="1">'
	for r in $(seq 0 $((N - 1))); do
		for c in $(seq 0 $((N - 1))); do
			echo "<SimpleSource><SourceFilename relativeToVRT=\"0\">$W/tiles/$(printf 't-%03d-%03d.tif' "$r" "$c")</SourceFilename><SourceBand>1</SourceBand>"
			echo "<SrcRect xOff=\"0\" yOff=\"0\" xSize=\"$TILE\" ySize=\"$TILE\"/><DstRect xOff=\"$((c * TILE))\" yOff=\"$((r * TILE))\" xSize=\"$TILE\" ySize=\"$TILE\"/></SimpleSource>"
		done
	done
	echo '</VRTRasterBand></VRTDataset>'
} >"$W/dem.vrt"
echo "# input: synth-height ${SIZE}x${SIZE} as ${N}x${N} 16-bit TIFF tiles of ${TILE}, $THREADS threads"

# timed OUT CMD...: run CMD, print "wall cpu rss_kib" of it.
timed() {
	local out=$1
	shift
	sync
	/usr/bin/time -f '%e %U %S %M' -o "$W/t" "$@" >/dev/null 2>"$W/err" ||
		{ cat "$W/err" >&2; die "failed: $*"; }
	rm -f "$out.keep"
	awk '{ printf "%s %.2f %s\n", $1, $2 + $3, $4 }' "$W/t"
}
printf '%-4s %-9s %9s %9s %9s %13s\n' E tool wall_s cpu_s rss_MiB bytes
for E in $ERRORS; do
	gbest= ; abest= ; grss=0 ; arss=0
	for _ in $(seq "$REPS"); do
		rm -f "$W/h.gv" "$W/c.tif"
		read -r w c m < <(timed "$W/h.gv" "$GV" encode --quiet --height \
			--max-error "$E" -j "$THREADS" --mosaic "${N}x${N}" "${tiles[@]}" -o "$W/h.gv")
		if [ -z "$gbest" ] || [ "$(echo "$w < $gbest" | bc)" = 1 ]; then gbest=$w; gcpu=$c; fi
		[ "$m" -gt "$grss" ] && grss=$m
		read -r w c m < <(timed "$W/c.tif" gdal_translate -q -of COG \
			-co COMPRESS=LERC_ZSTD -co MAX_Z_ERROR="$E" -co OVERVIEWS=AUTO \
			-co RESAMPLING=AVERAGE -co NUM_THREADS="$THREADS" \
			--config GDAL_CACHEMAX 512 "$W/dem.vrt" "$W/c.tif")
		if [ -z "$abest" ] || [ "$(echo "$w < $abest" | bc)" = 1 ]; then abest=$w; acpu=$c; fi
		[ "$m" -gt "$arss" ] && arss=$m
	done
	gb=$(stat -c %s "$W/h.gv")
	ab=$(stat -c %s "$W/c.tif")
	printf '%-4s %-9s %9s %9s %9d %13d\n' "$E" gigaview "$gbest" "$gcpu" $((grss / 1024)) "$gb"
	printf '%-4s %-9s %9s %9s %9d %13d\n' "$E" gdal-COG "$abest" "$acpu" $((arss / 1024)) "$ab"
	printf '%-4s ratio     %9.3f %9.3f %9.3f %13.3f   (gigaview / GDAL)\n' "$E" \
		"$(echo "$gbest / $abest" | bc -l)" "$(echo "$gcpu / $acpu" | bc -l)" \
		"$(echo "$grss / $arss" | bc -l)" "$(echo "$gb / $ab" | bc -l)"
done
