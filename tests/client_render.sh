#!/bin/sh
# client_render.sh - the native thin client (`gigaview render`, `gigaview
# info URL`) against gigaviewd started on port 0 over a scratch store
# directory, and against a tiny fault-injecting HTTP stub.
#
# Covers: info URL lists the images; render (tiles fetched over HTTP,
# decoded on the GPU) is pixel-identical to `gigaview export` for regions
# of tiled levels, the root and a root mip, RGB and gray, and the view form
# at an integer zoom equals the matching region; a fractional zoom with a
# rotation renders; tiles come in one batch request (?etag=1) and a second
# run revalidates every tile in that one request, as 304 frames (client
# --verbose and the daemon's access log); a damaged disk-cache entry is
# ignored; a server that refuses the batch (413) gets the tiles one by
# one; errors exit 1 with a clear message and leave any existing
# output untouched: unreachable server, unknown image, region and level
# out of range, truncated bodies (cut connection, a short tile in a
# consistent batch, a batch cut between frames), a 500, and a response
# slower than --timeout; GIGAVIEW_GPU_PLATFORM forces the
# EGL platform.  Render checks skip when no EGL context can be made; a
# build configured --without-gpu only checks that render refuses.  Needs
# curl, python3, oiiotool and idiff.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
# The client's bound on each HTTP request that must be answered
# (--timeout; 30 s by default) is GV_TEST_PATIENCE.
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" "$T/cache" || bail "mkdir"
cd "$T/w" || bail "cd"
XDG_CACHE_HOME=$T/cache
export XDG_CACHE_HOME

run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode x: $(cat "$T/err")"
run encode -q 40 synth:1300x1100:gray -o "$S/g.gv"
[ "$rc" -eq 0 ] || bail "encode g: $(cat "$T/err")"

cat >"$T/d.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 4
cache_bytes = 16M
connection_timeout = 10
access_log = stderr
log_level = info
EOF2
start_daemon "$T/d.conf"

# ---------------------------------------------------------------- info URL
run info "$BASE"
if [ "$rc" -eq 0 ] && grep -Eq '^x +3000 +2000 +6 +3 ' "$T/out" &&
    grep -Eq '^g +1300 +1100 ' "$T/out"; then
    ok "info URL lists the server's images"
else
    not_ok "info URL lists the server's images (exit $rc)" "$(cat "$T/out" "$T/err")"
fi
run info "$BASE/"
expect_rc "info URL with a trailing slash" 0

# ---------------------------------------------------------------- GPU build, platform
# A build configured --without-gpu has no render: it says what it needs,
# exits 1 and writes nothing, and nothing below can run.
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 2 --region 0,0,64,64 -o nb.png
if grep -q 'needs a build with GPU support' "$T/err"; then
    check "not built: render exits 1, says it needs GPU support, writes nothing" \
        test "$rc" -eq 1 -a ! -e nb.png
    stop_daemon
    done_testing
fi
# GIGAVIEW_GPU_PLATFORM forces an EGL platform: an unknown one is a usage
# error before anything is fetched; Mesa's surfaceless platform works
# wherever the daemon's automatic choice was Mesa.
req "$(url /healthz)"
gpu_vendor=$(json_get 'j["gpu"].get("vendor", "")')
GIGAVIEW_GPU_PLATFORM=wayland
export GIGAVIEW_GPU_PLATFORM
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 2 --region 0,0,64,64 -o p.png
expect_rc "GIGAVIEW_GPU_PLATFORM=wayland is refused" 2
expect_err "GIGAVIEW_GPU_PLATFORM=wayland: says what it accepts" \
    "GIGAVIEW_GPU_PLATFORM wants auto, device, surfaceless or default, not 'wayland'"
GIGAVIEW_GPU_PLATFORM=surfaceless
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 2 --region 0,0,64,64 -o p.png -v
unset GIGAVIEW_GPU_PLATFORM
case $gpu_vendor in
*Mesa*)
    expect_rc "GIGAVIEW_GPU_PLATFORM=surfaceless renders" 0
    expect_err "GIGAVIEW_GPU_PLATFORM=surfaceless: decoded there" 'render: gpu .*\(surfaceless\): ' ;;
