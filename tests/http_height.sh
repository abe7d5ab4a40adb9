#!/bin/sh
# http_height.sh - a height store (docs/FORMAT.md section 12) on the command
# line and over HTTP (docs/API.md):
#
#   - `gigaview encode --height` and `gigaview info` (unit, range, bound);
#   - /v1/images/{id} has the elevation object (an image store has none); tiles are served as stored
#     (mode and e in the buffer's first bytes);
#   - region format=png16 is the codes, within the bound of the input;
#     format=tiff32 the values (code * scale + offset) as floats;
#     png16 of an image store is 400;
#   - IIIF serves the gray mapping (a gray JPEG) and the root a 16-bit PNG;
#     the root as WebP is 400 (a gray image store's decodes to its raw root).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
DEM=$TESTDATA/etopo5-himalaya-1030x300-u16.png
run encode --height --unit m --offset -11000 --max-error 2 "$DEM" -o "$S/dem.gv"
expect_rc "encode --height" 0
run encode synth:600x400 -o "$S/img.gv"
expect_rc "encode an image store beside it" 0
run encode -q 40 synth:700x500:gray -o "$S/gray.gv"
expect_rc "encode a gray image store beside it" 0
run encode --max-error 2 "$DEM" -o "$S/bad.gv"
expect_rc "--max-error without --height is a usage error" 2
run info "$S/dem.gv"
expect_rc "info" 0
check "info shows the bound and the unit" grep -q '^max error    2 m (2 codes)$' "$T/out"
check "info shows the range" grep -q '^source       16-bit, range -8103 .. 3986 m$' "$T/out"
run info --json "$S/dem.gv"
check "info --json: kind, unit, bound" python3 -c "
import json,sys; j=json.load(open(sys.argv[1]))
assert j['kind']=='height' and j['unit']=='m' and j['max_error']==2 and j['offset']==-11000, j" "$T/out"

cat >"$T/h.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
gpu = off
EOF2
start_daemon "$T/h.conf"

expect_status "image info" 200 /v1/images/dem
check "image info has the elevation object" test \
    "$(json_get "j['elevation']['unit'], j['elevation']['max_error'], j['elevation']['offset'], j['elevation']['min']")" = "m 2.0 -11000.0 -8103.0"
check "... beside the image's own width and height" test \
    "$(json_get "j['width'], j['height']")" = "1030 300"
expect_status "an image store's info" 200 /v1/images/img
check "an image store has no elevation object" test "$(json_get "'elevation' in j")" = False

expect_status "a tile as stored" 200 /v1/images/dem/tiles/0/1/0
check "the tile is a coded height buffer with e = 2" python3 -c "
import sys; b=open(sys.argv[1],'rb').read()
assert b[0]==1 and b[1]==0 and b[2]|b[3]<<8==2 and len(b)%4==0, b[:8]" "$T/b"

expect_status "region png16" 200 '/v1/images/dem/region?level=0&x=500&y=100&w=300&h=150&format=png16'
check "png16: image/png" test "$(header Content-Type)" = image/png
cp "$T/b" r16.png
check "png16 is one 16-bit channel" sh -c "oiiotool --info -v r16.png | grep -q '1 channel, uint16 png'"
oiiotool "$DEM" --cut 300x150+500+100 --origin +0+0 --fullpixels -o want.png
# 2 codes of 65535, and a margin for the float arithmetic of --diff.
check "png16 within 2 codes of the input everywhere" \
    oiiotool --fail 3.06e-5 --failpercent 0 r16.png want.png --diff
check "png16 is not lossless here (the bound is used)" \
    sh -c "! oiiotool --fail 1e-7 r16.png want.png --diff >/dev/null"

expect_status "region tiff32" 200 '/v1/images/dem/region?level=0&x=500&y=100&w=300&h=150&format=tiff32'
check "tiff32: image/tiff" test "$(header Content-Type)" = image/tiff
cp "$T/b" r32.tif
check "tiff32 is one float channel" sh -c "oiiotool --info -v r32.tif | grep -q '1 channel, float tiff'"
oiiotool r16.png --mulc 65535 --subc 11000 -d float -o r16v.tif
check "tiff32 = png16 * 1 - 11000 (metres)" \
    oiiotool --fail 0.002 --failpercent 0 r32.tif r16v.tif --diff

expect_status "png16 of a level above the root" 200 '/v1/images/dem/region?level=4&x=0&y=0&w=65&h=19&format=png16'
expect_status "png16 of an image store is 400" 400 '/v1/images/img/region?level=0&x=0&y=0&w=10&h=10&format=png16'
expect_status "a gray 8-bit region of the height store" 200 '/v1/images/dem/region?level=1&x=0&y=0&w=515&h=150'
cp "$T/b" gray.png
check "the 8-bit region is one 8-bit channel" sh -c "oiiotool --info -v gray.png | grep -q '1 channel, uint8 png'"

expect_status "IIIF of the height store" 200 /iiif/3/dem/full/max/0/default.jpg
check "IIIF gives the whole field" test "$(image_size "$T/b")" = "1030 300 1"
expect_status "the root as a 16-bit PNG" 200 /v1/images/dem/root
cp "$T/b" root.png
check "the root PNG is 16-bit" sh -c "oiiotool --info -v root.png | grep -q '1 channel, uint16 png'"
expect_status "the root raw: 2 bytes a sample" 200 '/v1/images/dem/root?format=raw'
check "raw root is 258 x 75 x 2 bytes" test "$(wc -c <"$T/b")" = $((258 * 75 * 2))

# The root as a lossless WebP: a height store has none (its root holds
# 16-bit codes); a gray image store's decodes to three channels, each
# exactly the raw root.
expect_status "the root of a height store as WebP is 400" 400 '/v1/images/dem/root?format=webp'
check "... saying why" grep -q 'no WebP form' "$T/b"
expect_status "a gray store's raw root" 200 '/v1/images/gray/root?format=raw'
cp "$T/b" gray.raw
check "the gray raw root is 88 x 63 x 1 bytes (root side 128)" test "$(wc -c <gray.raw)" = $((88 * 63))
expect_status "a gray store's root as WebP" 200 '/v1/images/gray/root?format=webp'
cp "$T/b" gray.webp
check "its three channels are each the raw root" webp_is_raw gray.webp gray.raw 1
check "its headers say gray (X-Channels 1)" test "$(header Content-Type) $(header X-Channels)" = "image/webp 1"


stop_daemon
check "the daemon stops cleanly" test "$drc" = 0
done_testing
