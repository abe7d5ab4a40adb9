#!/bin/sh
# make-variants.sh - regenerates the JPEG, PNG and TIFF variants in this
# folder (tests/test_native_read.c reads each with the native readers and
# with the OpenImageIO module and compares).  Run from the repository root;
# needs vips (libvips-tools), cjpeg and jpegtran (libjpeg-turbo-progs),
# ppm2tiff, tiffcp, tiffmedian and tiffset (libtiff-tools) and python3.
# The pixels are a 61x45 crop of tests/data/seeding-700x520.png (the
# TIFFs: a 37x29 one).
set -eu
out=tests/data/native
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
vips crop tests/data/seeding-700x520.png "$t/crop.ppm" 100 100 61 45
vips colourspace "$t/crop.ppm" "$t/gray.pgm" b-w
# JPEG: chroma subsampling, progressive, restart intervals, arithmetic
# coding, gray, RGB (no colour transform), multi-scan sequential, and CMYK
# (declined).
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
# sequential, one scan per component: held whole, like a progressive one
printf '0;\n1;\n2;\n' >"$t/scans"
cjpeg -quality 85 -scans "$t/scans" "$t/crop.ppm" >"$out/multiscan.jpg"
vips colourspace "$t/crop.ppm" "$t/cmyk.v" cmyk
vips jpegsave "$t/cmyk.v" "$out/cmyk.jpg" --Q 85 --strip
python3 "$out/make-variants.py" "$t/crop.ppm" "$out"
# TIFF (native_tiff.c): a 37x29 crop, in strips and in 16x16 tiles (the
# last column and row of tiles partial), uncompressed, LZW, deflate with
# and without the horizontal predictor, PackBits; big-endian, BigTIFF;
# RGB and grey, 8 and 16 bits.  Declined by the native reader (the module
# reads them): alpha, palette, MINISWHITE, JPEG-compressed.  Needs
# libtiff-tools (tiffcp, tiffmedian, tiffset).
vips crop tests/data/seeding-700x520.png "$t/t.ppm" 200 150 37 29
vips colourspace "$t/t.ppm" "$t/tg.pgm" b-w
ppm2tiff "$t/t.ppm" "$t/rgb8.tif"
ppm2tiff "$t/tg.pgm" "$t/gray8.tif"
vips linear "$t/t.ppm" "$t/rgb16.v" 257 3
vips cast "$t/rgb16.v" "$t/rgb16c.v" ushort
vips tiffsave "$t/rgb16c.v" "$t/rgb16.tif" --strip
vips linear "$t/tg.pgm" "$t/gray16.v" 257 1
vips cast "$t/gray16.v" "$t/gray16c.v" ushort
vips tiffsave "$t/gray16c.v" "$t/gray16.tif" --strip
vips bandjoin_const "$t/t.ppm" "$t/rgba.v" 200
vips tiffsave "$t/rgba.v" "$t/rgba8.tif" --strip
tiffcp -c none -r 5 "$t/rgb8.tif" "$out/rgb8-none-strips.tif"
tiffcp -c lzw -t -w 16 -l 16 "$t/rgb8.tif" "$out/rgb8-lzw-tiled.tif"
tiffcp -c zip:2 -r 7 "$t/rgb8.tif" "$out/rgb8-zip-pred.tif"
tiffcp -c packbits -t -w 16 -l 16 "$t/rgb8.tif" "$out/rgb8-packbits-tiled.tif"
tiffcp -B -c lzw:2 -r 4 "$t/rgb8.tif" "$out/rgb8-be-lzw-pred.tif"
tiffcp -8 -B -c none -t -w 16 -l 32 "$t/rgb8.tif" "$out/rgb8-bigtiff-be-tiled.tif"
tiffcp -c none -r 64 "$t/gray8.tif" "$out/gray8-none.tif"
tiffcp -c packbits -t -w 32 -l 16 "$t/gray8.tif" "$out/gray8-packbits-tiled.tif"
tiffcp -c zip -r 3 "$t/rgb16.tif" "$out/rgb16-zip.tif"
tiffcp -B -c lzw:2 -t -w 16 -l 16 "$t/rgb16.tif" "$out/rgb16-be-lzw-tiled.tif"
tiffcp -c none -r 8 "$t/gray16.tif" "$out/gray16-none.tif"
tiffcp -8 -c zip:2 -t -w 16 -l 16 "$t/gray16.tif" "$out/gray16-bigtiff-tiled.tif"
tiffcp -c lzw "$t/rgba8.tif" "$out/rgba8-declined.tif"
tiffmedian "$t/rgb8.tif" "$out/palette8-declined.tif"
tiffcp -c none "$t/gray8.tif" "$out/gray8-miniswhite-declined.tif"
tiffset -s 262 0 "$out/gray8-miniswhite-declined.tif"
tiffcp -c jpeg:90 -r 16 "$t/rgb8.tif" "$out/rgb8-jpeg-declined.tif"
