#!/bin/sh
# client_render_codes.sh - `gigaview render` on stores of 16-bit codes
# (docs/FORMAT.md sections 12 and 13), decoded on the GPU by
# lib/gpu/gpu_height.c behind the GPU tile cache:
#   - a five-channel sample store at --max-error 40, a three-channel one
#     with a default window and colours (encode --window --colours), a
#     one-channel one and a height store: the region form equals `gigaview
#     export` (the store's own picture) bit for bit, across tiles, a whole
#     level, the root level and a root mip;
#   - --window and --colours equal the server's region with the same
#     `window` and `colours`, bit for bit; a height store's --window
#     applies to its gray;
#   - the view form at an integer zoom equals the level's region; at a
#     fractional zoom with a rotation it writes a picture of the right
#     size and channels;
#   - bad --colours, --colours for another store and a window of another
#     channel count are refused (exit 2), and nothing is written;
#   - `gigaview view` draws them as well: its frames at 1:1 equal render's
#     views (five channels with a window each, a height store's gray with
#     and without a window, a store's own window and colours; with and
#     without the decode thread), a window
#     change fetches and decodes no tile, and auto sets a window from the
#     root's codes.
# Skips where the build or the machine has no GPU context.  Needs curl,
# python3, oiiotool and idiff.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
# The client's bounds on what must come get GV_TEST_PATIENCE: each HTTP
# request (--timeout; 30 s by default) and a script's settle and
# wait-file (PMS milliseconds; 60 s by default).
PMS=$((GV_TEST_PATIENCE * 1000))
need_tool oiiotool idiff

S=$T/stores
mkdir "$S" "$T/w" "$T/cache" || bail "mkdir"
cd "$T/w" || bail "cd"
XDG_CACHE_HOME=$T/cache
export XDG_CACHE_HOME

oiiotool --pattern "noise:type=uniform:min=0.1:max=0.9" 1300x900 5 \
    --pattern "checker:width=64:height=64:color1=0.2,0.4,0.6,0.8,1:color2=0,0.1,0.2,0.3,0.4" 1300x900 5 \
    --add -d uint16 -o c5.tif || bail "oiiotool c5"
oiiotool "$TESTDATA/picos-1100x700.jpg" -d uint16 -o p16.png || bail "oiiotool p16"
oiiotool p16.png --ch R -o g16.png || bail "oiiotool g16"
run encode --bits 16 --max-error 40 c5.tif -o "$S/c5.gv"
[ "$rc" -eq 0 ] || bail "encode c5: $(cat "$T/err")"
run encode --bits 16 -q 60 p16.png --window 2000,50000,1.5 --colours '00ffff;ff00ff;ffff00' \
    -o "$S/s3.gv"
[ "$rc" -eq 0 ] || bail "encode s3: $(cat "$T/err")"
run encode --bits 16 g16.png -o "$S/g1.gv"
[ "$rc" -eq 0 ] || bail "encode g1: $(cat "$T/err")"
run encode --height --max-error 2 synth-height:1100x1030 -o "$S/dem.gv"
[ "$rc" -eq 0 ] || bail "encode dem: $(cat "$T/err")"
run encode synth:600x400 -o "$S/img.gv"
[ "$rc" -eq 0 ] || bail "encode img: $(cat "$T/err")"

cat >"$T/d.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = stderr
log_level = info
EOF2
start_daemon "$T/d.conf"

run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --level 3 -o probe.png
if [ "$rc" -ne 0 ] && grep -q 'needs a build with GPU support\|EGL\|gpu' "$T/err"; then
    skip "render on stores of codes" "no GPU context: $(head -c 200 "$T/err")"
    stop_daemon
    done_testing
fi

