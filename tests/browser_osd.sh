#!/bin/sh
# browser_osd.sh - OpenSeadragon, installed from npm, shows an image
# through gigaviewd's IIIF endpoint in headless Chromium (Debian's
# /usr/bin/chromium driven by playwright-core; tests/browser/osd.mjs).
#
# Encodes tests/data/picos-1100x700.jpg (a real photograph) as store
# "picos", starts gigaviewd on port 0, and opens
# /iiif/3/picos/info.json in an 825x525 viewer (the image's aspect ratio,
# so the home view is the whole image at 0.75 and OSD draws six level-0
# tiles, resampled by the browser).  osd.mjs checks that every tile
# loaded, that every IIIF response was 200 with
# Access-Control-Allow-Origin (the page is on another origin and asks
# for CORS images, so a missing header fails the load), that the
# screenshot of the canvas is not blank, and that it matches the
# reference full/825,525/0/default.png from the same endpoint.
#
# Thresholds (in osd.mjs), per channel: mean absolute difference < 4
# and PSNR > 30 dB; luma standard deviation > 10 for "not blank".
# Measured on Debian Chromium 156 with OSD 6.1.1 (WebGL drawer on SwiftShader):
# MAD 1.3, PSNR 42-43 dB - OSD's bilinear resampling of the 512-pixel
# tiles against gigaviewd's own downscale.  The same screenshot against
# the reference moved by one pixel gives MAD 7.7 and PSNR 26.7, so both
# limits reject a one-pixel misregistration; osd.mjs re-checks that on
# every run (and against the mirrored reference) so a future image or
# browser cannot make the metric vacuous.
#
# Negative controls of the whole pipeline, each must FAIL the match:
# tiles served from a black store (MAD ~98, stddev 0), tiles from a
# different picture of the same size (MAD 35-84), and every tile region
# moved 4 image pixels (MAD 7.2).
#
# Skipped when /usr/bin/chromium, node or tests/browser/node_modules is
# missing (scripts/install-deps.sh installs chromium and nodejs;
# scripts/check.sh runs `npm ci` in tests/browser).
# Needs curl, python3 and oiiotool.
. "$(dirname "$0")/lib.sh"

browser_preflight openseadragon
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$S/picos.gv"
[ "$rc" -eq 0 ] || bail "encode picos: $(cat "$T/err")"
# The negative controls' stores: black, and another photograph, both
# 1100x700 like picos.
oiiotool --create 1100x700 3 -d uint8 -o "$T/black.png" &&
    oiiotool "$TESTDATA/seeding-640x480.jpg" --resize 1100x700 -o "$T/other.png" ||
    bail "oiiotool"
for n in black other; do
    run encode "$T/$n.png" -o "$S/$n.gv"
    [ "$rc" -eq 0 ] || bail "encode $n: $(cat "$T/err")"
done

cat >"$T/osd.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = stderr
log_level = info
EOF2
start_daemon "$T/osd.conf"

# osd [ARGS...]: run osd.mjs (at most BROWSER_HANG s) against the daemon; its
# output in $T/osd.out, its status in $orc.
osd() {
    orc=0
    timeout "$BROWSER_HANG" node "$BROWSER_DIR/osd.mjs" --base "$BASE" --id picos \
        --chromium "$CHROMIUM" --out "$T/shots" "$@" >"$T/osd.out" 2>&1 ||
        orc=$?
}

osd
while IFS= read -r line; do
    case $line in
    "PASS "*) ok "${line#PASS }" ;;
    "FAIL "*) not_ok "${line#FAIL }" ;;
    "# tile "*) ;;
    "#"*) printf '%s\n' "$line" ;;
    *) diag "$line" ;;
    esac
done <"$T/osd.out"
if [ "$orc" -ne 0 ] && ! grep -q '^FAIL ' "$T/osd.out"; then
    not_ok "osd.mjs ran (exit $orc)" "$(tail -n 20 "$T/osd.out")"
fi

# expect_mismatch DESCRIPTION ARGS...: the sabotaged run must fail the
# reference match (and nothing else may have broken it).
expect_mismatch() {
    d=$1
    shift
    osd "$@"
    if [ "$orc" -eq 1 ] && grep -q '^FAIL the canvas matches the reference' "$T/osd.out" &&
        grep -q '^PASS OpenSeadragon opened' "$T/osd.out"; then
        ok "negative control: $d fails the match ($(grep -A1 '^FAIL the canvas matches' \
            "$T/osd.out" | sed -n 's/^# MAD R\/G\/B \([^ ]*\).*/MAD \1/p'))"
    else
        not_ok "negative control: $d fails the match (exit $orc)" \
            "$(grep -v '^# tile\|^# sabotage' "$T/osd.out" | tail -n 20)"
    fi
}
expect_mismatch "tiles from a black image" --tiles-from black
expect_mismatch "tiles from another picture" --tiles-from other
expect_mismatch "tiles moved 4 pixels" --shift-tiles 4

stop_daemon
if [ "$drc" -eq 0 ]; then ok "gigaviewd exits 0 on SIGTERM"; else
    not_ok "gigaviewd exits 0 on SIGTERM (exit $drc)" "$(tail -n 20 "$T/daemon.log")"
fi
done_testing
