#!/bin/sh
# browser_height.sh - the WebGL2 height decoder in headless Chromium
# (tests/browser/height.mjs): every tile of every level of two height
# stores, decoded in the page by client/web/heighttile.js and
# shaders/height_decode.frag.glsl (GLSL ES 3.00, as the daemon serves
# them), equals the CPU reference decoder's codes sample for sample.
# Stores: the ETOPO5 crop at a 2 m bound and synthetic terrain, lossless;
# and a sample store (docs/FORMAT.md section 13, a photograph's three
# channels at e = 1), each channel split from the tiles by heighttile.js.
# Skipped when /usr/bin/chromium, node 20+ or tests/browser/node_modules
# is missing, and under valgrind.  Needs curl and python3 (http_util.sh).
. "$(dirname "$0")/lib.sh"

browser_preflight "" "http_height.sh covers gigaviewd"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode --height --max-error 2 "$TESTDATA/etopo5-himalaya-1030x300-u16.png" -o "$S/dem.gv"
[ "$rc" -eq 0 ] || bail "encode dem: $(cat "$T/err")"
run encode --height synth-height:1100x1030 -o "$S/terrain.gv"
[ "$rc" -eq 0 ] || bail "encode terrain: $(cat "$T/err")"
run encode --bits 16 --max-error 1 "$TESTDATA/picos-1100x700.jpg" -o "$S/rgb16.gv"
[ "$rc" -eq 0 ] || bail "encode rgb16: $(cat "$T/err")"
cat >"$T/h.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = off
gpu = off
EOF2
start_daemon "$T/h.conf"

req "$(url /web/height_decode.frag.glsl)"
check "/web/height_decode.frag.glsl is the shared shader, byte for byte" \
    sh -c "[ '$code' = 200 ] && cmp -s '$T/b' '$srcdir/shaders/height_decode.frag.glsl'"
for run_of in dem terrain rgb16:0 rgb16:1 rgb16:2; do
    id=${run_of%%:*}
    chan=
    [ "$id" != "$run_of" ] && chan="--channel ${run_of#*:}"
    vrc=0
    # shellcheck disable=SC2086
    timeout "$BROWSER_HANG" node "$BROWSER_DIR/height.mjs" --base "$BASE" --id "$id" $chan \
        --chromium "$CHROMIUM" >"$T/h.out" 2>&1 || vrc=$?
    if grep -q '^1\.\.0 # SKIP' "$T/h.out"; then
        skip "$id in the browser" "$(sed -n 's/^1\.\.0 # SKIP //p' "$T/h.out")"
        continue
    fi
    # Re-number height.mjs's TAP lines into ours.
    while IFS= read -r line; do
        case $line in
        "ok "*) ok "${line#ok * - }" ;;
        "not ok "*) not_ok "${line#not ok * - }" "$(grep '^#' "$T/h.out" | head -n 12)" ;;
        esac
    done <"$T/h.out"
    check "height.mjs for $run_of exits 0 (status $vrc)" [ "$vrc" = 0 ]
done
stop_daemon
done_testing