# same DESC RENDER-ARGS -- EXPORT-ARGS: render's picture equals export's.
same() {
    d=$1
    shift
    rargs=
    while [ "$1" != -- ]; do rargs="$rargs $1"; shift; done
    shift
    rm -f r.png e.png
    # shellcheck disable=SC2086
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" $rargs -o r.png
    rrc=$rc
    cp "$T/err" "$T/render.err"
    run export "$@" -o e.png
    if [ "$rrc" -ne 0 ] || [ "$rc" -ne 0 ]; then
        not_ok "$d (render exit $rrc, export exit $rc)" "$(cat "$T/render.err" "$T/err")"
    elif idiff -a r.png e.png >"$T/idiff" 2>&1; then
        ok "$d"
    else
        not_ok "$d" "$(tail -n 5 "$T/idiff")"
    fi
}
for st in c5 s3 g1 dem; do
    same "$st level 0, a region across tiles, equals export" \
        --image $st --level 0 --region 300,200,600,500 -- "$S/$st.gv" --level 0 --region 300,200,600,500
    same "$st level 1, the whole level, equals export" \
        --image $st --level 1 -- "$S/$st.gv" --level 1
done
same "c5 level 2 (the root), equals export" --image c5 --level 2 -- "$S/c5.gv" --level 2
same "c5 level 4 (a root mip), equals export" --image c5 --level 4 -- "$S/c5.gv" --level 4
check "c5's picture is RGB (three channels)" sh -c "oiiotool --info r.png | grep -q '3 channel'"
same "g1 (one channel) is gray" --image g1 --level 2 -- "$S/g1.gv" --level 2
check "... one channel" sh -c "oiiotool --info r.png | grep -q '1 channel'"

# region_same DESC ID QUERY RENDER-ARGS...: render's level-0 region
# 100,50 700x600 equals the server's with QUERY.
region_same() {
    d=$1 id=$2 q=$3
    shift 3
    rm -f r.png
    run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image "$id" --level 0 --region 100,50,700,600 "$@" -o r.png
    rrc=$rc
    cp "$T/err" "$T/render.err"
    req "$(url "/v1/images/$id/region?level=0&x=100&y=50&w=700&h=600&format=png$q")"
    cp "$T/b" s.png
    if [ "$rrc" -ne 0 ] || [ "$code" != 200 ]; then
        not_ok "$d (render exit $rrc, region $code)" "$(cat "$T/render.err" "$T/b")"
    elif idiff -a r.png s.png >"$T/idiff" 2>&1; then
        ok "$d"
    else
        not_ok "$d" "$(tail -n 5 "$T/idiff")"
    fi
}
region_same "c5 --window and --colours equal the server's region with them" c5 \
    '&window=7000,60000,1%3B10000,50000,0.6%3B5000,65535,2%3B0,40000,1%3B20000,62000,1.3&colours=ff0000%3B00ff00%3B0000ff%3Bffff00%3B808080' \
    --window '7000,60000,1;10000,50000,0.6;5000,65535,2;0,40000,1;20000,62000,1.3' \
    --colours 'ff0000;00ff00;0000ff;ffff00;808080'
region_same "s3 with no options: the store's window and colours" s3 ''
region_same "s3 --window none: the codes' range, the store's colours" s3 '&window=none' --window none
region_same "s3 --colours alone: the store's window" s3 '&colours=102030%3Bffffff%3B00ff80' \
    --colours '102030;ffffff;00ff80'
region_same "dem --window: on its gray, as the server" dem '&window=40,200,0.7' --window 40,200,0.7
# A wrong window must not match (the comparison can see a difference).
rm -f r.png
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image s3 --level 0 --region 100,50,700,600 --window 2001,50000,1.5 -o r.png
req "$(url "/v1/images/s3/region?level=0&x=100&y=50&w=700&h=600&format=png")"
cp "$T/b" s.png
check "negative control: a black point one code off differs from the store's window" \
    sh -c "[ -s r.png ] && ! idiff -a r.png s.png >/dev/null 2>&1"

