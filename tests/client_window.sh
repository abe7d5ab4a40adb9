#!/bin/sh
# client_window.sh - the display window (render/window.h) outside the
# browser: `gigaview render --window`, a store's default window
# (`gigaview encode --window`, its metadata's display.window) as
# gigaviewd, `gigaview info` and the native viewer use it, and the native
# viewer's window keys.
#
# Covers: render --window of a region equals the server's region with the
# same window byte for byte (one window, one a channel, a gray store);
# the same input encoded with --window keeps its pixels, `info` shows the
# window, the image document names it, and gigaviewd applies it to
# regions and IIIF when no window is asked (the output equals the plain
# store's with that window), an explicit window overrides it and
# window=none turns it off; render uses it by default (--window none
# not); encode refuses a malformed window or one of the wrong channel
# count; the native viewer (SDL offscreen, EGL surfaceless) opens with the
# store's window, its frame at 1:1 equals render's, and the window keys
# (b, w, y, a, x) and a scripted window redraw with no tile fetched or
# decoded again (the viewer's counters and the daemon's access log), the
# final frame equal to render's with that window.  The link of key c
# carries the window as the browser writes it (window=none when it is off
# in a store with a default, no key when there is none at all); --view
# LINK opens with the link's window (--window wins over it) and a frame
# equal to render's with it; a malformed window in a link is refused.
# Needs oiiotool and idiff; the viewer part skips without a window.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
# The client's bounds on what must come get GV_TEST_PATIENCE: each HTTP
# request (--timeout; 30 s by default) and a script's settle and
# wait-file (PMS milliseconds; 60 s by default).
PMS=$((GV_TEST_PATIENCE * 1000))
export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}detect_leaks=0"
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" "$T/cache" || bail "mkdir"
cd "$T/w" || bail "cd"
XDG_CACHE_HOME=$T/cache
SDL_VIDEODRIVER=offscreen
export XDG_CACHE_HOME SDL_VIDEODRIVER

W='30,200,1.5'
run encode synth:1500x1000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode x: $(cat "$T/err")"
run encode synth:1500x1000 --window "$W" -o "$S/d.gv"
[ "$rc" -eq 0 ] || bail "encode d: $(cat "$T/err")"
run encode synth:700x500:gray -o "$S/g.gv"
[ "$rc" -eq 0 ] || bail "encode g: $(cat "$T/err")"

run info "$S/d.gv"
check "info shows the store's window" grep -q 'display.window.*30,200,1.500' "$T/out"
run encode synth:300x200 --window '5,5,1' -o "$T/bad.gv"
check "encode --window 5,5,1 is refused" sh -c "[ $rc -ne 0 ] && grep -q 'window' '$T/err' && [ ! -e '$T/bad.gv' ]"
run encode synth:300x200:gray --window '0,255,1;0,255,1' -o "$T/bad.gv"
check "encode: two windows for a gray image are refused" sh -c "[ $rc -ne 0 ] && grep -q 'window' '$T/err'"
run encode --height synth-height:300x200 --window "$W" -o "$T/bad.gv"
check "encode --height --window is a usage error" [ "$rc" -eq 2 ]

cat >"$T/d.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = stderr
log_level = info
EOF2
start_daemon "$T/d.conf"

# same DESC A B: A.pnm and B.pnm are the same bytes.
same() {
    if [ -f "$2.pnm" ] && [ -f "$3.pnm" ] && cmp -s "$2.pnm" "$3.pnm"; then
        ok "$1"
    else
        not_ok "$1" "$(cmp "$2.pnm" "$3.pnm" 2>&1)"
    fi
}

req "$(url /v1/images/d)"
check "the image document names the default window" grep -q '"window": *"30,200,1.500"' "$T/b"
req "$(url /v1/images/x)"
check "a store without one names none" sh -c "! grep -q '\"window\"' '$T/b'"

# ---------------------------------------------------------------- store default
R="region?level=0&x=400&y=300&w=600&h=400"
pnm "/v1/images/x/$R&window=$W" xw
pnm "/v1/images/x/$R" xp
pnm "/v1/images/d/$R" dd
same "region: the store's default applies when none is asked" xw dd
check "the default window changes the pixels" sh -c "! cmp -s xw.pnm xp.pnm"
pnm "/v1/images/d/$R&window=none" dn
same "region: window=none turns the default off" xp dn
pnm "/v1/images/x/$R&window=0,255,2" x2
pnm "/v1/images/d/$R&window=0,255,2" d2
same "region: an explicit window overrides the default" x2 d2
I="0,0,512,512/max/0/default.png"
pnm "/iiif/3/x/$I?window=$W" ixw
pnm "/iiif/3/d/$I" idd
same "IIIF: the store's default applies (8-bit output)" ixw idd
pnm "/iiif/3/x/$I?window=0,255,0.5" ix5
pnm "/iiif/3/d/$I?window=0,255,0.5" id5
same "IIIF: an explicit window overrides the default" ix5 id5
pnm "/iiif/3/x/$I" ixp
pnm "/iiif/3/d/$I?window=none" idn
same "IIIF: window=none turns the default off" ixp idn
check "the default window's IIIF answer is 8-bit" sh -c "head -c 2 idd.pnm | grep -q P6 && sed -n 3p idd.pnm | grep -qx 255"

