#!/bin/sh
# client_view.sh - the native viewer (`gigaview view`) under SDL's
# offscreen video driver (EGL surfaceless on llvmpipe where there is no
# GPU), driven by --script files, against gigaviewd started on port 0 over
# a scratch store directory and against a small fault-injecting proxy.
#
# Covers: frames at 1:1 equal `gigaview render` of the same view bit for
# bit, for views across tile edges, at levels 0 and 1, RGB and gray (the
# gray one opened from a browser link's hash), with the root fetched as
# the store's lossless WebP (one request per image opened, no raw mip;
# from a server without that form, the raw mips and the same frame), and again after the atlas
# evicted tiles (a small --gpu-cache; the daemon's log shows evictions);
# a decoder sabotaged with GIGAVIEW_VIEW_SABOTAGE=decode fails that check;
# tiles decode on the decode thread (a GL context shared with the
# window's), and --no-decode-thread (decoding in the frame) gives the same
# frames bit for bit; quitting with decodes in flight exits cleanly;
# scripted drag, arrow key, wheel, rotation and Home reach the views the
# browser's geometry predicts, printed as browser links, and the frame
# after the drag equals render; faults: a tile answered 500 until a gate
# file appears, a server that holds tile answers until a gate opens
# (frames go on meanwhile: the script draws 30 frames and writes one
# while the request hangs), and gigaviewd stopped mid-pan and started
# again on its port: the window keeps drawing (ancestors) and the final
# frame equals render.  A bad script is a usage error naming its line.
# Gamepad and touch (synthetic SDL events from the script): shoulders
# turn, a finger pans, a pinch zooms, a stick pans and a trigger zooms.
# Filters: a region filtered by the server (negate) is drawn in place
# equal to the endpoint's answer, another graph and a stepped parameter
# redraw it, Delete clears it, a refused graph is an error the window
# survives.
# Skips when the build has no viewer (it then only checks the refusal)
# or no EGL/SDL window can be made.  Needs python3, oiiotool and idiff.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
# The client's bounds on what must come get GV_TEST_PATIENCE: each HTTP
# request (--timeout; 30 s by default) and a script's settle and
# wait-file (PMS milliseconds; 60 s by default).
PMS=$((GV_TEST_PATIENCE * 1000))
# Under LeakSanitizer the viewer's exit reports 128 bytes that Mesa's GL
# driver allocated, from a module already unloaded by then (its frames
# read "<unknown module>", so no suppression can name them), and every run
# would fail: leak checking is off for this test's processes; the
# sanitizers' memory-error checks stay on.
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}detect_leaks=0"
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" "$T/cache" || bail "mkdir"
cd "$T/w" || bail "cd"
XDG_CACHE_HOME=$T/cache
SDL_VIDEODRIVER=offscreen
export XDG_CACHE_HOME SDL_VIDEODRIVER

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
log_level = info
# The filter jobs below must succeed however busy the machine.
filter_timeout_ms = $((GV_TEST_PATIENCE * 1000))
EOF2
start_daemon "$T/d.conf"

# ---------------------------------------------------------------- built?
printf 'quit\n' >"$T/quit.txt"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --script "$T/quit.txt" --size 64x64
if grep -q 'needs a build with' "$T/err"; then
    check "not built: view exits 1 and says what it needs" test "$rc" -eq 1
    stop_daemon
    done_testing
fi
if [ "$rc" -ne 0 ]; then
    skip "gigaview view" "no window: $(head -c 300 "$T/err")"
    stop_daemon
    done_testing
fi
ok "view opens a window and quits (exit 0)"

# same_as_render DESC SHOT IMAGE CX,CY ZOOM [ROT]: the shot equals render.
same_as_render() {
    rm -f r.png
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image "$3" --center "$4" --zoom "$5" --rotate "${6:-0}" \
        --size 640x480 -o r.png
    if [ "$rc" -ne 0 ]; then
        not_ok "$1 (render exit $rc)" "$(cat "$T/err")"
    elif [ ! -f "$2" ]; then
        not_ok "$1 (no $2)" "$(cat "$T/view.err" 2>/dev/null)"
    elif idiff -a "$2" r.png >"$T/idiff" 2>&1; then
        ok "$1"
    else
        not_ok "$1" "$(tail -n 4 "$T/idiff")"
    fi
}

# ---------------------------------------------------------------- bit for bit
cat >"$T/views.txt" <<EOF2
# level 0 across the tile corner at (512, 512) and the image's last tile
view 512,512,0
settle $PMS
shot v1.png
view 2700,1850,0
settle $PMS
shot v2.png
# level 1 at 1:1 (centre on texel centres), the middle of the image
view 1500,1000,1
settle $PMS
shot v3.png
# the gray image, from a browser link
view http://host/#image=g&x=650&y=550&z=0&r=0
settle $PMS
shot v4.png
# back to x, through an image switch
view #image=x&x=1100&y=900&z=0&r=0
settle $PMS
shot v5.png
EOF2
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/views.txt" -v \
    --stats "$T/views.tsv"