# ---------------------------------------------------------------- view form
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --center 650,450 --zoom 1 --size 500x400 -o v.png
vrc=$rc
run export "$S/c5.gv" --level 1 --region 75,25,500,400 -o ve.png
if [ "$vrc" -eq 0 ] && [ "$rc" -eq 0 ] && idiff -a v.png ve.png >/dev/null 2>&1; then
    ok "c5 view at integer zoom 1 equals the level-1 region"
else
    not_ok "c5 view at integer zoom 1 equals the level-1 region (exit $vrc)" "$(cat "$T/err")"
fi
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image dem --center 500,500 --zoom 0.6 --rotate 20 --size 320x240 -o v2.png
check "dem view at zoom 0.6, turned 20 degrees: a 320x240 gray picture" \
    sh -c "[ $rc -eq 0 ] && oiiotool --info v2.png | grep -q '320 x  *240, 1 channel'"

# ---------------------------------------------------------------- refusals
rm -f x.png
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --colours 'ff0000;00ff00' -o x.png
expect_rc "two colours for five channels: exit 2" 2
expect_err "... saying how many" "colours: 2 colours for an image of 5 channels"
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --colours 'red' -o x.png
expect_rc "colours that are not RRGGBB: exit 2" 2
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image img --colours 'ff0000;00ff00;0000ff' -o x.png
expect_rc "--colours for an image store: exit 2" 2
expect_err "... for sample stores only" "for sample stores only"
run render "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --window '0,100;0,200' -o x.png
expect_rc "two windows for five channels: exit 2" 2
check "nothing written by a refused render" test ! -e x.png

# ---------------------------------------------------------------- view
# gigaview view draws them too (the atlas holds a layer a channel, the
# display pass maps each tap through the tables): its frames at 1:1 equal
# render's views, with windows; a window change fetches and decodes no
# tile (its counters), and auto sets one from the root's codes.
SDL_VIDEODRIVER=offscreen
export SDL_VIDEODRIVER
cat >views.txt <<EOF2
view 512,512,0
settle $PMS
shot v1.png
view 300,300,1
settle $PMS
shot v2.png
counters before
window 7000,60000,1;10000,50000,0.6;5000,65535,2;0,40000,1;20000,62000,1.3
settle $PMS
shot v3.png
counters after
key a
settle $PMS
counters auto
view #image=dem&x=512&y=512&z=0&r=0
settle $PMS
shot v4.png
window 40,200,0.7
settle $PMS
shot v5.png
view #image=s3&x=550&y=350&z=0&r=0
settle $PMS
shot v6.png
EOF2
# --no-prefetch: nothing is fetched once the view has settled, so the
# counters around the window change see only what the change does (with
# prefetching, a loaded machine was still fetching after the settle).
# Leak checking is off for the viewer's process alone: its exit reports
# bytes Mesa's GL driver allocated from a module already unloaded (see
# client_view.sh); render's runs keep it.
lsan_saved=${LSAN_OPTIONS-}
LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}detect_leaks=0"
export LSAN_OPTIONS
run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --size 640x480 --no-prefetch --script views.txt
LSAN_OPTIONS=$lsan_saved
cp "$T/out" view.out
if grep -q 'needs a build with\|no window\|SDL' "$T/err"; then
    skip "gigaview view on stores of codes" "no viewer here: $(head -c 200 "$T/err")"
