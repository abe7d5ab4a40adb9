#!/bin/sh
# http_iiif.sh - gigaviewd's pixels over HTTP: regions in every output
# format, and IIIF (303, info.json, a dozen request forms pixel-compared
# with `gigaview export` plus oiiotool crops, rotations, flips and luma;
# TIFF, bitonal, JPEG, WebP and gray WebP answers, upscaling and its
# limits, and every IIIF error).  Split from tests/http_api.sh (which
# drives the other routes) so that the two run in parallel under
# `make -j2 check`; the same store x (synth:3000x2000) and configuration.
# The pixels must not depend on the GPU: a build configured --without-gpu
# (scripts/check.sh's third build) runs this test too.
# Needs curl, python3, oiiotool and idiff (openimageio-tools).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"

# Store x: 3000x2000, levels 0-2 tiled, root 375x250 at level 3.
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode x: $(cat "$T/err")"

cat >"$T/good.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
cache_bytes = 8M   # small, but holds every page of x
max_region_pixels = 4M
batch_max_tiles = 8
connection_timeout = 10
access_log = stderr
log_level = info
EOF2
start_daemon "$T/good.conf"
diag "gigaviewd on port $PORT"

# ---------------------------------------------------------------- region
for f in jpeg webp tiff; do
    req "$(url "/v1/images/x/region?level=2&x=0&y=0&w=200&h=100&format=$f")"
    got=$(image_size "$T/b")
    if [ "$code" = 200 ] && [ "$got" = "200 100 3" ] &&
        [ "$(header Content-Type)" = "image/$f" ]; then
        ok "region format=$f"
    else
        not_ok "region format=$f (status $code, size '$got', $(header Content-Type))"
    fi
done

# ---------------------------------------------------------------- IIIF
req -H 'Accept: application/ld+json' "$(url /iiif/3/x)"
check "IIIF base URI: 303" test "$code" = 303
check "IIIF base URI: Location" test "$(header Location)" = "http://127.0.0.1:$PORT/iiif/3/x/info.json"
expect_status "info.json" 200 /iiif/3/x/info.json
check "info.json: application/json by default" test "$(header Content-Type)" = "application/json"
check "info.json: context Link header" sh -c "grep -qi '^Link: <http://iiif.io/api/image/3/context.json>' '$T/h'"
check "info.json: CORS *" test "$(header Access-Control-Allow-Origin)" = "*"
check "info.json: fields" test "$(json_get '(j["@context"],j["id"],j["type"],j["protocol"],j["profile"],j["width"],j["height"])')" = "('http://iiif.io/api/image/3/context.json', 'http://127.0.0.1:$PORT/iiif/3/x', 'ImageService3', 'http://iiif.io/api/image', 'level2', 3000, 2000)"
check "info.json: tiles" test "$(json_get 'j["tiles"]')" = "[{'width': 512, 'height': 512, 'scaleFactors': [1, 2, 4, 8, 16, 32]}]"
check "info.json: sizes include every level" test "$(json_get '[(s["width"],s["height"]) for s in j["sizes"]][-4:]')" = "[(375, 250), (750, 500), (1500, 1000), (3000, 2000)]"
check "info.json: limits" test "$(json_get '(j["maxWidth"],j["maxHeight"],j["maxArea"])')" = "(16384, 16384, 16777216)"
check "info.json: extras" test "$(json_get '(j["extraFormats"], "mirroring" in j["extraFeatures"])')" = "(['webp', 'tif'], True)"
expect_status "info.json as JSON-LD" 200 /iiif/3/x/info.json -H 'Accept: application/ld+json'
check "info.json: JSON-LD content type with profile" test "$(header Content-Type)" = 'application/ld+json;profile="http://iiif.io/api/image/3/context.json"'

# Pixel checks.  Each case fetches an image from gigaviewd and builds its
# reference from `gigaview export` output with oiiotool (crop, rotate,
# flop, luma); one oiiotool run converts everything to PNM and pnmcmp.py
# compares them (exactly, or within a tolerance for gray).  Batching the
# conversions keeps the test fast: each OpenImageIO start costs ~0.3 s.
run export "$S/x.gv" -o e_l0.png
run export "$S/x.gv" --level 1 -o e_l1.png
run export "$S/x.gv" --level 2 -o e_l2.png
run export "$S/x.gv" --region 512,512,1024,1024 -o e_r1.png
run export "$S/x.gv" --level 3 -o e_root.png
cat >pnmcmp.py <<'PY'
import sys
def pnm(path):
    b = open(path, 'rb').read()
    f = b.split(None, 4)
    assert f[0] in (b'P5', b'P6') and f[3] == b'255', path
    w, h = int(f[1]), int(f[2])
    c = 3 if f[0] == b'P6' else 1
    return w, h, c, b[len(b) - w * h * c:]