cp "$T/err" "$T/view.err"
expect_rc "the views script runs" 0
# Each image opened (one metadata request) fetched its root in one
# request, the store's lossless WebP (200, or 304 from the disk cache),
# and never the raw mips; the frames below show it decoded exactly.
nopen=$(grep -c 'GET [^ ]*/v1/images/[^/ ]* -> 200' "$T/view.err")
nwebp=$(grep -c 'GET [^ ]*/v1/images/[^/ ]*/root?format=webp -> [23]0[04]' "$T/view.err")
check "the root came as WebP, one request per image opened ($nwebp for $nopen)" \
    test "$nwebp" -ge 3 -a "$nwebp" = "$nopen"
check "no raw root mip was fetched" sh -c "! grep -q 'format=raw' '$T/view.err'"
check "x opened again: its WebP root revalidated from the disk cache (304)" \
    grep -q 'GET [^ ]*/v1/images/x/root?format=webp -> 304' "$T/view.err"
same_as_render "level 0 across a tile corner equals render" v1.png x 512,512 0
same_as_render "level 0, the last tiles equal render" v2.png x 2700,1850 0
same_as_render "level 1 at 1:1 equals render" v3.png x 1500,1000 1
same_as_render "gray image opened from a link equals render" v4.png g 650,550 0
same_as_render "after switching back to x, equals render" v5.png x 1100,900 0

# Those frames came from the decode thread (a GL context sharing the
# window's: jobs in flight show in --stats' ninth column); without it
# (--no-decode-thread: decoding in the frame) they are the same bit for
# bit.  Where no shared context can be made the viewer says so and
# decodes in the frame.
if grep -q 'no decode thread' "$T/view.err"; then
    skip "the decode thread" "$(grep -m1 'no decode thread' "$T/view.err")"
else
    check "the views were decoded on the decode thread" \
        grep -q '; decode thread, ' "$T/view.err"
    check "decode jobs were in flight between frames" \
        awk -F'\t' 'NR > 1 && $9 > 0 { f = 1 } END { exit !f }' "$T/views.tsv"
fi
mkdir thread && mv v1.png v2.png v3.png v4.png v5.png thread/ || bail "mv"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/views.txt" -v \
    --no-decode-thread --stats "$T/views.tsv"
expect_rc "the views script runs with --no-decode-thread" 0
check "--no-decode-thread decodes in the frame" grep -q '; decode in frame, ' "$T/err"
check "--no-decode-thread: no job is ever in flight" \
    awk -F'\t' 'NR > 1 && $9 > 0 { f = 1 } END { exit f }' "$T/views.tsv"
same=0
for v in 1 2 3 4 5; do
    cmp -s "thread/v$v.png" "v$v.png" && same=$((same + 1))
done
check "the same five frames with and without the decode thread ($same)" test "$same" -eq 5
# Quitting (and switching images) while decodes are in flight joins the
# decode thread cleanly.
printf 'view 1500,1000,1\nframes 2\nkey Tab\nframes 2\nquit\n' >"$T/busy.txt"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/busy.txt"
expect_rc "quitting with decodes in flight" 0

# After evictions: 16 MiB of GPU memory leaves the atlas a few layers, so
# the later views evict the tiles of the first, which is drawn again.
cat >"$T/evict.txt" <<EOF2
view 512,512,0
settle $PMS
view 2700,1850,0
settle $PMS
view 300,1800,0
settle $PMS
view 2600,300,0
settle $PMS
view 512,512,0
settle $PMS
shot e1.png
view 2700,1850,0
settle $PMS
shot e2.png
EOF2
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --gpu-cache 16 --script "$T/evict.txt" -v
cp "$T/err" "$T/view.err"
expect_rc "the eviction script runs" 0
ev=$(sed -n 's/.* \([0-9][0-9]*\) atlas evictions.*/\1/p' "$T/err")
check "the small atlas evicted tiles (${ev:-none})" test "${ev:-0}" -gt 0
same_as_render "after evictions, a view equals render" e1.png x 512,512 0
same_as_render "after evictions, another view equals render" e2.png x 2700,1850 0

# A sabotaged decode must fail the comparison.
GIGAVIEW_VIEW_SABOTAGE=decode
export GIGAVIEW_VIEW_SABOTAGE
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/views.txt"
unset GIGAVIEW_VIEW_SABOTAGE
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --center 512,512 --zoom 0 --size 640x480 -o r.png
if idiff -a v1.png r.png >/dev/null 2>&1; then
    not_ok "a sabotaged decode differs from render" "the comparison cannot fail"
else
    ok "a sabotaged decode differs from render"
