#!/bin/sh
# make-variants.sh - regenerates the JPEG and PNG variants in this folder
# (tests/test_native_read.c reads each with the native readers and with
# the OpenImageIO module and compares).  Run from the repository root;
# needs vips (libvips-tools), cjpeg and jpegtran (libjpeg-turbo-progs) and
# python3.  The pixels are a 61x45 crop of tests/data/seeding-700x520.png.
set -eu
out=tests/data/native
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
vips crop tests/data/seeding-700x520.png "$t/crop.ppm" 100 100 61 45
vips colourspace "$t/crop.ppm" "$t/gray.pgm" b-w
# JPEG: chroma subsampling, progressive, restart intervals, arithmetic
# coding, gray, RGB (no colour transform), and CMYK (declined).
cjpeg -quality 85 -sample 2x2 "$t/crop.ppm" >"$out/s420.jpg"
cjpeg -quality 85 -sample 2x1 "$t/crop.ppm" >"$out/s422.jpg"
cjpeg -quality 85 -sample 1x2 "$t/crop.ppm" >"$out/s440.jpg"
cjpeg -quality 85 -sample 1x1 "$t/crop.ppm" >"$out/s444.jpg"
cjpeg -quality 85 -progressive "$t/crop.ppm" >"$out/progressive.jpg"
cjpeg -quality 85 -restart 1 "$t/crop.ppm" >"$out/restart.jpg"
cjpeg -quality 85 -arithmetic "$t/crop.ppm" >"$out/arithmetic.jpg"
cjpeg -quality 85 -optimize "$t/gray.pgm" >"$out/gray.jpg"
cjpeg -quality 85 -progressive "$t/gray.pgm" >"$out/gray-progressive.jpg"
cjpeg -quality 95 -rgb "$t/crop.ppm" >"$out/rgb.jpg"
vips colourspace "$t/crop.ppm" "$t/cmyk.v" cmyk
vips jpegsave "$t/cmyk.v" "$out/cmyk.jpg" --Q 85 --strip
python3 "$out/make-variants.py" "$t/crop.ppm" "$out"