# ---------------------------------------------------------------- render --window
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x -o plain.png
if grep -q 'needs a build with GPU' "$T/err" || { [ "$rc" -ne 0 ] && grep -qi 'egl' "$T/err"; }; then
    skip "render and view" "no GPU context: $(head -c 200 "$T/err")"
    stop_daemon
    done_testing
fi
# render_case DESC IMAGE LEVEL X,Y,W,H WINDOW [RENDER WINDOW]: render equals
# the server's region with WINDOW (RENDER WINDOW: what render is given, if
# not WINDOW; "-" for no --window at all).
render_case() {
    d=$1 img=$2 lv=$3 rg=$4 sw=$5 rw=${6:-$5}
    wq=$(printf '%s' "$sw" | sed 's/;/%3B/g')
    x=${rg%%,*}; r1=${rg#*,}; y=${r1%%,*}; r2=${r1#*,}; w=${r2%%,*}; h=${r2#*,}
    if [ "$rw" = - ]; then
        run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image "$img" --level "$lv" --region "$rg" -o rr.png
    else
        run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image "$img" --level "$lv" --region "$rg" --window "$rw" -o rr.png
    fi
    if [ "$rc" -ne 0 ]; then
        not_ok "$d (render exit $rc)" "$(cat "$T/err")"
        return
    fi
    oiiotool rr.png -o rr.pnm 2>/dev/null
    pnm "/v1/images/$img/region?level=$lv&x=$x&y=$y&w=$w&h=$h&window=$wq" sr
    same "$d" rr sr
}
render_case "render --window equals the server's region" x 0 400,300,600,400 "$W"
render_case "render --window, across tiles at level 1" x 1 100,50,500,400 "40,90,0.45"
render_case "render --window, one a channel" x 0 0,0,700,520 "10,250,1;50,150,0.5;0,100,3.333"
render_case "render --window of a gray store" g 0 100,100,400,300 "20,180,1.8"
render_case "render uses the store's default window" d 0 400,300,600,400 "$W" -
render_case "render --window none: no window" d 0 400,300,600,400 none none
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,10,10 --window '0,255,1;0,255,1' -o bad.png
check "render: two windows for three channels is refused" sh -c "[ $rc -ne 0 ] && [ ! -e bad.png ]"
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image x --level 0 --region 0,0,10,10 --window '9,3' -o bad.png
check "render --window 9,3 is refused" sh -c "[ $rc -ne 0 ] && [ ! -e bad.png ]"

# ---------------------------------------------------------------- view
printf 'quit\n' >"$T/quit.txt"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --script "$T/quit.txt" --size 64x64
if grep -q 'needs a build with' "$T/err" || [ "$rc" -ne 0 ]; then
    skip "gigaview view" "no window: $(head -c 300 "$T/err")"
    stop_daemon
    done_testing
fi
cat >"$T/keys.txt" <<EOF2
view 700,500,0
settle $PMS
shot v0.png
counters before
key b
key b
key shift+W
key y
frames 3
counters keys
key a
frames 3
counters auto
key x
frames 3
counters reset
key shift+X
frames 3
counters none
window 10,250,1;50,150,0.5;0,100,3.333
frames 3
shot v1.png
counters after
EOF2
: >"$T/daemon.log"
sed -n '1,4p' "$T/keys.txt" >"$T/first.txt"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image d --size 640x480 --no-prefetch --no-cache --script "$T/first.txt"
n_first=$(grep -cE '"(GET|POST) /v1/images/d[/?"]' "$T/daemon.log")
: >"$T/daemon.log"
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image d --size 640x480 --no-prefetch --no-cache --script "$T/keys.txt"
n_all=$(grep -cE '"(GET|POST) /v1/images/d[/?"]' "$T/daemon.log")
if [ "$rc" -ne 0 ]; then
    not_ok "view runs the window script (exit $rc)" "$(cat "$T/err")"
else
    ok "view runs the window script"
fi
f0=$(sed -n 's/^before fetched=\([0-9]*\) decodes=\([0-9]*\).*/\1 \2/p' "$T/out")
f1=$(sed -n 's/^after fetched=\([0-9]*\) decodes=\([0-9]*\).*/\1 \2/p' "$T/out")
check "view opens with the store's window" grep -q '^before .* window=30,200,1.500$' "$T/out"
check "b, b, Shift+W, y move black, white and gamma ($(grep '^keys' "$T/out"))" \
    grep -q '^keys .* window=40,205,1.650$' "$T/out"
check "a sets the window from the root's histogram" sh -c "grep '^auto ' '$T/out' | grep -qv 'window=40,205,1.650'"
check "x goes back to the starting window" grep -q '^reset .* window=30,200,1.500$' "$T/out"
check "Shift+X turns the window off" grep -q '^none .* window=none$' "$T/out"
check "window changes fetch and decode no tile (before: $f0, after: $f1)" \
    sh -c "[ -n '$f0' ] && [ '$f0' != '0 0' ] && [ '$f0' = '$f1' ]"
# same_as_render DESC SHOT WINDOW: the shot equals render of the view.
same_as_render() {
    rm -f r.png
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image d --center 700,500 --zoom 0 --size 640x480 --window "$3" -o r.png
    if [ "$rc" -ne 0 ] || [ ! -f "$2" ]; then
        not_ok "$1 (render exit $rc)" "$(cat "$T/err")"
    elif idiff -a "$2" r.png >"$T/idiff" 2>&1; then
        ok "$1"
    else
        not_ok "$1" "$(tail -n 4 "$T/idiff")"
    fi
}
same_as_render "the viewer's frame with the store's window equals render's" v0.png "$W"
same_as_render "the viewer's frame after a scripted window equals render's" v1.png \
    "10,250,1;50,150,0.5;0,100,3.333"
check "the daemon saw no request for the window changes ($n_first for the first frame alone, $n_all with them)" \
    sh -c "[ '$n_first' -gt 0 ] && [ '$n_first' = '$n_all' ]"

# ---------------------------------------------------------------- links
# The link of key c carries the window as the browser writes it
# (URLSearchParams: ',' %2C, ';' %3B), and --view reads it back.
PER='10,250,1;50,150,0.5;0,100,3.333'
PERF='10,250,1.000;50,150,0.500;0,100,3.333'
PERQ='10%2C250%2C1.000%3B50%2C150%2C0.500%3B0%2C100%2C3.333'
# view_link NAME ARGS...: run a view whose script is $T/NAME.txt; its
# stdout is $T/NAME.out.
view_link() {
    n=$1
    shift
    run view "$BASE" --timeout "$GV_TEST_PATIENCE" --size 640x480 --no-prefetch --script "$T/$n.txt" "$@"
    cp "$T/out" "$T/$n.out"
}
printf 'view 700,500,0\nsettle %s\nwindow %s\nframes 3\nkey c\nquit\n' "$PMS" "$PER" >"$T/copy.txt"
view_link copy --image d
link=$(grep '^#image=' "$T/copy.out" | head -n 1)
check "key c's link carries the window as the browser writes it ($link)" \
    test "$link" = "#image=d&x=700&y=500&z=0&r=0&window=$PERQ"
printf 'settle %s\ncounters rt\nshot rt.png\nquit\n' "$PMS" >"$T/open.txt"
rm -f rt.png
view_link open --view "http://h/$link"
check "--view LINK opens with the link's window ($(grep '^rt ' "$T/open.out"))" \
    grep -q "^rt .* window=$PERF\$" "$T/open.out"
same_as_render "the frame opened from the link equals render's with its window" rt.png "$PER"
view_link open --view "$link" --window 0,255,2
check "--window wins over the link's ($(grep '^rt ' "$T/open.out"))" \
    grep -q '^rt .* window=0,255,2.000$' "$T/open.out"
view_link open --view "${link%%&window=*}"
check "a link without a window opens with the store's ($(grep '^rt ' "$T/open.out"))" \
    grep -q '^rt .* window=30,200,1.500$' "$T/open.out"
printf 'view 700,500,0\nsettle %s\nkey shift+X\nframes 3\nkey c\nquit\n' "$PMS" >"$T/copy.txt"
view_link copy --image d
nlink=$(grep '^#image=' "$T/copy.out" | head -n 1)
check "with the window off, the link of a store with a default says window=none ($nlink)" \
    test "$nlink" = "#image=d&x=700&y=500&z=0&r=0&window=none"
view_link open --view "$nlink"
check "and opens with none ($(grep '^rt ' "$T/open.out"))" grep -q '^rt .* window=none$' "$T/open.out"
printf 'view 700,500,0\nsettle %s\nkey c\nquit\n' "$PMS" >"$T/copy.txt"
view_link copy --image x
xlink=$(grep '^#image=' "$T/copy.out" | head -n 1)
check "no window set, none by default: the link has no window ($xlink)" \
    test "$xlink" = "#image=x&x=700&y=500&z=0&r=0"
for bad in '9,3' '1%2' '0,255,1;0,255,1;0,255,1;0,255,1;0,255,1;0,255,1;0,255,1;0,255,1;0,255,1'; do
    run view "$BASE" --timeout "$GV_TEST_PATIENCE" --size 64x64 --script "$T/quit.txt" --view "#image=d&x=1&y=1&z=0&window=$bad"
    check "--view with the link's window '$bad' is refused" sh -c "[ $rc -eq 2 ] && grep -q \"link's window\" '$T/err'"
done

stop_daemon
check "gigaviewd exits 0 on SIGTERM" [ "$drc" -eq 0 ]
done_testing
