#!/bin/sh
# browser_viewer.sh - the browser viewer that gigaviewd serves at /
# (client/web/), in headless Chromium with WebGL2 on SwiftShader (Debian's
# /usr/bin/chromium driven by playwright-core; tests/browser/viewer.mjs
# lists every check), and its filter panel against the server's filter
# graphs (the stock library, a token for saving).
#
# Encodes tests/data/picos-1100x700.jpg as store "picos" (two tiled
# levels; every tile of it is entropy-coded), synth:3000x2000 at -q 30 as
# "synth" (three tiled levels, both tile layouts), and with layout-D
# (transform-coded) tiles the photo again as "picosd" and
# synth:1100x700:gray as "grayd", starts gigaviewd on
# port 0, and runs viewer.mjs: 1:1 views of pyramid levels read back from
# the canvas against the region endpoint (the CPU reference decoder; mean
# absolute difference <= 1 per channel, measured 0: the shared decode
# shader and the JavaScript rANS decoder are bit-exact in the browser),
# every decoded tile against the same endpoint (also after an eviction
# tour, and for a prefetch that must make room while the parent it
# decodes from is the least recently used tile), mouse, keyboard, wheel,
# touch and gamepad input checked for the view they reach and against
# `gigaview render` of that view, the URL hash round trip, the fallback
# without WebGL2, the image list, and no console errors; the root fetched
# once, as the store's lossless WebP (never as PNG or raw samples).  Then
# the filter flows: an ROI and a graph from a link, ROI drag-select, a slider
# (debounced, stale requests aborted), re-running after a pan with the
# stale result in place meanwhile, the graph view, a GLSL compile error at
# its line, saving; every ROI picture bit for bit the filter endpoint's.
#
# With the tests/dct_coefs helper, viewer.mjs also decodes its synthetic
# layout-D tiles (escapes, clamps, full and empty blocks) in the page
# against gv_tile_decode.  Layout D's unpacking is also checked in node against the C decoder's
# (tests/browser/dct_unpack.mjs with the tests/dct_coefs helper): every D
# tile and the helper's synthetic buffers, intact, with a step changed and
# damaged, refused alike (same message) or unpacked to the same
# coefficients.
#
# Negative controls of the whole pipeline (one browser runs them all, each
# on a page of its own), each must FAIL the 1:1 match:
# a decode shader with one prediction weight changed (29/111 to 30/110),
# a rANS decoder that flips the lowest bit of every index, a layout-D
# unpacking with the zigzag order transposed (on picosd), and a root
# (as the viewer decoded it) with the lowest bit of every 97th sample
# flipped.
#
# Skipped when /usr/bin/chromium, node or tests/browser/node_modules is
# missing (scripts/install-deps.sh installs chromium and nodejs;
# scripts/check.sh runs `npm ci` in tests/browser), and under valgrind.
# Needs curl and python3 (http_util.sh).
. "$(dirname "$0")/lib.sh"

browser_preflight
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
# picos and synth keep the VQ layouts (--layouts vq), whose rANS index
# decoder the browser runs too; picosd and grayd below are layout D.
run encode --layouts vq "$TESTDATA/picos-1100x700.jpg" -o "$S/picos.gv"
[ "$rc" -eq 0 ] || bail "encode picos: $(cat "$T/err")"
# At -q 30 the synthetic image has fixed-layout tiles (near-flat index
# histograms at rates 1 and 2) beside entropy-coded ones.
run encode --layouts vq -q 30 synth:3000x2000 -o "$S/synth.gv"
[ "$rc" -eq 0 ] || bail "encode synth: $(cat "$T/err")"
# Layout D (FORMAT.md 4.3): the same photo and a gray synthetic image
# with transform-coded tiles.
run encode --layouts d "$TESTDATA/picos-1100x700.jpg" -o "$S/picosd.gv"
[ "$rc" -eq 0 ] || bail "encode picosd: $(cat "$T/err")"
run encode --layouts all synth:1100x700:gray -o "$S/grayd.gv"
[ "$rc" -eq 0 ] || bail "encode grayd: $(cat "$T/err")"

absrc=$(cd "$srcdir" && pwd)
cat >"$T/viewer.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = stderr
log_level = info
filter_library_dir = "$absrc/filters/library"
filter_dir = "$T/filters"
auth_token = "viewer-test-token"
EOF2
start_daemon "$T/viewer.conf"

# The page and its files come from the daemon, with validators.
req "$(url /)"
check "/ is the viewer page with the image list" sh -c "[ '$code' = 200 ] &&
    grep -q 'text/html' '$T/h' && grep -qi 'content-security-policy' '$T/h' &&
    grep -q 'href=\"#image=picos\"' '$T/b' && grep -q 'web/main.js' '$T/b'"
