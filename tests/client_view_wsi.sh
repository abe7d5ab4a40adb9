#!/bin/sh
# client_view_wsi.sh - the native viewer (`gigaview view`) in real window
# systems rather than SDL's offscreen driver: on X11 (an Xvfb server) and
# on Wayland (weston's X11 backend nested in that Xvfb: weston's headless
# backend has no seat, and SDL 2.26's Wayland start-up crashes without
# one).  Both run Mesa's llvmpipe through EGL on the window system's
# platform, with the decode thread's shared context.
#
# Covers, on each: the window opens, the scripted views are drawn, and the
# frames at 1:1 equal `gigaview render` of the same views bit for bit (a
# level-0 view across a tile corner and a level-1 view), on the decode
# thread.  Skips a window system whose server (Xvfb, weston) is not
# installed, and everything when the build has no viewer.  Needs oiiotool
# and idiff.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
# The client's bounds on what must come get GV_TEST_PATIENCE: each HTTP
# request (--timeout; 30 s by default) and a script's settle and
# wait-file (PMS milliseconds; 60 s by default).
PMS=$((GV_TEST_PATIENCE * 1000))
# As in client_view.sh: the GL driver's allocations from an unloaded
# module are reported as leaks at exit; memory-error checks stay on.
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}detect_leaks=0"
need_tool oiiotool idiff
if under_valgrind; then
    skip "window systems" "llvmpipe under valgrind is too slow"
    done_testing
fi

S=$T/stores
mkdir "$S" "$T/w" "$T/cache" || bail "mkdir"
cd "$T/w" || bail "cd"
XDG_CACHE_HOME=$T/cache
export XDG_CACHE_HOME

run encode synth:1500x1100 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
cat >"$T/d.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
log_level = info
EOF2
start_daemon "$T/d.conf"

xpid="" wpid=""
stop_servers() {
    [ -n "$wpid" ] && kill "$wpid" 2>/dev/null
    [ -n "$xpid" ] && kill "$xpid" 2>/dev/null
    [ -n "$wpid" ] && wait "$wpid" 2>/dev/null
    [ -n "$xpid" ] && wait "$xpid" 2>/dev/null
    wpid="" xpid=""
}
trap 'stop_servers; http_cleanup' EXIT

# Is there a viewer at all?
printf 'quit\n' >"$T/quit.txt"
SDL_VIDEODRIVER=offscreen
export SDL_VIDEODRIVER
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --script "$T/quit.txt" --size 64x64
if grep -q 'needs a build with' "$T/err"; then
    skip "window systems" "the build has no viewer"
    done_testing
fi

cat >"$T/views.txt" <<EOF2
view 512,512,0
settle $PMS
shot v1.png
view 700,500,1
settle $PMS
shot v2.png
quit
EOF2
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --center 512,512 --zoom 0 --size 640x480 -o r1.png
[ "$rc" -eq 0 ] || bail "render: $(cat "$T/err")"
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --center 700,500 --zoom 1 --size 640x480 -o r2.png
[ "$rc" -eq 0 ] || bail "render: $(cat "$T/err")"

# on_window_system NAME: run the views script with the environment set by
# the caller, then check the frames against render's.
on_window_system() {
    rm -f v1.png v2.png
    rc=0
    # A hang guard for the whole run: many waits, each up to
    # GV_TEST_PATIENCE (--timeout, the script's settle).
    timeout -k 5 $((GV_TEST_PATIENCE * 4)) "$GIGAVIEW" view "$BASE" --image x --size 640x480 \
        --timeout "$GV_TEST_PATIENCE" \
        --script "$T/views.txt" --no-cache -v >"$T/out" 2>"$T/err" || rc=$?
    expect_rc "$1: the views script runs" 0
    check "$1: drawn with the decode thread" grep -q '; decode thread, ' "$T/err"
    for v in 1 2; do
        if [ ! -f "v$v.png" ]; then
            not_ok "$1: view $v equals render" "no frame: $(tail -n 3 "$T/err")"
        elif idiff -a "v$v.png" "r$v.png" >"$T/idiff" 2>&1; then
            ok "$1: view $v equals render bit for bit"
        else
            not_ok "$1: view $v equals render" "$(tail -n 4 "$T/idiff")"
        fi
    done
}

# ---------------------------------------------------------------- X11
if ! command -v Xvfb >/dev/null 2>&1; then
    skip "X11" "no Xvfb (apt-get install xvfb)"
    skip "Wayland" "no Xvfb to nest weston in"
    done_testing
fi
# -displayfd: Xvfb picks a free display and writes its number once ready.
Xvfb -displayfd 3 -screen 0 1024x768x24 -nolisten tcp 3>"$T/xdisplay" \
    >"$T/xvfb.log" 2>&1 &
xpid=$!
# shellcheck disable=SC2317 # run by wait_until
x_ready() {
    [ -s "$T/xdisplay" ] || ! kill -0 "$xpid" 2>/dev/null
}
wait_until x_ready
if [ ! -s "$T/xdisplay" ]; then
    skip "X11" "Xvfb did not start: $(tail -n 2 "$T/xvfb.log")"
    skip "Wayland" "no X server to nest weston in"
    done_testing
fi
DISPLAY=:$(cat "$T/xdisplay")
export DISPLAY
SDL_VIDEODRIVER=x11
on_window_system X11

# ---------------------------------------------------------------- Wayland
if ! command -v weston >/dev/null 2>&1; then
    skip "Wayland" "no weston (apt-get install weston)"
    done_testing
fi
XDG_RUNTIME_DIR=$T/xdg
mkdir -m 700 "$XDG_RUNTIME_DIR" || bail "mkdir xdg"
export XDG_RUNTIME_DIR
sock=gigaview-test-$$
weston --backend=x11-backend.so --socket="$sock" --idle-time=0 --no-config \
    >"$T/weston.log" 2>&1 &
wpid=$!
# shellcheck disable=SC2317 # run by wait_until
weston_ready() {
    [ -S "$XDG_RUNTIME_DIR/$sock" ] || ! kill -0 "$wpid" 2>/dev/null
}
wait_until weston_ready
if [ ! -S "$XDG_RUNTIME_DIR/$sock" ]; then
    skip "Wayland" "weston did not start: $(tail -n 2 "$T/weston.log")"
    done_testing
fi
WAYLAND_DISPLAY=$sock SDL_VIDEODRIVER=wayland
export WAYLAND_DISPLAY
on_window_system Wayland

stop_servers
stop_daemon
done_testing