*)
    skip "GIGAVIEW_GPU_PLATFORM=surfaceless renders" "the daemon's EGL is not Mesa (${gpu_vendor:-none})"
    skip "GIGAVIEW_GPU_PLATFORM=surfaceless: decoded there" "the daemon's EGL is not Mesa" ;;
esac

# ---------------------------------------------------------------- render == export
# same_as_export DESC STORE LEVEL [REGION]: render and export agree.
no_gpu=
same_as_export() {
    d=$1 st=$2 lv=$3 rg=${4:-}
    set -- --level "$lv"
    [ -n "$rg" ] && set -- "$@" --region "$rg"
    rm -f r.png e.png
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image "$st" "$@" -o r.png
    if [ "$rc" -ne 0 ] && grep -q 'EGL\|gpu' "$T/err"; then
        no_gpu=$(head -c 300 "$T/err")
        skip "$d" "no GPU context"
        return
    fi
    rrc=$rc
    cp "$T/err" "$T/render.err"
    run export "$S/$st.gv" "$@" -o e.png
    if [ "$rrc" -ne 0 ] || [ "$rc" -ne 0 ]; then
        not_ok "$d (render exit $rrc, export exit $rc)" "$(cat "$T/render.err" "$T/err")"
    elif idiff -a r.png e.png >"$T/idiff" 2>&1; then
        ok "$d"
    else
        not_ok "$d" "$(tail -n 5 "$T/idiff")"
    fi
}
same_as_export "x level 0, a region across 4x2 tiles" x 0 100,200,1500,900
same_as_export "x level 0, the last tile's edge" x 0 2500,1500,500,500
same_as_export "x level 1, the whole level" x 1
same_as_export "x level 2, a region" x 2 10,20,700,480
same_as_export "x level 3 (the root)" x 3 5,6,300,200
same_as_export "x level 5 (a root mip)" x 5
same_as_export "g (gray) level 0, the whole image" g 0
same_as_export "g (gray) level 1, one pixel" g 1 649,549,1,1

# ---------------------------------------------------------------- view form
if [ -z "$no_gpu" ]; then
    # Integer zoom, no rotation: output pixel centres fall on level-1
    # pixel centres, so the view is exactly the region 200,100 600x400.
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --center 1000,600 --zoom 1 --size 600x400 -o v.png
    vrc=$rc
    run export "$S/x.gv" --level 1 --region 200,100,600,400 -o ve.png
    if [ "$vrc" -eq 0 ] && [ "$rc" -eq 0 ] && idiff -a v.png ve.png >/dev/null 2>&1; then
        ok "view at integer zoom 1 equals the level-1 region"
    else
        not_ok "view at integer zoom 1 equals the level-1 region (exit $vrc)" \
            "$(cat "$T/err")"
    fi
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --center 1500,1000 --zoom 1.6 --rotate 30 \
        --size 640x480 -o vr.png
    if [ "$rc" -eq 0 ] && [ "$(image_size vr.png)" = "640 480 3" ]; then
        ok "view at zoom 1.6, rotated 30 degrees, renders 640x480"
    else
        not_ok "view at zoom 1.6 rotated (exit $rc)" "$(cat "$T/err")"
    fi
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image g --center 650,550 --zoom -2 --size 200x100 -o zm.png
    expect_rc "view with a negative zoom (magnified)" 0
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image g --center 99999,99999 --zoom 0 --size 50x40 -o zo.png
    if [ "$rc" -eq 0 ] && [ "$(image_size zo.png)" = "50 40 1" ]; then
        ok "view entirely outside the image is black, not an error"
    else
        not_ok "view outside the image (exit $rc)" "$(cat "$T/err")"
    fi
else
    skip "view form" "no GPU context: $no_gpu"
fi

