#!/bin/sh
# browser_window.sh - the display window in the browser viewer, in
# headless Chromium with WebGL2 on SwiftShader (tests/browser/window.mjs
# lists the checks): a window from the link, per channel, from the panel's
# auto button and a slider, each drawn without a single request and equal,
# bit for bit at a 1:1 view, to the server's region with the same
# `window`; the hash carries it; a gray store too; a table off by one
# fails the match (negative control); a store encoded with --window opens
# with that default (the first frame equal to the server's region) when
# the link names no window, and with none when it says window=none; a
# 16-bit sample store is drawn from its codes in WebGL2: windows and
# colours on the codes (the link's, the panel's, the store's own) without
# a request, equal to the server's regions bit for bit, and through the
# server's regions without WebGL2; a height store likewise, its window on
# the gray the server draws of its codes.
#
# Skipped when /usr/bin/chromium, node or tests/browser/node_modules is
# missing, and under valgrind.  Needs curl and python3 (http_util.sh).
. "$(dirname "$0")/lib.sh"

browser_preflight
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$S/picos.gv"
[ "$rc" -eq 0 ] || bail "encode picos: $(cat "$T/err")"
run encode "$TESTDATA/picos-1100x700.jpg" --window 30,200,0.7 -o "$S/dflt.gv"
[ "$rc" -eq 0 ] || bail "encode dflt: $(cat "$T/err")"
run encode synth:1100x700:gray -o "$S/gray.gv"
[ "$rc" -eq 0 ] || bail "encode gray: $(cat "$T/err")"
oiiotool "$TESTDATA/picos-1100x700.jpg" -d uint16 -o "$T/p16.png" || bail "oiiotool p16"
run encode --bits 16 "$T/p16.png" -o "$S/s16.gv"
[ "$rc" -eq 0 ] || bail "encode s16: $(cat "$T/err")"
# Five channels (two groups of three in the display shader), near-lossless.
oiiotool --pattern "noise:type=uniform:min=0.1:max=0.9" 1100x700 5 \
    --pattern "checker:width=64:height=64:color1=0.2,0.4,0.6,0.8,1:color2=0,0.1,0.2,0.3,0.4" 1100x700 5 \
    --add -d uint16 -o "$T/c5.tif" || bail "oiiotool c5"
run encode --bits 16 --max-error 40 "$T/c5.tif" -o "$S/c5.gv"
[ "$rc" -eq 0 ] || bail "encode c5: $(cat "$T/err")"
run encode --height --max-error 2 synth-height:1100x700 -o "$S/dem.gv"
[ "$rc" -eq 0 ] || bail "encode dem: $(cat "$T/err")"
run encode --bits 16 "$T/p16.png" --window 2000,50000,1.5 --colours '00ffff;ff00ff;ffff00' -o "$S/s16d.gv"
[ "$rc" -eq 0 ] || bail "encode s16d: $(cat "$T/err")"
# A slide that says its microns per pixel (tests/make_slide, read through
# OpenSlide), for the scale bar; without OpenSlide window.mjs skips it.
builddir=$(cd "${top_builddir:-.}" && pwd)
if grep -q '^#define GV_HAVE_OPENSLIDE 1' "$builddir/config.h" 2>/dev/null &&
    "$builddir/tests/make_slide" "$T/slide.svs" 1500 1100 none 0.2527 40; then
    run encode "$T/slide.svs" -o "$S/slide.gv"
    [ "$rc" -eq 0 ] || bail "encode slide: $(cat "$T/err")"
fi
cat >"$T/w.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = stderr
log_level = info
EOF2
start_daemon "$T/w.conf"
wrc=0
timeout "$BROWSER_HANG" node "$BROWSER_DIR/window.mjs" --base "$BASE" --chromium "$CHROMIUM" >"$T/window.out" 2>&1 || wrc=$?
browser_relay "$T/window.out" "$wrc" window.mjs
stop_daemon
check "gigaviewd exits 0 on SIGTERM" [ "$drc" -eq 0 ]
done_testing
