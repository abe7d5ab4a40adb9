#!/bin/sh
# http_resident.sh - the coarse levels every store keeps decoded from its
# opening (resident_bytes; server/catalog.c, gv_decoder_pin_levels).
#
# Store x (synth:3000x2000) has tiled levels 0 (6x4 tiles), 1 (3x2), 2
# (2x1), 3 and 4 (one tile each) under its root tile (94x63, root side
# 128); an RGB tile is 513x513x3 = 789507 bytes.
#   - resident_bytes = 10M: the root and levels 4 to 1 (11 tiles) are
#     decoded before the first request, level 0 (24 more) is not; IIIF
#     answers from levels 1 and 2 then decode nothing, one from level 0
#     decodes its own tile only (its parent is resident);
#   - the answers are the bytes of a server that keeps nothing resident;
#   - the budget is shared, in id order: y after x gets the rest (its root
#     tile and level 4); and it is at most half of decoder_cache_bytes;
#   - a store dropped on a rescan (SIGHUP) lets its tiles go.
. "$(dirname "$0")/lib.sh"
. "$(dirname "$0")/http_util.sh"

S=$T/stores
mkdir "$S" "$T/w" || bail "mkdir"
cd "$T/w" || bail "cd"
run encode synth:3000x2000 -o "$S/x.gv"
[ "$rc" -eq 0 ] || bail "encode: $(cat "$T/err")"
TILE=789507
conf() { # RESIDENT DECODER_CACHE
    cat >"$T/r.conf" <<EOF2
store_dir = "$S"
threads = 2
access_log = off
gpu = off
output_cache_bytes = 0
resident_bytes = $1
decoder_cache_bytes = $2
EOF2
}
metric() {
    curl -sS --max-time "$GV_TEST_PATIENCE" "$(url /metrics)" | awk -v n="$1" '$1 == n { print $2 }'
}
URLS="/iiif/3/x/0,0,2048,2000/512,/0/default.jpg
/iiif/3/x/1024,0,1024,1024/512,/0/default.jpg
/iiif/3/x/full/375,/0/gray.png
/iiif/3/x/512,512,512,512/max/0/default.jpg
/iiif/3/x/2560,1536,440,464/max/90/default.jpg"
# fetch PREFIX: every URL's answer into PREFIX.N
fetch() {
    i=0
    for u in $URLS; do
        i=$((i + 1))
        req "$(url "$u")"
        [ "$code" = 200 ] || not_ok "$u: $code" "$(head -c 300 "$T/b")"
        cp "$T/b" "$1.$i"
    done
}

conf 10M 64M
start_daemon "$T/r.conf"
check "resident: 11 tiles (root, levels 4 to 1) decoded at the start" \
    test "$(metric gigaview_tile_cache_misses_total) $(metric gigaview_tile_cache_bytes)" = "11 $((11 * TILE))"
expect_status "IIIF from level 1" 200 /iiif/3/x/1024,0,1024,1024/512,/0/default.jpg
expect_status "IIIF from level 2" 200 /iiif/3/x/0,0,2048,2000/512,/0/default.jpg
check "levels 1 and 2 are answered without a decode" \
    test "$(metric gigaview_tile_cache_misses_total)" = 11
check "...and with no decode time" test \
    "$(metric 'gigaview_render_stage_seconds_sum{stage="decode"}')" = 0.000000
expect_status "IIIF from level 0" 200 /iiif/3/x/512,512,512,512/max/0/default.jpg
check "a whole level-0 tile decodes itself alone, outside the cache: its parent is resident" \
    test "$(metric gigaview_tile_cache_misses_total) $(metric gigaview_tile_cache_lent_total)" = "11 1"
expect_status "IIIF across level-0 tiles" 200 /iiif/3/x/256,256,512,512/max/0/default.jpg
check "...and a level-0 tile covered in part goes into the cache" \
    test "$(metric gigaview_tile_cache_misses_total) $(metric gigaview_tile_cache_lent_total)" = "15 1"
fetch with
stop_daemon
check "the daemon stopped cleanly" test "$drc" -eq 0

conf 0 64M
start_daemon "$T/r.conf"
check "resident_bytes = 0: nothing decoded at the start" \
    test "$(metric gigaview_tile_cache_misses_total)" = 0
fetch without
i=0
for u in $URLS; do
    i=$((i + 1))
    check "$u: the same bytes with and without resident levels" \
        cmp -s "with.$i" "without.$i"
done
stop_daemon

cp "$S/x.gv" "$S/y.gv" || bail "cp"
conf 10M 64M
start_daemon "$T/r.conf"
check "x then y: x keeps 11 tiles, y what is left (its root, level 4): 13 tiles" \
    test "$(metric gigaview_tile_cache_misses_total) $(metric gigaview_tile_cache_bytes)" = "13 $((13 * TILE))"
rm "$S/x.gv"
# Once the rescan has ended, x's image is put back (/metrics counts one
# store before the old image is let go).
rescan_daemon
check "x dropped on a rescan lets its 11 tiles go" \
    test "$(metric gigaview_tile_cache_bytes)" = "$((2 * TILE))"
stop_daemon

conf 32M 3M
start_daemon "$T/r.conf"
check "at most half of decoder_cache_bytes: 1.5 MB holds the root alone" \
    test "$(metric gigaview_tile_cache_misses_total)" = 1
stop_daemon
check "the daemon stopped cleanly" test "$drc" -eq 0
done_testing