for line in open(sys.argv[1]):
    desc, got, ref, tol = line.rstrip('\n').split('|')
    try:
        g, r = pnm(got), pnm(ref)
    except Exception as e:
        print('not ok|%s|cannot read: %s' % (desc, e)); continue
    if g[:3] != r[:3]:
        print('not ok|%s|size %dx%dx%d, wanted %dx%dx%d' % ((desc,) + g[:3] + r[:3])); continue
    d = 0 if g[3] == r[3] else max(abs(x - y) for x, y in zip(g[3], r[3]))
    print('%s|%s|max difference %d' % ('ok' if d <= int(tol) else 'not ok', desc, d))
PY
: >cases
ocmd=
ncase=0
# pix_case DESC PATH TOLERANCE REFERENCE-OIIOTOOL-ARGS...
pix_case() {
    ncase=$((ncase + 1))
    d=$1 p=$2 tol=$3
    shift 3
    req "$(url "$p")"
    if [ "$code" != 200 ] || [ "$(header Content-Type)" != image/png ]; then
        not_ok "$d: $p (status $code)" "$(head -c 300 "$T/b")"
        return
    fi
    cp "$T/b" "got$ncase.png"
    ocmd="$ocmd $* -o ref$ncase.pnm got$ncase.png -o got$ncase.pnm"
    echo "$d: $p|got$ncase.pnm|ref$ncase.pnm|$tol" >>cases
}
pix_case "region level 0 across tiles" \
    "/v1/images/x/region?level=0&x=500&y=300&w=700&h=600" 0 e_l0.png --cut 700x600+500+300
pix_case "region level 1 at the edge" \
    "/v1/images/x/region?level=1&x=1200&y=800&w=300&h=200&format=png" 0 e_l1.png --cut 300x200+1200+800
pix_case "region root level" "/v1/images/x/region?level=3&x=10&y=10&w=100&h=80" 0 \
    e_root.png --cut 100x80+10+10
run export "$S/x.gv" --level 5 -o e_l5.png
pix_case "region root mip" "/v1/images/x/region?level=5&x=0&y=0&w=94&h=63" 0 e_l5.png
I=/iiif/3/x
pix_case "IIIF full/max = level 0" $I/full/max/0/default.png 0 e_l0.png
pix_case "IIIF full/pct:50 = level 1" $I/full/pct:50/0/default.png 0 e_l1.png
pix_case "IIIF full/w, = level 1 (color)" $I/full/1500,/0/color.png 0 e_l1.png
pix_case "IIIF full/,h = level 2" $I/full/,500/0/default.png 0 e_l2.png
pix_case "IIIF full/!w,h = root" "$I/full/!375,375/0/default.png" 0 e_root.png
pix_case "IIIF full/w,h = root" $I/full/375,250/0/default.png 0 e_root.png
pix_case "IIIF x,y,w,h/max = export --region" $I/512,512,1024,1024/max/0/default.png 0 e_r1.png
pix_case "IIIF tile at scale 2" $I/1024,0,1024,1024/512,/0/default.png 0 e_l1.png --cut 512x512+512+0
pix_case "IIIF tile at scale 4, w,h" $I/512,0,1024,1024/256,256/0/default.png 0 e_l2.png --cut 256x256+128+0
pix_case "IIIF edge tile at scale 2" $I/2048,1024,952,976/476,/0/default.png 0 e_l1.png --cut 476x488+1024+512
pix_case "IIIF pct region" $I/pct:10,10,50,50/max/0/default.png 0 e_l0.png --cut 1500x1000+300+200
pix_case "IIIF square region" $I/square/max/0/default.png 0 e_l0.png --cut 2000x2000+500+0
pix_case "IIIF rotation 90" $I/0,0,400,300/max/90/default.png 0 e_l0.png --cut 400x300+0+0 --rotate90
pix_case "IIIF rotation 180" $I/0,0,400,300/max/180/default.png 0 e_l0.png --cut 400x300+0+0 --rotate180
pix_case "IIIF rotation 270" $I/0,0,400,300/max/270/default.png 0 e_l0.png --cut 400x300+0+0 --rotate270
pix_case "IIIF mirror" "$I/0,0,400,300/max/!0/default.png" 0 e_l0.png --cut 400x300+0+0 --flop
pix_case "IIIF mirror then 90" "$I/0,0,400,300/max/!90/default.png" 0 e_l0.png --cut 400x300+0+0 --flop --rotate90
pix_case "IIIF gray (BT.601 luma, within 1)" $I/0,0,400,300/max/0/gray.png 1 \
    e_l0.png --cut 400x300+0+0 --chsum:weight=0.299,0.587,0.114