# ---------------------------------------------------------------- disk cache
if [ -z "$no_gpu" ]; then
    rm -rf "$T/cache"
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,1100,600 -o c1.png -v
    down=$(sed -n 's/.* \([0-9]*\) tiles downloaded, \([0-9]*\) revalidated.*/\1 \2/p' "$T/err")
    before=$(grep -c '" 304 ' "$T/daemon.log")
    batches=$(grep -cE '"POST /v1/images/x/batch(\?[^"]*)?" 200 ' "$T/daemon.log")
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,1100,600 -o c2.png -v
    again=$(sed -n 's/.* \([0-9]*\) tiles downloaded, \([0-9]*\) revalidated.*/\1 \2/p' "$T/err")
    after=$(grep -c '" 304 ' "$T/daemon.log")
    batches=$(($(grep -cE '"POST /v1/images/x/batch(\?[^"]*)?" 200 ' "$T/daemon.log") - batches))
    n=${down%% *}
    # 1100x600 at level 0: 6 tiles there, 2 at level 1, 1 at each of
    # levels 2 to 4 (the root is level 5); the requests: the metadata, the
    # batch and the root (a 304).
    if [ "$rc" -eq 0 ] && [ "$down" = "11 0" ] && [ "$again" = "0 $n" ] &&
        [ $((after - before)) -eq 1 ] && [ "$batches" -eq 1 ] &&
        grep -q "^render: $n tiles needed (ancestors included); http: 3 requests," "$T/err" &&
        cmp -s c1.png c2.png; then
        ok "second run revalidates all $n tiles in one batch (304 frames) and the root with a 304, and renders the same"
    else
        not_ok "disk cache revalidation (first '$down', second '$again', 304s $before -> $after, $batches batches)" \
            "$(cat "$T/err")"
    fi
    # A damaged entry is ignored and fetched afresh.
    f=$(find "$T/cache" -name '0-0-0' | head -n 1)
    if [ -n "$f" ]; then
        printf 'GVC1garbage' >"$f"
        run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,1100,600 -o c3.png -v
        if [ "$rc" -eq 0 ] && grep -q ' 1 tiles downloaded' "$T/err" && cmp -s c1.png c3.png; then
            ok "a damaged cache entry is refetched"
        else
            not_ok "a damaged cache entry is refetched (exit $rc)" "$(cat "$T/err")"
        fi
    else
        not_ok "cache entry 0-0-0 exists under \$XDG_CACHE_HOME/gigaview" "$(find "$T/cache")"
    fi
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,600,600 -o c4.png -v --no-cache
    # 4 tiles at level 0, 1 at each of levels 1 to 4 in one batch; the
    # metadata and the root are the other requests (the byte count varies
    # with the port).
    if [ "$rc" -eq 0 ] && grep -q '^render: 8 tiles needed (ancestors included); http: 3 requests, 8 tiles downloaded, 0 revalidated (304), ' "$T/err"; then
        ok "--no-cache downloads everything"
    else
        not_ok "--no-cache (exit $rc)" "$(cat "$T/err")"
    fi
else
    skip "disk cache" "no GPU context"
fi