else
    expect_rc "the views script runs" 0
    # view_same DESC SHOT RENDER-ARGS...: a frame equals render's view.
    view_same() {
        d=$1 shot=$2
        shift 2
        rm -f r.png
        run render "$BASE" --timeout "$GV_TEST_PATIENCE" --size 640x480 "$@" -o r.png
        if [ "$rc" -ne 0 ] || [ ! -f "$shot" ]; then
            not_ok "$d (render exit $rc)" "$(cat "$T/err")"
        elif idiff -a "$shot" r.png >"$T/idiff" 2>&1; then
            ok "$d"
        else
            not_ok "$d" "$(tail -n 4 "$T/idiff")"
        fi
    }
    view_same "view: c5 at 1:1 across tiles equals render" v1.png --image c5 --center 512,512 --zoom 0
    view_same "view: c5 level 1 at 1:1 equals render" v2.png --image c5 --center 300,300 --zoom 1
    view_same "view: c5 with a window a channel equals render with it" v3.png --image c5 \
        --center 300,300 --zoom 1 \
        --window '7000,60000,1;10000,50000,0.6;5000,65535,2;0,40000,1;20000,62000,1.3'
    view_same "view: a height store's gray equals render" v4.png --image dem --center 512,512 --zoom 0
    view_same "view: ... with a window on its gray" v5.png --image dem --center 512,512 --zoom 0 \
        --window 40,200,0.7
    view_same "view: a sample store's own window and colours equal render" v6.png --image s3 \
        --center 550,350 --zoom 0
    check "view: negative control: the windowed frame is not the plain one" \
        sh -c "! idiff -a v3.png v2.png >/dev/null 2>&1"
    # Without the decode thread the render thread decodes into the atlas.
    printf 'view 512,512,0\nsettle %s\nshot n1.png\n' "$PMS" >nt.txt
    run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --size 640x480 --no-decode-thread --script nt.txt
    view_same "view --no-decode-thread: c5 at 1:1 equals render" n1.png --image c5 \
        --center 512,512 --zoom 0
    b=$(sed -n 's/^before fetched=\([0-9]*\) decodes=\([0-9]*\).*/\1 \2/p' view.out)
    a=$(sed -n 's/^after fetched=\([0-9]*\) decodes=\([0-9]*\).*/\1 \2/p' view.out)
    check "view: a window change fetches and decodes no tile ($b, then $a)" \
        sh -c "[ -n '$b' ] && [ '$b' = '$a' ]"
    check "view: auto sets a window from the root's codes" \
        sh -c "grep -q '^auto .* window=[0-9]*,[0-9]*,1.000$' view.out && ! grep -q '^auto .* window=7000,60000' view.out"
    # K picks the channel the window keys move: one window becomes one a
    # channel, and only the picked one moves; auto sets that one alone.
    cat >keys.txt <<EOF2
view 300,300,1
settle $PMS
window 7000,60000,1
key k
key k
key b
key b
counters ch2
key shift+k
key shift+w
counters ch1
key k
key k
key a
counters auto3
settle $PMS
shot k1.png
EOF2
    LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}detect_leaks=0"
    export LSAN_OPTIONS
    run view "$BASE" --timeout "$GV_TEST_PATIENCE" --image c5 --size 640x480 --no-prefetch --script keys.txt
    LSAN_OPTIONS=$lsan_saved
    expect_rc "view: the channel-keys script runs" 0
    win_of() { sed -n "s/^$1 .* window=\([^ ]*\)\$/\1/p" "$T/out"; }
    w2=$(win_of ch2) w1=$(win_of ch1) w3=$(win_of auto3)
    check "view: k, k, b, b moves channel 2's black point alone ($w2)" test \
        "$w2" = '7000,60000,1.000;9570,60000,1.000;7000,60000,1.000;7000,60000,1.000;7000,60000,1.000'
    check "view: Shift+K back to channel 1, Shift+W moves its white point alone ($w1)" test \
        "$w1" = '7000,61285,1.000;9570,60000,1.000;7000,60000,1.000;7000,60000,1.000;7000,60000,1.000'
    check "view: k, k then a sets channel 3 from its histogram, the others kept ($w3)" sh -c "
        case '$w3' in '7000,61285,1.000;9570,60000,1.000;7000,60000,1.000;'*) exit 1 ;;
        '7000,61285,1.000;9570,60000,1.000;'*';7000,60000,1.000;7000,60000,1.000') exit 0 ;; esac; exit 1"
    view_same "view: that window a channel, drawn, equals render with it" k1.png --image c5 \
        --center 300,300 --zoom 1 --window "$w3"
fi

stop_daemon
check "gigaviewd exits 0 on SIGTERM" [ "$drc" -eq 0 ]
done_testing