pix_case "IIIF full/w, = level 2" $I/full/750,/0/default.png 0 e_l2.png
# shellcheck disable=SC2086
oiiotool $ocmd >oiio.out 2>&1 || diag "oiiotool: $(tail -n 3 oiio.out)"
python3 pnmcmp.py cases >cmp.out 2>&1 || diag "pnmcmp: $(tail -n 3 cmp.out)"
check "every pixel case compared" test "$(wc -l <cmp.out)" -eq "$ncase"
while IFS='|' read -r verdict desc detail; do
    if [ "$verdict" = ok ]; then ok "$desc"; else not_ok "$desc" "$detail"; fi
done <cmp.out
req "$(url $I/full/max/0/default.tif)"
cp "$T/b" got.tif
check "IIIF tif: image/tiff equal to the export" sh -c "test '$(header Content-Type)' = image/tiff && idiff -q e_l0.png got.tif >/dev/null 2>&1"
req "$(url $I/full/375,250/0/bitonal.png)"
cp "$T/b" bit.png
oiiotool bit.png -o bit.pgm 2>/dev/null
check "IIIF bitonal: one channel, only 0 and 255, both present" python3 -c "
import sys
b = open('bit.pgm', 'rb').read()
assert b[:2] == b'P5'
px = b[-375 * 250:]
sys.exit(0 if set(px) == {0, 255} else 1)"
req "$(url /iiif/3/x/full/max/0/default.jpg)"
check "IIIF jpg: image/jpeg 3000x2000" test "$code $(header Content-Type) $(image_size "$T/b")" = "200 image/jpeg 3000 2000 3"
check "IIIF image: CORS *" test "$(header Access-Control-Allow-Origin)" = "*"
check "IIIF image: canonical and profile Link" sh -c "grep -i '^Link:' '$T/h' | grep -q 'rel=\"canonical\"' && grep -i '^Link:' '$T/h' | grep -q 'level2.json>;rel=\"profile\"'"
req "$(url /iiif/3/x/full/max/0/default.webp)"
check "IIIF webp" test "$code $(header Content-Type) $(image_size "$T/b")" = "200 image/webp 3000 2000 3"
# WebP has no gray mode: a gray answer is RGB with equal channels (OIIO
# 2.4's WebP writer read past a one-channel image and crashed the daemon).
req "$(url /iiif/3/x/0,0,400,300/max/0/gray.webp)"
check "IIIF gray webp: RGB" test "$code $(header Content-Type) $(image_size "$T/b")" = "200 image/webp 400 300 3"
oiiotool "$T/b" -o "$T/gw.ppm" 2>/dev/null
# (lossy WebP codes RGB as YUV 4:2:0, so the channels agree within 1)
check "IIIF gray webp: the channels agree within 1" python3 -c "
import sys
b = open('$T/gw.ppm', 'rb').read()[-400 * 300 * 3:]
d = max(max(abs(b[i] - b[i + 1]), abs(b[i] - b[i + 2])) for i in range(0, len(b), 3))
sys.exit(0 if d <= 1 else 1)"
expect_status "the daemon lives on after a gray webp" 200 /healthz
req "$(url '/iiif/3/x/0,0,100,100/%5E200,/0/default.png')"
check "IIIF ^ upscaling within the limit" test "$code $(image_size "$T/b")" = "200 200 200 3"
expect_status "IIIF w, beyond the region without ^" 400 '/iiif/3/x/0,0,100,100/200,/0/default.png'
expect_status "IIIF ^ beyond max_upscale" 400 '/iiif/3/x/0,0,100,100/%5E1000,/0/default.png'
expect_status "IIIF arbitrary rotation" 501 /iiif/3/x/full/max/45/default.jpg
expect_status "IIIF unknown quality" 400 /iiif/3/x/full/max/0/sepia.jpg
expect_status "IIIF bad region" 400 /iiif/3/x/0,0,abc,10/max/0/default.jpg
expect_status "IIIF zero-size region" 400 /iiif/3/x/0,0,0,10/max/0/default.jpg
expect_status "IIIF region outside the image" 400 /iiif/3/x/5000,0,10,10/max/0/default.jpg
expect_status "IIIF zero size" 400 /iiif/3/x/full/0,/0/default.jpg
expect_status "IIIF negative size" 400 /iiif/3/x/full/-5,/0/default.jpg
expect_status "IIIF overflowing number" 400 /iiif/3/x/0,0,99999999999999999999,10/max/0/default.jpg
expect_status "IIIF unknown image" 404 /iiif/3/nope/info.json
expect_status "IIIF unknown image (request)" 404 /iiif/3/nope/full/max/0/default.jpg
check "IIIF errors carry CORS *" test "$(header Access-Control-Allow-Origin)" = "*"

stop_daemon
check "SIGTERM: exit status 0" test "$drc" -eq 0
no_sanitizer_report
done_testing