fi

# ---------------------------------------------------------------- input
# From 1500,1000 at 1:1: a drag by (-100, -100) moves the centre by
# (100, 100); Right pans a fifth of the window (128); a wheel notch at the
# centre zooms in half a level about it; R turns 15 degrees; Home shows
# the whole image (3000x2000 in 640x480: zoom log2(3000/640)).
cat >"$T/input.txt" <<EOF2
view 1500,1000,0
settle $PMS
drag 320 240 220 140
settle $PMS
shot i1.png
print drag
key Right
settle $PMS
print right
wheel 320 240 1
settle $PMS
print wheel
key R
settle $PMS
print rotate
key shift+R
key Home
settle $PMS
print home
EOF2
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/input.txt"
cp "$T/err" "$T/view.err"
expect_rc "the input script runs" 0
check "drag pans with the pointer" grep -qx 'drag #image=x&x=1600&y=1100&z=0&r=0' "$T/out"
check "Right pans a fifth of the window" grep -qx 'right #image=x&x=1728&y=1100&z=0&r=0' "$T/out"
check "a wheel notch zooms in half a level about the pointer" \
    grep -qx 'wheel #image=x&x=1728&y=1100&z=-0.5&r=0' "$T/out"
check "R turns 15 degrees" grep -qx 'rotate #image=x&x=1728&y=1100&z=-0.5&r=15' "$T/out"
check "Home shows the whole image" grep -qx 'home #image=x&x=1500&y=1000&z=2.2288&r=0' "$T/out"
same_as_render "the frame after the drag equals render" i1.png x 1600,1100 0

# ---------------------------------------------------------------- gamepad, touch
# Synthetic SDL events from the script.  From 1500,1000 at 1:1: the right
# shoulder turns 15 degrees, the left one back (twice: -15); a finger
# dragged by (-100, -100) pans like the mouse; a pinch whose fingers move
# apart by a quarter of the window (log2(1 + 4 * 0.25) = 1) zooms in one
# level about their midpoint; the left stick held right pans right and
# the right trigger zooms in (by amounts that depend on the frame times:
# only their direction is checked).
cat >"$T/pad.txt" <<EOF2
view 1500,1000,0
settle $PMS
pad-button rightshoulder
settle $PMS
print rshoulder
pad-button leftshoulder
pad-button leftshoulder
settle $PMS
print lshoulder
view 1500,1000,0
settle $PMS
touch 320 240 220 140
settle $PMS
print touch
view 1500,1000,0
settle $PMS
pinch 320 240 0.25 0
settle $PMS
print pinch
view 1500,1000,0
settle $PMS
pad-axis leftx 1
frames 10
pad-axis leftx 0
settle $PMS
print stick
view 1500,1000,0
settle $PMS
pad-axis righttrigger 1
frames 10
pad-axis righttrigger 0
settle $PMS
print trigger
EOF2
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/pad.txt"
cp "$T/err" "$T/view.err"
expect_rc "the gamepad and touch script runs" 0
check "the right shoulder turns 15 degrees" grep -qx 'rshoulder #image=x&x=1500&y=1000&z=0&r=15' "$T/out"
check "the left shoulder turns back" grep -qx 'lshoulder #image=x&x=1500&y=1000&z=0&r=-15' "$T/out"
check "a finger drag pans with the finger" grep -qx 'touch #image=x&x=1600&y=1100&z=0&r=0' "$T/out"
check "a pinch zooms in a level about the fingers" grep -qx 'pinch #image=x&x=1500&y=1000&z=-1&r=0' "$T/out"
check "the left stick pans right" awk -F'[=&]' '/^stick /{ok = $4 > 1500 && $6 == 1000 && $8 == 0} END{exit !ok}' "$T/out"
check "the right trigger zooms in" awk -F'[=&]' '/^trigger /{ok = $4 == 1500 && $6 == 1000 && $8 < 0} END{exit !ok}' "$T/out"

# ---------------------------------------------------------------- filters
# A region filtered by the server, drawn in place.  From 1500,1000 at 1:1
# in 640x480, window pixels (100, 100)-(300, 250) show level-0 pixels
# (1280, 860) to (1480, 1010): the frame's pixels there equal the
# server's negate of that region; the gamma graph, and its parameter
# stepped (Page Up), give other pixels; Delete clears; a Shift-drag does
# what `filter` does; a graph the server lacks is a 404 shown as an error
# while the window goes on.
code=$(curl -s -o neg.png -w '%{http_code}' -H 'Content-Type: application/json' \
    -d '{"filter":"negate","level":0,"region":[1280,860,200,150]}' "$BASE/v1/images/x/filter")
if [ "$code" != 200 ]; then
    skip "filters in the viewer" "the server runs no filters here (HTTP $code)"
else
    cat >"$T/filt.txt" <<EOF2
