#!/bin/sh
# http_window.sh - display windows (`window=B,W,G`, lib/render/window.h)
# on decoded regions and IIIF images.
#
# Against tests/window_ref.py, an independent reference in Python: a
# region with a window is the region without it through the reference's
# tables, sample for sample (photo and gray store, one window for all
# channels and one per channel; IIIF at a level's own size likewise);
# and client/web/window.js (under node) builds the same tables as the
# reference for 3000 windows and refuses the same malformed texts.  The
# window is in the ETag and the cache key: each window its own ETag and
# its own bytes, the same window written two ways the same.  Hostile
# windows are 400 with the JSON error body.
#
# Needs curl, python3, oiiotool; the table comparison needs node (skipped
# without it).
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"
need_tool oiiotool
srcdir=$(cd "${top_srcdir:-$(dirname "$0")/..}" && pwd)

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
run encode "$TESTDATA/picos-1100x700.jpg" -o "$S/photo.gv"
[ "$rc" -eq 0 ] || bail "encode photo: $(cat "$T/err")"
run encode synth:600x400:gray -o "$S/gray.gv"
[ "$rc" -eq 0 ] || bail "encode gray: $(cat "$T/err")"

cat >"$T/w.conf" <<EOF2
listen = 127.0.0.1
port = 0
store_dir = "$S"
threads = 2
access_log = stderr
log_level = info
EOF2
start_daemon "$T/w.conf"


# window_case DESCRIPTION PATH WINDOW: PATH with window=WINDOW equals PATH
# through the reference's tables.
window_case() {
    d=$1 p=$2 w=$3
    sep='?'
    case $p in *'?'*) sep='&' ;; esac
    if ! pnm "$p" raw; then
        not_ok "$d: the plain image (HTTP $code)" "$(head -c 300 "$T/b")"
        return
    fi
    wq=$(printf '%s' "$w" | sed 's/;/%3B/g')
    if ! pnm "$p${sep}window=$wq" win; then
        not_ok "$d: the windowed image (HTTP $code)" "$(head -c 300 "$T/b")"
        return
    fi
    if out=$(python3 "$srcdir/tests/window_ref.py" apply "$w" raw.pnm win.pnm) &&
        ! cmp -s raw.pnm win.pnm; then
        ok "$d: window $w ($out)"
    else
        not_ok "$d: window $w" "$out"
    fi
}
R="/v1/images/photo/region?level=0&x=100&y=50&w=300&h=200"
window_case "region of a photograph" "$R" "30,200,1"
window_case "region of a photograph" "$R" "0,255,2.2"
window_case "region of a photograph" "$R" "40,90,0.45"
window_case "region of a photograph, per channel" "$R" "10,250,1;50,150,0.5;0,100,3.333"
window_case "region of a gray store" "/v1/images/gray/region?level=1&x=0&y=0&w=300&h=200" "20,180,1.8"
window_case "IIIF tile of a photograph" "/iiif/3/photo/0,0,512,512/max/0/default.png" "30,200,0.7"
window_case "IIIF level 1 of a gray store" "/iiif/3/gray/full/300,/0/default.png" "60,200,1.5"

# ETags and the cache: each window its own answer.
req "$(url "$R")"; e0=$(header ETag); cp "$T/b" n0
req "$(url "$R&window=30,200,1")"; e1=$(header ETag); cp "$T/b" n1
req "$(url "$R&window=30,200,1.5")"; e2=$(header ETag); cp "$T/b" n2
req "$(url "$R&window=30,200")"; e3=$(header ETag); cp "$T/b" n3
check "the ETag names the window (none $e0, 30,200,1 $e1, 30,200,1.5 $e2)" \
    sh -c "[ -n '$e0' ] && [ '$e0' != '$e1' ] && [ '$e1' != '$e2' ] && [ '$e0' != '$e2' ]"
check "each window its own bytes from the cache" sh -c "! cmp -s n0 n1 && ! cmp -s n1 n2"
check "30,200 and 30,200,1 are one window: one ETag, the same bytes" \
    sh -c "[ '$e1' = '$e3' ] && cmp -s n1 n3"
