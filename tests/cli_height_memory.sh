#!/bin/sh
# cli_height_memory.sh - the height encoder's peak memory does not grow
# with the height field's area.
#
# Encodes two mosaics of tests/data/etopo5-720x361-u16.png (PNG-16):
# 6 x 12 tiles (4320 x 4332, 18.7 M samples) and 12 x 24 tiles (8640 x
# 8664, 74.9 M samples: 4x the area), --max-error 2, 2 threads, and
# measures peak RSS with /usr/bin/time -f %M.  The smaller one is more
# than a page (4096) across and down, so that it already has the whole
# page window of pass 2.
#
# The bound (docs/FORMAT.md section 12, "Encoder memory"):
#   page window             4097^2 * 2            = 33.6 MB
#   64 decoded tiles        64 * 513^2 * 2        = 33.7 MB
#   16 parent tiles         16 * 513^2 * 2        =  8.4 MB
#   64 tile buffers         what is written: ~2 bytes a sample = 33.7 MB
#   per thread              tile + prediction     =  1.6 MB
#   input rows              4 MiB + the source's 4 MiB + 12 PNG decoders
#                                                 ~ 10 MB
#                                         total ~ 121 MB = 115 MiB
# over the process's own (`gigaview --version`).  Assert: both peaks <=
# baseline + 115 MiB + 15%, and the 4x-area run within +15% of the
# smaller one's peak.  The in-memory encoder this one replaced held
# 2.7 bytes a sample of code pyramid plus the decoded tiles of a whole
# level: over 350 MB for the larger mosaic.
#
# A sample store (`encode --bits 16`, docs/FORMAT.md section 13) streams
# the same way with C codes a pixel: a 4 x 7 and an 8 x 14 mosaic of a
# 16-bit RGB tile (1100 x 700, 3 channels), --max-error 2: the 4x-area run
# within +15% of the smaller one's peak, both under 4 times the bound
# above (the page's window, decoded tiles and buffers hold 3 channels:
# 368 and 382 MiB measured on 2026-12-03).
#
# Skipped without /usr/bin/time, under valgrind and in sanitizer builds.
. "$(dirname "$0")/lib.sh"

peak_rss_preflight

# mosaic COLS ROWS [TILE]: the arguments of a COLSxROWS mosaic of one tile
# (default the ETOPO5 PNG-16).
mosaic() {
    i=0
    args="--mosaic $1x$2"
    while [ "$i" -lt $(($1 * $2)) ]; do
        args="$args ${3:-$TESTDATA/etopo5-720x361-u16.png}"
        i=$((i + 1))
    done
    echo "$args"
}

base=$(peak_kib --version)
diag "baseline (gigaview --version): $((base / 1024)) MiB"
bound=$(( (base + 115 * 1024) * 115 / 100 ))

# peaks WHAT BOUND SMALL_NAME LARGE_NAME ARGS...: gigaview ARGS on the
# mosaic $small_mosaic, then on $large_mosaic (4x the area); both peaks
# within BOUND (KiB) and the larger within +15% of the smaller.
peaks() {
    what=$1 bnd=$2 sn=$3 ln=$4
    shift 4
    start=$(date +%s)
    # shellcheck disable=SC2046,SC2086
    small=$(peak_kib "$@" $small_mosaic -o "$T/a.gv")
    # shellcheck disable=SC2046,SC2086
    large=$(peak_kib "$@" $large_mosaic -o "$T/b.gv")
    diag "$what, peak RSS: $sn $((small / 1024)) MiB, $ln $((large / 1024)) MiB" \
        "(bound $((bnd / 1024)) MiB) in $(( $(date +%s) - start )) s"
    for pair in "$sn $small" "$ln $large"; do
        set -- $pair
        if [ "$2" -le "$bnd" ]; then
            ok "$what $1: peak $(($2 / 1024)) MiB <= $((bnd / 1024)) MiB"
        else
            not_ok "$what $1: peak $(($2 / 1024)) MiB exceeds $((bnd / 1024)) MiB"
        fi
    done
    if [ "$large" -le $((small * 115 / 100)) ]; then
        ok "$what, 4x the area: peak grows by $(( (large - small) / 1024 )) MiB (<= 15%)"
    else
        not_ok "$what, 4x the area: peak grows from $((small / 1024)) to $((large / 1024)) MiB"
    fi
    check "$what: both stores were written" test -s "$T/a.gv" -a -s "$T/b.gv"
    rm -f "$T/a.gv" "$T/b.gv"
}

small_mosaic=$(mosaic 6 12)
large_mosaic=$(mosaic 12 24)
peaks "height store" "$bound" 4320x4332 8640x8664 \
    encode --height --max-error 2 -j 2 --quiet

# Sample stores: three channels.
oiiotool "$TESTDATA/picos-1100x700.jpg" -d uint16 -o "$T/rgb16.png" || bail "oiiotool"
small_mosaic=$(mosaic 4 7 "$T/rgb16.png")
large_mosaic=$(mosaic 8 14 "$T/rgb16.png")
peaks "sample store" "$(( (base + 4 * 115 * 1024) * 115 / 100 ))" 4400x4900x3 8800x9800x3 \
    encode --bits 16 --max-error 2 -j 2 --quiet

done_testing