view 1500,1000,0
settle $PMS
shot n0.png
filter 100 100 300 250
settle $PMS
shot n1.png
graph gamma
settle $PMS
shot n2.png
param +
settle $PMS
shot n3.png
key Delete
settle $PMS
shot n4.png
graph negate
down 100 100 shift
move 200 200
up 300 250
settle $PMS
shot n5.png
graph no-such-graph
filter 100 100 300 250
settle $PMS
message after-error
EOF2
    run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/filt.txt" -v
    cp "$T/err" "$T/view.err"
    expect_rc "the filter script runs on after a refused graph" 0
    check "the filter asked for the region under the rectangle" \
        grep -q 'view: filter negate level 0 region 1280,860,200,150' "$T/err"
    cut_eq() {  # cut_eq DESC SHOT REF: SHOT's region equals REF
        if oiiotool "$2" --cut 200x150+100+100 -o "c-$2" >/dev/null 2>&1 &&
            idiff -a "c-$2" "$3" >"$T/idiff" 2>&1; then
            ok "$1"
        else
            not_ok "$1" "$(tail -n 4 "$T/idiff" 2>/dev/null)"
        fi
    }
    differ() {  # differ DESC A B: the shots differ
        if [ -f "$2" ] && [ -f "$3" ] && ! idiff -a "$2" "$3" >/dev/null 2>&1; then
            ok "$1"
        else
            not_ok "$1" "no $2 or $3, or they are equal"
        fi
    }
    cut_eq "the filtered region equals the server's negate, in place" n1.png neg.png
    differ "the region changed" n0.png n1.png
    check "choosing the gamma graph ran it again with its default" \
        grep -q 'view: filter gamma level 0 region 1280,860,200,150 param gamma=0.5$' "$T/err"
    differ "gamma draws other pixels than negate" n1.png n2.png
    check "Page Up stepped the parameter a tenth of its range" \
        grep -q 'view: filter gamma .* param gamma=1.49$' "$T/err"
    differ "the stepped parameter draws other pixels" n2.png n3.png
    if idiff -a n4.png n0.png >/dev/null 2>&1; then
        ok "Delete clears the result"
    else
        not_ok "Delete clears the result" "n4.png differs from the unfiltered frame"
    fi
    cut_eq "a Shift-drag filters the same region" n5.png neg.png
    check "a refused graph shows the server's error" grep -q 'filter: HTTP 4[0-9][0-9]' "$T/err"
    check "the overlay shows the error, and the window went on" \
        grep -q '^after-error filter: HTTP 4[0-9][0-9]' "$T/out"
fi

# ---------------------------------------------------------------- bad script
printf 'view 1,2,0\nsettle\nfly 3\n' >"$T/bad.txt"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --script "$T/bad.txt"
expect_rc "an unknown script command is a usage error" 2
expect_err "the message names the line" 'bad.txt:3: unknown command'

# ---------------------------------------------------------------- faults
# proxy.py MODE UPSTREAM PORTFILE GATE: a proxy.  MODE fail (tiles
# answered 500) or hold (tile answers held), either until the file GATE
# exists; oldroot: the root's WebP form answered 400, as a server older
# than it does; hang-tiles or hang-filter: every tile request, or the
# filter job's POST, held for ever after creating the file GATE (the
# prompt-quit checks below).  Everything else passes through.
cat >"$T/proxy.py" <<'PY'
import http.server, os, sys, time, urllib.request, urllib.error
mode, upstream, portfile, gate = sys.argv[1:5]
class H(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    def log_message(self, *a): pass
    def do_POST(self):
        self.do_GET(self.rfile.read(int(self.headers.get("Content-Length", 0))))
    def do_GET(self, data=None):
        tile = "/tiles/" in self.path or "/batch" in self.path
        job = data is not None and self.path.endswith("/filter")
        if (mode == "hang-tiles" and tile) or (mode == "hang-filter" and job):
            open(gate, "w").close()
            while True:
                time.sleep(1)
        if tile and mode == "hold":
            while not os.path.exists(gate):
                time.sleep(0.05)
        if tile and mode == "fail" and not os.path.exists(gate):
            status, ctype = 500, "application/json"
            body = b'{"error":{"status":500,"code":"io_error","message":"injected"}}'
        elif mode == "oldroot" and "/root?" in self.path and "format=webp" in self.path:
            status, ctype = 400, "application/json"
            body = b'{"error":{"status":400,"code":"bad_request","message":"root: format must be png or raw"}}'
        else:
            hdrs = {k: self.headers[k] for k in ("Content-Type", "If-None-Match") if self.headers[k]}
            try:
                with urllib.request.urlopen(urllib.request.Request(upstream + self.path, data, hdrs)) as r:
                    status, body, ctype = r.status, r.read(), r.headers.get("Content-Type")
            except urllib.error.HTTPError as e:
                status, body, ctype = e.code, e.read(), e.headers.get("Content-Type")
        self.send_response(status)
        self.send_header("Content-Type", ctype or "application/octet-stream")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)