req -H "If-None-Match: $e1" "$(url "$R&window=30,200,1.000")"
check "If-None-Match with the window's ETag: 304" [ "$code" = 304 ]
req -H "If-None-Match: $e1" "$(url "$R&window=31,200,1")"
check "If-None-Match with another window's ETag: 200" [ "$code" = 200 ]
I=/iiif/3/photo/0,0,512,512/max/0/default.png
req "$(url "$I")"; i0=$(header ETag)
req "$(url "$I?window=30,200,1")"; i1=$(header ETag)
check "IIIF: the ETag names the window ($i0, $i1)" sh -c "[ -n '$i1' ] && [ '$i0' != '$i1' ]"

# Hostile windows.
for w in '' ',' '5,5,1' '6,5,1' '0,256,1' '-1,255,1' '%2B1,255,1' '0,255,1e1' \
    '0,255,.5' '0,255,1.' '0,255,1.2345' '0,255,0.099' '0,255,10.001' \
    '0,255,1%3B' '%200,255,1' '0,255,1,1' '0,255,nan' '0x1,255,1' \
    '99999999999999999999,255,1' '0,255,1%3B0,255,1' \
    "$(python3 -c "print('%3B'.join(['0,255,1'] * 9))")" \
    "$(python3 -c "print('0,255,1%3B' * 100)")"; do
    expect_status "region window=$(printf '%.40s' "$w")" 400 "$R&window=$w"
done
# The messages say what is wrong (the values as given).
for pair in '0,9%3B7,7|window: channel 2: black 7 is not below white 7' \
    '0,70000|window: channel 1: a point past 65535' \
    '0,300|window: white point 300 is past this image'"'"'s largest sample, 255' \
    'abc|window: channel 1: want B,W[,G]: integers B < W'; do
    req "$(url "$R&window=${pair%%|*}")"
    m=$(json_get 'j["error"]["message"]')
    check "window=${pair%%|*}: 400 saying '${pair#*|}' ($m)" \
        sh -c "[ '$code' = 400 ] && case \"\$1\" in \"\$2\"*) true ;; *) false ;; esac" - "$m" "${pair#*|}"
done
expect_status "three windows for a gray store" 400 \
    "/v1/images/gray/region?level=1&x=0&y=0&w=30&h=20&window=0,255,1%3B0,255,1%3B0,255,1"
expect_status "IIIF window=5,5,1" 400 "$I?window=5,5,1"
expect_status "IIIF two windows for three channels" 400 "$I?window=0,255,1%3B0,9,1"

# The browser's tables (client/web/window.js) against the reference's.
if command -v node >/dev/null 2>&1; then
    python3 "$srcdir/tests/window_cases.py" 3000 7 >cases
    python3 "$srcdir/tests/window_ref.py" tables cases >ref.tables
    if node "$srcdir/tests/browser/window_tables.mjs" cases >js.tables 2>js.err &&
        cmp -s ref.tables js.tables; then
        ok "window.js: the reference's tables for $(wc -l <cases) windows ($(grep -c '^error$' ref.tables) refused by both)"
    else
        not_ok "window.js: the reference's tables" "$(cat js.err; cmp ref.tables js.tables)"
    fi
    # A sample store's tables on 16-bit codes (the WebGL2 viewer's).
    python3 "$srcdir/tests/window_cases.py" 200 11 65535 >cases16
    python3 "$srcdir/tests/window_ref.py" tables cases16 65535 >ref16.tables
    if node "$srcdir/tests/browser/window_tables.mjs" cases16 65535 >js16.tables 2>js16.err &&
        cmp -s ref16.tables js16.tables; then
        ok "window.js: the reference's 16-bit tables for $(wc -l <cases16) windows ($(grep -c '^error$' ref16.tables) refused by both)"
    else
        not_ok "window.js: the reference's 16-bit tables" "$(cat js16.err; cmp ref16.tables js16.tables)"
    fi
else
    skip "window.js against the reference" "no node"
fi

stop_daemon
check "gigaviewd exits 0 on SIGTERM" [ "$drc" -eq 0 ]
done_testing
