#!/bin/sh
# browser_terrain.sh - terrain in headless Chromium (Debian's
# /usr/bin/chromium with WebGL on SwiftShader, driven by playwright-core):
#   1. CesiumJS from npm (tests/browser/node_modules/cesium), unchanged,
#      loads gigaviewd's terrain service (tests/browser/terrain_cesium.mjs
#      lists its checks): layer.json and the quantized-mesh tiles load and
#      parse with no failed request and no console error, sampled heights
#      are those of the store, the screenshot shows relief where the
#      ellipsoid alone is flat, without skirts no crack shows, and with
#      requestVertexNormals the tiles come with their normals (asked in
#      the Accept header) and CesiumJS lights the globe through them;
#   2. the viewer's 3D terrain mode (client/web/terrain*.js;
#      tests/browser/terrain_viewer.mjs lists its checks);
#   3. z-field simplification in the browser (client/web/zfield*.js;
#      tests/browser/zfield.mjs lists its checks): the WebGL2 sweep gives
#      gigaviewd's CPU mesh triangle for triangle (and, in the
#      view-dependent mode, tests/zfield_states's), and the terrain mode's
#      `refine=zfield` refines the mesh per frame as the camera orbits.
#
# Encodes tests/data/etopo5-720x361-u16.png (the globe every half degree;
# its column 0 is at Greenwich, hence lon0=0) as the height store
# "world", and tests/data/picos-1100x700.jpg as an image store to drape.
#
# Skipped when /usr/bin/chromium, node or tests/browser/node_modules (with
# cesium) is missing (scripts/install-deps.sh installs chromium and
# nodejs; scripts/check.sh runs `npm ci` in tests/browser), and under
# valgrind.  Needs curl and python3 (http_util.sh).
. "$(dirname "$0")/lib.sh"

browser_preflight cesium/Build/Cesium/Cesium.js "http_terrain.sh covers the routes"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" || bail "mkdir"
run encode --height --max-error 2 --unit m --offset -11000 \
    "$TESTDATA/etopo5-720x361-u16.png" -o "$S/world.gv"
[ "$rc" -eq 0 ] || bail "encode world: $(cat "$T/err")"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$S/picos.gv"
[ "$rc" -eq 0 ] || bail "encode picos: $(cat "$T/err")"

cat >"$T/t.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
access_log = off
EOF2
start_daemon "$T/t.conf"

# 1. CesiumJS
crc=0
timeout "$BROWSER_HANG" node "$BROWSER_DIR/terrain_cesium.mjs" --base "$BASE" --id world \
    --lon0 0 --chromium "$CHROMIUM" --out "$T/shots" >"$T/cesium.out" 2>&1 || crc=$?
browser_relay "$T/cesium.out" "$crc" terrain_cesium.mjs

# 2. the viewer's terrain mode
if [ -f "$BROWSER_DIR/terrain_viewer.mjs" ]; then
    vrc=0
    timeout "$BROWSER_HANG" node "$BROWSER_DIR/terrain_viewer.mjs" --base "$BASE" --id world \
        --drape picos --chromium "$CHROMIUM" --out "$T/shots" >"$T/viewer.out" 2>&1 || vrc=$?
    browser_relay "$T/viewer.out" "$vrc" terrain_viewer.mjs
fi

# 3. z-field simplification in the browser
# (tests/zfield_states, a check program, gives lib/mesh/zfield.c's states)
: "${ZFIELD_STATES:=./tests/zfield_states}"
if [ -f "$BROWSER_DIR/zfield.mjs" ]; then
    zrc=0
    set -- --base "$BASE" --id world --chromium "$CHROMIUM" --out "$T/shots"
    [ -x "$ZFIELD_STATES" ] && set -- "$@" --helper "$ZFIELD_STATES"
    timeout "$BROWSER_HANG" node "$BROWSER_DIR/zfield.mjs" "$@" >"$T/zfield.out" 2>&1 || zrc=$?
    browser_relay "$T/zfield.out" "$zrc" zfield.mjs
fi

stop_daemon
if [ "$drc" -eq 0 ]; then ok "gigaviewd exits 0 on SIGTERM"; else
    not_ok "gigaviewd exits 0 on SIGTERM (exit $drc)" "$(tail -n 20 "$T/daemon.log")"
fi
done_testing