s = http.server.ThreadingHTTPServer(("127.0.0.1", 0), H)
s.daemon_threads = True
open(portfile + ".tmp", "w").write(str(s.server_address[1]))
os.rename(portfile + ".tmp", portfile)
s.serve_forever()
PY
PPID_=
VPID=
proxy_stop() {
    [ -n "$PPID_" ] && kill "$PPID_" 2>/dev/null && wait "$PPID_" 2>/dev/null
    PPID_=
}
view_stop() {
    [ -n "$VPID" ] && kill "$VPID" 2>/dev/null && wait "$VPID" 2>/dev/null
    VPID=
}
trap 'view_stop; proxy_stop; http_cleanup' EXIT
# shellcheck disable=SC2317 # run by wait_until
proxy_up() {
    [ -s "$T/proxy.port" ] || ! kill -0 "$PPID_" 2>/dev/null
}
proxy_start() {
    rm -f "$T/proxy.port"
    python3 "$T/proxy.py" "$1" "$BASE" "$T/proxy.port" "$2" 2>"$T/proxy.log" &
    PPID_=$!
    wait_until proxy_up
    [ -s "$T/proxy.port" ] || bail "proxy did not start: $(cat "$T/proxy.log")"
    PROXY="http://127.0.0.1:$(cat "$T/proxy.port")"
}
# seen_or_ended FILE PATTERN: a line of FILE matches, or the viewer ended.
# shellcheck disable=SC2317 # run by wait_until
seen_or_ended() {
    grep -q "$2" "$1" 2>/dev/null || ! kill -0 "$VPID" 2>/dev/null
}
# wait_for FILE PATTERN: until a line of FILE matches (or the viewer ended).
wait_for() {
    wait_until seen_or_ended "$1" "$2"
    grep -q "$2" "$1" 2>/dev/null
}
# view_bg URL SCRIPT ARGS...: the viewer in the background, output in
# $T/vout and $T/verr; view_wait: its exit status in $vrc.
view_bg() {
    u=$1 s=$2
    shift 2
    gv view "$u" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --no-cache --script "$s" -v "$@" \
        >"$T/vout" 2>"$T/verr" &
    VPID=$!
}
view_wait() {
    vrc=0
    wait "$VPID" || vrc=$?
    VPID=
    cp "$T/verr" "$T/view.err"
}

# A tile answered 500: the window draws the ancestors (the root mips come
# through), asks again, and recovers once the server answers.
rm -f "$T/gate"
proxy_start fail "$T/gate"
cat >"$T/f500.txt" <<EOF2
view 1100,900,0
frames 20
shot f1.png
wait-file $T/gate $PMS
settle $PMS
shot f2.png
EOF2
view_bg "$PROXY" "$T/f500.txt"
if wait_for "$T/verr" 'HTTP 500'; then
    ok "500: the viewer saw the failure"
else
    not_ok "500: the viewer saw the failure" "$(tail -n 5 "$T/verr")"
fi
touch "$T/gate"
view_wait
proxy_stop
check "500: the window kept drawing (a frame during the failures, exit $vrc)" \
    test "$vrc" -eq 0 -a -f f1.png
same_as_render "500: after recovery the frame equals render" f2.png x 1100,900 0

# A server without the root's WebP form (400): the viewer fetches the raw
# mips instead, one request each, and draws the same frame.
proxy_start oldroot ""
printf 'view 512,512,0\nsettle %s\nshot o1.png\n' "$PMS" >"$T/old.txt"
view_bg "$PROXY" "$T/old.txt"
view_wait
proxy_stop
check "old server: the viewer asked for the WebP root once, got 400 (exit $vrc)" \
    test "$(grep -c 'root?format=webp -> 400' "$T/view.err")" = 1
check "old server: ... then the 8 raw root mips, one request each" \
    test "$(grep -c 'root?mip=[0-9]*&format=raw -> 200' "$T/view.err")" = 8
same_as_render "old server: the frame from the raw root mips equals render" o1.png x 512,512 0

# A server that holds tile answers: frames go on (30 of them, and one
# written) while the request hangs, then the view completes.
rm -f "$T/gate"
proxy_start hold "$T/gate"
cat >"$T/hold.txt" <<EOF2
view 1700,1100,0
frames 30
shot h1.png
print held
wait-file $T/gate $PMS
settle $PMS
shot h2.png
EOF2
view_bg "$PROXY" "$T/hold.txt"
if wait_for "$T/vout" '^held'; then
    ok "slow server: 30 frames drawn while the tiles were held"
else
    not_ok "slow server: 30 frames drawn while the tiles were held" "$(tail -n 5 "$T/verr")"