# ---------------------------------------------------------------- errors
# fails DESC PATTERN ARGS...: render exits 1 with PATTERN on stderr and
# leaves the existing out.png (a sentinel) untouched and no stray files.
fails() {
    d=$1 pat=$2
    shift 2
    rm -rf "$T/o"
    mkdir "$T/o"
    printf 'sentinel' >"$T/o/out.png"
    run render --timeout "$GV_TEST_PATIENCE" "$@" -o "$T/o/out.png"
    if [ "$rc" -ne 1 ]; then
        not_ok "$d (exit $rc, wanted 1)" "$(cat "$T/err")"
    elif ! grep -Eq -- "$pat" "$T/err"; then
        not_ok "$d: stderr does not match /$pat/" "$(cat "$T/err")"
    elif [ "$(cat "$T/o/out.png")" != sentinel ] || [ "$(listing "$T/o")" != out.png ]; then
        not_ok "$d: the output directory was touched" "$(ls -la "$T/o")"
    else
        ok "$d (exit 1)"
    fi
}
# A port nothing listens on: bind one, close it.
dead=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
fails "unreachable server" "cannot reach the server" "http://127.0.0.1:$dead" --image x
fails "unknown image" "no image 'nope'" "$BASE" --image nope
fails "invalid image id" "not a valid image id" "$BASE" --image ../x
fails "region out of range" "outside level 1" "$BASE" --image x --level 1 --region 1400,0,101,10
fails "level out of range" "no level 20" "$BASE" --image x --level 20
fails "not an http URL" "not an http" "ftp://127.0.0.1:$PORT" --image x
run info "http://127.0.0.1:$dead"
expect_rc "info on an unreachable server" 1
# A server that accepts and never answers: info gives up after its
# --timeout, which the message names (a 30 s default would name 30000 ms).
python3 -c 'import socket, sys
s = socket.socket(); s.bind(("127.0.0.1", 0)); s.listen(8)
open(sys.argv[1], "w").write(str(s.getsockname()[1]))
held = []
while True: held.append(s.accept()[0])' "$T/silent.port.tmp" &
SILENT=$!
# shellcheck disable=SC2317 # run by wait_until
silent_up() { [ -s "$T/silent.port.tmp" ]; }
wait_until silent_up
run info "http://127.0.0.1:$(cat "$T/silent.port.tmp")" --timeout 1
kill "$SILENT" 2>/dev/null
wait "$SILENT" 2>/dev/null
check "info URL --timeout 1 gives up on a server that never answers, saying so" \
    sh -c "[ $rc -eq 1 ] && grep -q 'within 1000 ms (--timeout)' '$T/err'"

# ---------------------------------------------------------------- fault stub
# A proxy in front of gigaviewd that damages tile and batch responses.
# MODE: cut (Content-Length of the whole body, half the bytes, connection
# closed), short (a consistent but truncated tile: in a batch, the first
# tile's frame says half its length), flip (right length, a corrupt rate
# byte), 500, slow (3 s before answering), frames (a batch cut after its
# first frame), 413 (every batch refused as too large), none.
cat >"$T/stub.py" <<'PY'
import http.server, struct, sys, time, urllib.request, urllib.error
mode, upstream, portfile = sys.argv[1], sys.argv[2], sys.argv[3]

