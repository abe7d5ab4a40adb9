#!/usr/bin/env bash
# elevation-filters.sh - the elevation stock graphs (hillshade, slope,
# aspect; docs/FILTERS.md section 8.5) on the GPU against GDAL's gdaldem on
# the same 8-bit DEM: the largest difference on every pixel off the edge,
# and the time of one run beside gdaldem's, as a ratio.  The DEM is a
# crop of shared/data/elevation/etopo5-4320x2161-u16.png (metres + 11000)
# brought to 8 bits as `gigaview encode --range LO:HI` does, LO and HI the
# crop's extremes widened to a whole number of metres per gray level.
# The work is done by tests/test_filter_elevation in its GV_ELEV_DEM mode
# (build it first: make -C build tests/test_filter_elevation); it also
# asserts the tolerances of make check (hillshade 1 LSB, slope 0.001,
# aspect 0.01 degree, flat pixels identical).
#
#   bench/elevation-filters.sh [WIDTHxHEIGHT+X+Y]   (default 2048x1024+2200+300:
#                                                   Asia, Himalaya included)
#
# Environment: BUILD (default build/), PIXEL (metres per pixel, default
# 8000: 5 arc-minutes at about 30 degrees of latitude).  Ours is
# gv_filter_run (upload, compile or cached program, run, read back) on
# the EGL context the machine has (llvmpipe here), best of 3; gdaldem is
# one process, float GeoTIFF in and out, single-threaded.  About 10 s.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/lib.sh
. "$here/lib.sh"

crop=${1:-2048x1024+2200+300}
build=${BUILD:-$top/build}
pixel=${PIXEL:-8000}
prog=$build/tests/test_filter_elevation
src=$DATA_DIR/elevation/etopo5-4320x2161-u16.png
[ -x "$prog" ] || die "$prog missing: make -C $build tests/test_filter_elevation"
[ -f "$src" ] || die "$src missing"
need_cmd gdaldem gdal-bin
[[ $crop =~ ^([0-9]+)x([0-9]+)\+([0-9]+)\+([0-9]+)$ ]] || die "crop: WIDTHxHEIGHT+X+Y"

T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
gdal_translate -q -srcwin "${BASH_REMATCH[3]}" "${BASH_REMATCH[4]}" \
	"${BASH_REMATCH[1]}" "${BASH_REMATCH[2]}" "$src" "$T/dem.png"
read -r lo hi < <(gdalinfo -mm "$T/dem.png" |
	sed -n 's/.*Computed Min\/Max=\([0-9.]*\),\([0-9.]*\).*/\1 \2/p')
# A whole number of metres per gray level.
mpl=$(awk -v lo="$lo" -v hi="$hi" 'BEGIN { m = int((hi - lo) / 255) + 1; print m }')
lo=${lo%.*}
hi=$((lo + 255 * mpl))
echo "# $src crop $crop: heights $((lo - 11000)) .. $((hi - 11000)) m as --range $lo:$hi, $mpl m per gray level, $pixel m pixels"
GV_ELEV_LABEL="etopo5 $crop" top_srcdir=$top TESTDATA=$top/tests/data GV_ELEV_DEM=$T/dem.png GV_ELEV_RANGE=$lo:$hi \
	GV_ELEV_M=$mpl GV_ELEV_PIXEL=$pixel "$prog"