fi
touch "$T/gate"
view_wait
proxy_stop
check "slow server: the view completes (exit $vrc)" test "$vrc" -eq 0
same_as_render "slow server: the final frame equals render" h2.png x 1700,1100 0
if [ -f h1.png ] && ! idiff -a h1.png h2.png >/dev/null 2>&1; then
    ok "slow server: the held frame was drawn from ancestors"
else
    not_ok "slow server: the held frame was drawn from ancestors" "no h1.png, or it is final"
fi

# gigaviewd stopped mid-pan and started again on the same port.
cat >"$T/down.txt" <<EOF2
view 600,600,0
settle $PMS
print ready
wait-file $T/stopped $PMS
drag 600 240 40 240 4
frames 20
shot d1.png
print panned
wait-file $T/restarted $PMS
settle $PMS
shot d2.png
EOF2
rm -f "$T/stopped" "$T/restarted"
view_bg "$BASE" "$T/down.txt"
wait_for "$T/vout" '^ready' || not_ok "server down: the first view settles" "$(tail -n 5 "$T/verr")"
OLDPORT=$PORT
stop_daemon
touch "$T/stopped"
if wait_for "$T/verr" 'view: tile '; then
    ok "server down: the viewer saw the failures"
else
    not_ok "server down: the viewer saw the failures" "$(tail -n 5 "$T/verr")"
fi
wait_for "$T/vout" '^panned' || true
sed "s/^port = 0/port = $OLDPORT/" "$T/d.conf" >"$T/d2.conf"
: >"$T/daemon.log"
(gvd -c "$T/d2.conf") 2>>"$T/daemon.log" &
DPID=$!
# shellcheck disable=SC2317 # run by wait_until
listening_or_gone() {
    grep -q 'listening on' "$T/daemon.log" || ! kill -0 "$DPID" 2>/dev/null
}
wait_until listening_or_gone
touch "$T/restarted"
view_wait
check "server down: the window kept drawing while it was down (exit $vrc)" \
    test "$vrc" -eq 0 -a -f d1.png
pan=$(sed -n 's/^panned #image=x&x=\([0-9.]*\)&y=\([0-9.]*\)&.*/\1,\2/p' "$T/vout")
check "server down: the pan moved the view (${pan:-?})" test "$pan" = "1160,600"
same_as_render "server down: after the restart the frame equals render" d2.png x 1160,600 0

# ================================================================
# Selection drawn while Shift-dragging, and a prompt quit while a request
# hangs (follow-up; this block is self-contained: it only uses
# $BASE, the helpers above, and files of its own).
# ================================================================

# ---------------------------------------------------------------- selection
# px.py: pixel checks on screenshots (converted to PPM by oiiotool).
#   px.py FILE X Y R G B      the pixel is exactly that colour
#   px.py same A B X Y        A's pixel equals B's
#   px.py fill A B X Y        A's pixel is B's blended with white at 0.25 (+-1)
#   px.py ink A B X0 Y0 X1 Y1 A has 20 more pure white pixels there than B
#   px.py edge A B Y X0 X1    along row Y from X0 towards X1 of A: B's
#                             pixels, then black, then white, then B's
#                             blended (fill)
cat >"$T/px.py" <<'PY'
import os, subprocess, sys
def load(f):
    ppm = f + ".ppm"
    if not os.path.exists(ppm):
        subprocess.run(["oiiotool", f, "--ch", "R,G,B", "-o", ppm], check=True,
                       stdout=subprocess.DEVNULL)
    b = open(ppm, "rb").read()
    parts, i = [], 0
    while len(parts) < 4:
        while b[i:i+1].isspace(): i += 1
        j = i
        while not b[j:j+1].isspace(): j += 1
        parts.append(b[i:j]); i = j
    w, h = int(parts[1]), int(parts[2])
    return w, b[i+1:]
def px(img, x, y):
    w, d = img
    o = (y * w + x) * 3
    return tuple(d[o:o+3])
def blend(p):
    return tuple(v + (255 - v) * 0.25 for v in p)
def is_fill(a, b):
    return all(abs(u - v) <= 1.01 for u, v in zip(a, blend(b)))
a = sys.argv[1:]
if a[0] == "same":
    A, B = load(a[1]), load(a[2]); x, y = int(a[3]), int(a[4])
    ok = px(A, x, y) == px(B, x, y); why = (px(A, x, y), px(B, x, y))
elif a[0] == "fill":
    A, B = load(a[1]), load(a[2]); x, y = int(a[3]), int(a[4])
    ok = is_fill(px(A, x, y), px(B, x, y)); why = (px(A, x, y), px(B, x, y))