def first_tile(body, edit):
    # The batch body with edit(tile) in place of its first 200 tile.
    v2 = body[:4] == b'GVB2'
    off = 8
    for i in range(struct.unpack_from('<I', body, 4)[0]):
        elen = body[off + 1]
        status, length = struct.unpack_from('<II', body, off + 12)
        data = off + 20 + (elen + 3) // 4 * 4
        if status == 200:
            tile = edit(body[data:data + length])
            head = body[off:off + 16] + struct.pack('<I', len(tile))
            rest = body[data + (length + 3) // 4 * 4:]
            pad = b'\0' * (-len(tile) % 4)
            return body[:off] + head + body[off + 20:data] + tile + pad + rest
        off = data + (length + 3) // 4 * 4
    return body

class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    def log_message(self, *a): pass
    def do_POST(self):
        self.do_GET(self.rfile.read(int(self.headers.get("Content-Length", 0))))
    def do_GET(self, data=None):
        hdrs = {k: self.headers[k] for k in ("Content-Type", "If-None-Match") if self.headers[k]}
        batch = "/batch" in self.path
        if batch and mode == "413":
            status, body, ctype = 413, b'{"error":{"status":413,"code":"too_large","message":"injected"}}', "application/json"
        else:
            try:
                with urllib.request.urlopen(urllib.request.Request(upstream + self.path, data, hdrs)) as r:
                    status, body, ctype = r.status, r.read(), r.headers.get("Content-Type")
            except urllib.error.HTTPError as e:
                status, body, ctype = e.code, e.read(), e.headers.get("Content-Type")
        tile = ("/tiles/" in self.path or batch) and status == 200
        if tile and mode == "500":
            status, body = 500, b'{"error":{"status":500,"code":"io_error","message":"injected"}}'
        if tile and mode == "slow":
            time.sleep(30)
        if tile and mode == "short":
            body = first_tile(body, lambda t: t[:len(t) // 2 // 4 * 4]) if batch else body[:len(body) // 2]
        if tile and mode == "flip":
            body = first_tile(body, lambda t: bytes([0x0f]) + t[1:]) if batch else bytes([0x0f]) + body[1:]
        if tile and batch and mode == "frames":
            body = body[:8 + 20]
        self.send_response(status)
        self.send_header("Content-Type", ctype or "application/octet-stream")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        if tile and mode == "cut":
            self.wfile.write(body[:len(body) // 2])
            self.wfile.flush()
            self.close_connection = True
            return
        self.wfile.write(body)
s = http.server.ThreadingHTTPServer(("127.0.0.1", 0), H)
s.daemon_threads = True
open(portfile + ".tmp", "w").write(str(s.server_address[1]))
import os; os.rename(portfile + ".tmp", portfile)
s.serve_forever()
PY
SPID=
stub_stop() {
    if [ -n "$SPID" ]; then
        kill "$SPID" 2>/dev/null
        wait "$SPID" 2>/dev/null
        SPID=
    fi
}
trap 'stub_stop; http_cleanup' EXIT
# shellcheck disable=SC2317 # run by wait_until
stub_up() {
    [ -s "$T/stub.port" ] || ! kill -0 "$SPID" 2>/dev/null
}
stub_start() {
    rm -f "$T/stub.port"
    python3 "$T/stub.py" "$1" "$BASE" "$T/stub.port" 2>"$T/stub.log" &
    SPID=$!
    wait_until stub_up
    [ -s "$T/stub.port" ] || bail "stub did not start: $(cat "$T/stub.log")"
    STUB="http://127.0.0.1:$(cat "$T/stub.port")"
}
if [ -z "$no_gpu" ]; then
    for m in cut short flip 500 slow frames; do
        stub_start $m
        case $m in
        cut) pat="truncated response";;
        short|flip) pat="tile [0-9]+/[0-9]+/[0-9]+ from .* is corrupt";;
        500) pat="HTTP 500: injected";;
        slow) pat="within 1000 ms";;
        frames) pat="batch: frame 0 \\(tile [0-9/]+\\) cut short";;
        esac
        # 'slow' stalls each tile for 30 s: a render that waited it out would
        # succeed, so the failure with the timeout message is the proof that
        # --timeout gave up (no wall-clock check, which load would break).
        # Only 'slow' gets the 1 s timeout (any request it cuts short fails
        # with the same message): the other modes damage what comes back,
        # however long the ASan daemon behind the stub takes.
        to=$GV_TEST_PATIENCE
        [ $m = slow ] && to=1
        fails "stub '$m': tile responses damaged" "$pat" "$STUB" --image x --level 0 \
            --region 0,0,600,600 --no-cache --timeout "$to"
        stub_stop
    done
    # The stub passes everything through untouched in any other mode.
    stub_start none
    run render "$STUB" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,600,600 --no-cache -o s.png
    run export "$S/x.gv" --level 0 --region 0,0,600,600 -o se.png
    check "through the stub untouched, render still equals export" \
        sh -c 'idiff -a s.png se.png >/dev/null 2>&1'
    stub_stop
    # A server that refuses the batch (a smaller batch_max_tiles): the
    # tiles come one by one, and the picture is the same.
    stub_start 413
    run render "$STUB" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,600,600 --no-cache -o s413.png -v
    check "a batch refused with 413: the 8 tiles come one by one, render still equals export" \
        sh -c "[ $rc -eq 0 ] && grep -q '^render: 8 tiles needed (ancestors included); http: 11 requests, 8 tiles downloaded' '$T/err' &&
            idiff -a s413.png se.png >/dev/null 2>&1"
    stub_stop
else
    skip "fault injection" "no GPU context"
fi

stop_daemon
[ "$drc" -eq 0 ] && ok "gigaviewd exits 0 on SIGTERM" || not_ok "gigaviewd exit $drc"
done_testing