req "$(url /web/tile_decode.frag.glsl)"
# Its #include "dct_matrix.glsl" expanded, as in the native programs.
sh "$srcdir/shaders/glsl_include.sh" "$srcdir/shaders/tile_decode.frag.glsl" >"$T/decode.glsl"
if [ "$code" = 200 ] && cmp -s "$T/b" "$T/decode.glsl" &&
    grep -q 'const highp int K\[64\]' "$T/b" && ! grep -q '^#include' "$T/b"; then
    ok "/web/tile_decode.frag.glsl is the shared decode shader with dct_matrix.glsl, byte for byte"
else
    not_ok "/web/tile_decode.frag.glsl is the shared decode shader (HTTP $code)"
fi
etag=$(header ETag)
req -H "If-None-Match: $etag" "$(url /web/tile_decode.frag.glsl)"
check "a matching If-None-Match gets 304 (ETag $etag)" [ "$code" = 304 ]
req "$(url /web/nope.js)"
check "an unknown file is 404" [ "$code" = 404 ]
req "$(url /web/..%2fviewer.conf)"
check "no path escapes the embedded files" [ "$code" = 404 ]

# The filter flows need filter graphs to run on this server (an EGL
# context and a worker); without them they are skipped.
req -H 'Content-Type: application/json' \
    -d '{"filter":"negate","level":0,"region":[0,0,8,8]}' "$(url /v1/images/picos/filter)"
if [ "$code" = 200 ]; then
    filters="--filters 1 --token viewer-test-token"
else
    filters=""
    skip "ROI filter flows" "no filter graphs on this server (HTTP $code: $(head -c 200 "$T/b"))"
fi

# The layout-D helper (a check program): synthetic tiles for viewer.mjs,
# coefficient planes for dct_unpack.mjs.
: "${DCT_COEFS:=./tests/dct_coefs}"
# viewer [ARGS...]: run viewer.mjs (at most BROWSER_HANG s); output in
# $T/viewer.out, status in $vrc.
viewer() {
    vrc=0
    timeout "$BROWSER_HANG" node "$BROWSER_DIR/viewer.mjs" --base "$BASE" --gigaview "$GIGAVIEW" \
        --chromium "$CHROMIUM" --dctcoefs "$DCT_COEFS" "$@" >"$T/viewer.out" 2>&1 || vrc=$?
}
# shellcheck disable=SC2086
viewer $filters
browser_relay "$T/viewer.out" "$vrc" viewer.mjs

# Layout D's unpacking in JavaScript against the C decoder's, tile by
# tile, intact and damaged (node only: tests/browser/dct_unpack.mjs).
urc=0
timeout "$BROWSER_HANG" node "$BROWSER_DIR/dct_unpack.mjs" --base "$BASE" --helper "$DCT_COEFS" \
    --images picosd,grayd >"$T/dct.out" 2>&1 || urc=$?
browser_relay "$T/dct.out" "$urc" dct_unpack.mjs

# The negative controls, in one browser (viewer.mjs runs each sabotage on
# a page of its own, its output from "# sabotage: NAME" on).
# expect_mismatch DESCRIPTION NAME: that sabotage must fail the 1:1
# match, and nothing else may have broken it.
viewer --sabotage shader,rans,dct,matrix,root
expect_mismatch() {
    d=$1
    img=picos
    case $2 in dct | matrix) img=picosd ;; esac
    awk -v s="# sabotage: $2" '$0 == s { on = 1; next } /^# sabotage: / { on = 0 } on' \
        "$T/viewer.out" >"$T/sabotage.out"
    if [ "$vrc" -eq 1 ] && grep -q "^FAIL $img level 0 1:1: the canvas matches" "$T/sabotage.out" &&
        grep -q '^PASS the viewer opened with WebGL2' "$T/sabotage.out"; then
        ok "negative control: $d fails the match ($(grep -A1 "^FAIL $img level 0" "$T/sabotage.out" |
            sed -n 's/^# \(MAD [^,]*\).*/\1/p'))"
    else
        not_ok "negative control: $d fails the match (exit $vrc)" "$(tail -n 20 "$T/sabotage.out")"
    fi
}
expect_mismatch "a decode shader with one weight changed" shader
expect_mismatch "a rANS decoder that flips index bits" rans
expect_mismatch "a layout-D unpacking with the zigzag order transposed" dct
expect_mismatch "a decode shader with one entry of dct_matrix.glsl's K changed" matrix
expect_mismatch "a root with a bit flipped in every 97th sample" root

stop_daemon
if [ "$drc" -eq 0 ]; then ok "gigaviewd exits 0 on SIGTERM"; else
    not_ok "gigaviewd exits 0 on SIGTERM (exit $drc)" "$(tail -n 20 "$T/daemon.log")"
fi
done_testing