elif a[0] == "ink":
    A, B = load(a[1]), load(a[2]); x0, y0, x1, y1 = map(int, a[3:7])
    n = lambda I: sum(px(I, x, y) == (255, 255, 255) for x in range(x0, x1) for y in range(y0, y1))
    ok = n(A) >= n(B) + 20; why = (n(A), n(B))
elif a[0] == "edge":
    A, B = load(a[1]), load(a[2]); y, x0, x1 = map(int, a[3:6])
    step = 1 if x1 > x0 else -1
    row = [(px(A, x, y), px(B, x, y)) for x in range(x0, x1, step)]
    k = 0
    while k < len(row) and row[k][0] == row[k][1]: k += 1
    dark = k
    while k < len(row) and row[k][0] == (0, 0, 0): k += 1
    light = k
    while k < len(row) and row[k][0] == (255, 255, 255): k += 1
    rest = row[k:]
    ok = 0 < dark < light < k < len(row) and all(is_fill(p, q) for p, q in rest)
    why = ("outside to", x0 + step * dark, "dark to", x0 + step * light,
           "light to", x0 + step * k, row)
else:
    A = load(a[0]); x, y = int(a[1]), int(a[2])
    want = tuple(map(int, a[3:6]))
    ok = px(A, x, y) == want; why = (px(A, x, y), "wanted", want)
if not ok:
    print("#  ", why)
sys.exit(0 if ok else 1)
PY
# From 1500,1000 at 1:1 in 640x480 a Shift-drag from (100, 100) is shot
# mid-way at (200, 200) and at (300, 250): the region's edges lie between
# a black outline just outside (column 99, row 99, ...) and a white one
# just inside (column 100, ...); inside is the picture blended with white;
# everything else equals the frame without a drag; the size label
# ("200 X 150 PX") is drawn below.  Esc cancels the drag (the frame is
# the plain one again, and the release filters nothing); a release
# filters the region drawn (a graph the server lacks, so nothing is drawn
# after it) and the outline goes.  Turned by 45 degrees, a 200x200 drag
# about the centre selects its image-space bounding box, 284 pixels wide
# (floor/ceil of 1500 -+ 141.42): drawn as a diamond with corners 200.8
# window pixels from the centre, which holds the dragged square.
cat >"$T/sel.txt" <<EOF2
graph no-such-graph
view 1500,1000,0
settle $PMS
shot s0.png
down 100 100 shift
move 200 200
shot s1.png
move 300 250
shot s2.png
key Escape
shot s3.png
up 300 250
frames 3
shot s4.png
print after-escape
down 100 100 shift
move 300 250
up 300 250
settle $PMS
shot s5.png
view 1500,1000,0,45
settle $PMS
shot r0.png
down 220 140 shift
move 420 340
shot r1.png
up 420 340
settle $PMS
shot r2.png
EOF2
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --size 640x480 --script "$T/sel.txt" -v
cp "$T/err" "$T/view.err"
expect_rc "selection: the drag script runs, Esc does not quit it" 0
pxc() {  # pxc DESC ARGS...: a px.py check
    d=$1
    shift
    if python3 "$T/px.py" "$@" >"$T/px.out" 2>&1; then ok "$d"; else not_ok "$d" "$(cat "$T/px.out")"; fi
}
pxc "selection mid-drag: black outline left of the region" s1.png 99 150 0 0 0
pxc "selection mid-drag: white outline on its first column" s1.png 100 150 255 255 255
pxc "selection mid-drag: white outline on its last column" s1.png 199 150 255 255 255
pxc "selection mid-drag: black outline right of it" s1.png 200 150 0 0 0
pxc "selection mid-drag: black outline above" s1.png 150 99 0 0 0
pxc "selection mid-drag: white outline on its first row" s1.png 150 100 255 255 255
pxc "selection mid-drag: white outline on its last row" s1.png 150 199 255 255 255
pxc "selection mid-drag: black outline below" s1.png 150 200 0 0 0
pxc "selection mid-drag: black corner" s1.png 99 99 0 0 0
pxc "selection mid-drag: inside is the picture with a light fill" fill s1.png s0.png 150 150
pxc "selection mid-drag: the fill reaches the white outline" fill s1.png s0.png 101 198
pxc "selection mid-drag: left of it is the plain picture" same s1.png s0.png 98 150
pxc "selection mid-drag: right of it is the plain picture" same s1.png s0.png 201 150
pxc "selection mid-drag: above it is the plain picture" same s1.png s0.png 150 98
pxc "selection mid-drag: far away is the plain picture" same s1.png s0.png 500 100
pxc "selection follows the pointer: new right edge" s2.png 300 150 0 0 0
pxc "selection follows the pointer: new bottom edge" s2.png 150 250 0 0 0
pxc "selection follows the pointer: white inside the new edge" s2.png 299 249 255 255 255
pxc "selection follows the pointer: the old edge is gone (fill)" fill s2.png s0.png 200 150
pxc "selection follows the pointer: outside the new edge is plain" same s2.png s0.png 301 150
pxc "selection: its size is labelled below it" ink s2.png s0.png 100 254 300 284
check "selection: Esc gives back the plain frame" idiff -a s3.png s0.png
check "selection: a release after Esc filters nothing" idiff -a s4.png s0.png
check "selection: the script went on after Esc" grep -qx 'after-escape #image=x&x=1500&y=1000&z=0&r=0' "$T/out"
check "selection: the release asked for the region drawn" \
    grep -q 'view: filter no-such-graph level 0 region 1280,860,200,150 ' "$T/err"
