#!/bin/sh
# install-deps.sh [--bench] [--print] - install the Debian 12 packages
# gigaview builds, tests and runs with.  Installs only what is missing;
# needs root (or sudo).
#   --bench  also what the benchmarks (bench/) and the conf/ examples run:
#            the anchors they measure against and their load generators
#   --print  print the missing packages, one a line, and install nothing
set -eu

PACKAGES="build-essential autoconf automake libtool pkg-config
  libmicrohttpd-dev libopenimageio-dev openimageio-tools libjansson-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri zlib1g-dev libwebp-dev
  libcurl4-openssl-dev libsdl2-dev time valgrind python3
  chromium nodejs"
# gdaldem, the anchor of tests/test_filter_elevation (skipped without it)
# and bench/elevation-filters.sh.
PACKAGES="$PACKAGES gdal-bin"
# Xvfb and weston: tests/client_view_wsi.sh runs the native viewer on X11
# and on Wayland (weston nested in Xvfb), not only SDL's offscreen driver.
PACKAGES="$PACKAGES xvfb weston"
# libjpeg-turbo and libpng: the native JPEG and PNG readers (lib/imageio).
PACKAGES="$PACKAGES libjpeg62-turbo-dev libpng-dev"
# libtiff: the native TIFF reader (lib/imageio); its tools (tiffcp) make
# tests/data/native's TIFF variants.
PACKAGES="$PACKAGES libtiff-dev libtiff-tools"
# OpenSlide and GDAL: whole-slide images and georeferenced rasters in
# (lib/imageio, optional at configure); openslide-tools and gdal-bin read
# the generated slide and GeoTIFF of tests/input_slide_geo.sh.
PACKAGES="$PACKAGES libopenslide-dev openslide-tools libgdal-dev"

# bench/*.sh and conf/: nginx (http-tiles, http-iiif), wrk, curl and jq
# (http-*), iipsrv behind spawn-fcgi (http-iiif), vips (encode-speed,
# rate-distortion, browser-bytes, http-iiif), cjpeg/djpeg and cwebp/dwebp
# (rate-distortion, browser-bytes), astcenc (rate-distortion), OpenCV and
# SciPy (edt-speed), GNU parallel (conf/parallel-encode.sh), gnuplot (the
# plots of tin-speed and others).
BENCH_PACKAGES="nginx-light wrk curl jq iipimage-server spawn-fcgi
  libvips-tools libjpeg-turbo-progs webp astcenc
  python3-opencv python3-scipy parallel gnuplot-nox"
# bench/simplify-speed.sh (mesh simplification)
BENCH_PACKAGES="$BENCH_PACKAGES libmeshoptimizer-dev python3-open3d assimp-testmodels"

bench=0 print=0
for arg in "$@"; do
    case $arg in
    --bench) bench=1 ;;
    --print) print=1 ;;
    *) echo "usage: install-deps.sh [--bench] [--print]" >&2; exit 2 ;;
    esac
done
wanted=$PACKAGES
[ "$bench" = 1 ] && wanted="$wanted $BENCH_PACKAGES"

missing=""
for p in $wanted; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
        missing="$missing $p"
done
# nginx-light provides nginx: a machine with another nginx flavour
# (nginx, nginx-full) has what the benchmarks run.
case " $missing " in
*" nginx-light "*)
    command -v nginx >/dev/null 2>&1 &&
        missing=$(echo "$missing" | sed 's/ nginx-light//') ;;
esac
# npm for the browser test (tests/browser): Debian's nodejs comes without
# it, but a nodejs that bundles its own (NodeSource's) conflicts with
# Debian's npm package, so ask for it only when there is no npm at all.
command -v npm >/dev/null 2>&1 || missing="$missing npm"
if [ "$print" = 1 ]; then
    for p in $missing; do echo "$p"; done
    exit 0
fi
[ -z "$missing" ] && exit 0

SUDO=""
if [ "$(id -u)" != 0 ]; then
    command -v sudo >/dev/null 2>&1 || {
        echo "install-deps: need root or sudo to install:$missing" >&2
        exit 1
    }
    SUDO=sudo
fi
echo "install-deps: installing$missing"
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
# shellcheck disable=SC2086
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $missing