check "selection: the release after Esc asked for nothing" \
    test "$(grep -c 'view: filter no-such-graph level' "$T/err")" -eq 2
check "selection: after the release the outline is gone" idiff -a s5.png s0.png
check "selection turned: the release asked for the bounding box" \
    grep -q 'view: filter no-such-graph level 0 region 1358,858,284,284 ' "$T/err"
pxc "selection turned: the upper left edge crosses row 200 near x=159" edge r1.png r0.png 200 140 181
pxc "selection turned: the upper right edge crosses row 200 near x=481" edge r1.png r0.png 200 501 460
pxc "selection turned: filled above the dragged square (bounding box)" fill r1.png r0.png 320 100
pxc "selection turned: filled near the top corner" fill r1.png r0.png 320 45
pxc "selection turned: plain above the top corner" same r1.png r0.png 320 30
pxc "selection turned: plain right of the right corner" same r1.png r0.png 530 240
check "selection turned: after the release the outline is gone" idiff -a r2.png r0.png

# ---------------------------------------------------------------- prompt quit
# The proxy above in its hang modes holds every tile request, or the
# filter job's POST, for ever after creating $T/held.  The viewer runs
# with a request timeout of 8 x GV_TEST_PATIENCE s under `timeout` of 2 x
# GV_TEST_PATIENCE: quitting while the request hangs must end it by
# itself with status 0 (124 would be the wrapper's kill: the quit waited
# on the request).
# hang_start MODE: the proxy in mode hang-MODE at $HANG, marking $T/held.
hang_start() {
    rm -f "$T/held"
    proxy_start "hang-$1" "$T/held"
    HANG=$PROXY
}
# hang_view SCRIPT: the viewer at $HANG under `timeout` (valgrind too
# when the suite runs under it), in the background as VPID.
hang_view() {
    vg=
    if under_valgrind; then vg="valgrind -q --error-exitcode=99"; fi
    timeout -k 5 $((GV_TEST_PATIENCE * 2)) $vg "$GIGAVIEW" view "$HANG" --image x \
        --size 640x480 --no-cache --timeout $((GV_TEST_PATIENCE * 8)) \
        --script "$1" -v >"$T/vout" 2>"$T/verr" &
    VPID=$!
}
# The scripts' wait for $T/held (which must come), and for a file that
# never comes (until SIGINT): past the wrapper's kill either way.
HELD_MS=$((GV_TEST_PATIENCE * 1000))
NEVER_MS=$((GV_TEST_PATIENCE * 8000))

# Quit (the script's, as Esc or closing the window) while tiles hang.
hang_start tiles
printf 'view 1700,1100,0\nwait-file %s %s\nquit\n' "$T/held" "$HELD_MS" >"$T/hq.txt"
hang_view "$T/hq.txt"
view_wait
check "quit while a tile request hangs: exits by itself (exit $vrc)" test "$vrc" -eq 0
check "quit while a tile request hangs: it was held" test -f "$T/held"
proxy_stop

# Ctrl+C (SIGINT) while tiles hang: SDL turns it into a quit.
hang_start tiles
printf 'view 1700,1100,0\nwait-file %s/never %s\n' "$T" "$NEVER_MS" >"$T/hi.txt"
hang_view "$T/hi.txt"
# shellcheck disable=SC2317 # run by wait_until
held_or_ended() {
    [ -f "$T/held" ] || ! kill -0 "$VPID" 2>/dev/null
}
wait_until held_or_ended
kill -INT "$VPID" 2>/dev/null
view_wait
check "Ctrl+C while a tile request hangs: exits by itself (exit $vrc)" test "$vrc" -eq 0
proxy_stop

# Quit while the filter job's POST hangs (tiles come through).
hang_start filter
printf 'view 1500,1000,0\nsettle %s\nfilter 100 100 300 250\nwait-file %s %s\nquit\n' \
    "$PMS" "$T/held" "$HELD_MS" >"$T/hf.txt"
hang_view "$T/hf.txt"
view_wait
check "quit while a filter job hangs: exits by itself (exit $vrc)" test "$vrc" -eq 0
check "quit while a filter job hangs: it was held" test -f "$T/held"
proxy_stop

stop_daemon
done_testing
