#!/bin/sh
# cli_level0_file.sh - an uncompressed TIFF is read where its pixels lie
# (lib/imageio/raw_regions.c): pass 1 reads its rows without libtiff, and
# pass 2 reads level 0 again from it instead of a scratch copy; the store
# is the same byte for byte as through libtiff and the scratch file.
#
# The inputs are made here: synthetic images encoded, exported to TIFF
# and rewritten by tiffcp without compression, tiled (tiles that overhang
# the right and bottom edges) or in strips (the last one short).  Each is
# encoded as it is (the summary must say that level 0 was read again) and
# with GIGAVIEW_RAW_REGIONS=0 (read by libtiff, with a scratch copy of
# level 0, so the scratch holds the image, and the image more than the
# first run's, which holds only the coarser levels): the two stores must
# be identical.  Small images
# take the path with GIGAVIEW_LEVEL0_RESIDENT=0 (level 0 would stay in
# memory otherwise); one tiled gray image of more than 4097^2 pixels
# takes it by default.  LZW, 16-bit and gray+alpha TIFFs are never read that
# way.  The large one is also changed while pass 2 reads it (the encoder
# stopped, its modification time touched): the encode must fail and
# publish nothing.  (cli_shard.sh checks that shards, which read level 0
# from the input too, merge into the whole encode's store.)
. "$(dirname "$0")/lib.sh"
need_tool tiffcp

export GIGAVIEW_LEVEL0_RESIDENT=0

# scratch_mb: the scratch line's megabytes in the last run's summary.
scratch_mb() {
    sed -n 's/^scratch *\([0-9.]*\) MB.*/\1/p' "$T/out"
}

# make_tiff SYNTH OUT TIFFCP-OPTIONS...: the pattern SYNTH, encoded and
# exported to a TIFF, rewritten by tiffcp with the options into OUT.
make_tiff() {
    synth=$1 out=$2
    shift 2
    gv encode --quiet -q 34 "$synth" -o "$T/src.gv" &&
        gv export "$T/src.gv" -o "$T/src.tif" &&
        tiffcp "$@" "$T/src.tif" "$out" ||
        bail "cannot make $out from $synth"
}

# both DESCRIPTION FILE MB [OPTION...]: encode FILE (MB megabytes of
# pixels) reading level 0 again and from a scratch copy; the same store,
# and the copy's scratch at least MB, and MB more than the first's (to the
# 0.1 MB the summary prints).
both() {
    what=$1 file=$2 mb=$3
    shift 3
    run encode -q 34 "$@" "$file" -o "$T/again.gv"
    expect_rc "$what: encode" 0
    check "$what: the summary says level 0 was read again from the input" \
        grep -q '^scratch .*level 0 read again from the input$' "$T/out"
    again=$(scratch_mb)
    GIGAVIEW_RAW_REGIONS=0 run encode -q 34 "$@" "$file" -o "$T/copy.gv"
    expect_rc "$what: encode with a scratch copy of level 0" 0
    copy=$(scratch_mb)
    check "$what: the copy's scratch ${copy} MB holds the image's $mb MB" \
        awk "BEGIN { exit !($copy >= $mb) }"
    check "$what: ... the image's $mb MB more than read again (${again} MB)" \
        awk "BEGIN { exit !($copy - $again >= $mb - 0.1) }"
    check "$what: the same store either way" cmp -s "$T/again.gv" "$T/copy.gv"
}

# Small images, level 0 out of memory by the switch: tiles of 64 x 64
# (1100 x 700: overhanging both edges), strips of 5 rows (1101 x 701: the
# last strip of 1 row, and an odd last row that pass 1's reader pairs
# with itself), gray in tiles of 16 x 48.
make_tiff synth:1100x700 "$T/tiled.tif" -c none -t -w 64 -l 64
both "RGB 1100x700 in 64x64 tiles" "$T/tiled.tif" 2.31
cp "$T/again.gv" "$T/rgb.gv"
make_tiff synth:1101x701 "$T/strips.tif" -c none -r 5
both "RGB 1101x701 in strips of 5 rows" "$T/strips.tif" 2.31
make_tiff synth:1300x600:gray "$T/gray.tif" -c none -t -w 16 -l 48
both "gray 1300x600 in 16x48 tiles" "$T/gray.tif" 0.78

# One strip of the whole image (780 KB) under --max-decoder-memory 100K:
# read where its rows lie, it needs no strip buffer, so the native reader
# keeps it (through libtiff, the strip would pass the limit and the file
# go to OpenImageIO, a row at a time): the same store either way.
make_tiff synth:1300x600:gray "$T/onestrip.tif" -c none -r 600
both "gray 1300x600 in one strip, --max-decoder-memory 100K" \
    "$T/onestrip.tif" 0.78 --max-decoder-memory 100K

# Level 0 kept in memory, its rows still read where they lie (and pairs
# of them reduced by pass 1's reader): the same store as through libtiff.
export GIGAVIEW_LEVEL0_RESIDENT=1
run encode -q 34 "$T/strips.tif" -o "$T/kept.gv"
expect_rc "RGB 1101x701 in strips, level 0 in memory: encode" 0
GIGAVIEW_RAW_REGIONS=0 run encode -q 34 "$T/strips.tif" -o "$T/kept-libtiff.gv"
expect_rc "... and through libtiff" 0
check "RGB 1101x701 in strips, level 0 in memory: the same store either way" \
    cmp -s "$T/kept.gv" "$T/kept-libtiff.gv"
export GIGAVIEW_LEVEL0_RESIDENT=0

# What is not stored as the encoder reads it goes through the scratch
# file: compressed, 16-bit, gray with alpha.
make_tiff synth:1100x700 "$T/lzw.tif" -c lzw -t -w 64 -l 64
run encode -q 34 "$T/lzw.tif" -o "$T/lzw.gv"
expect_rc "LZW tiles: encode" 0
check "LZW tiles: level 0 goes through the scratch file" \
    sh -c "! grep -q 'read again' '$T/out' && grep -q '^scratch' '$T/out'"
check "LZW tiles: the same store as the uncompressed ones" \
    cmp -s "$T/lzw.gv" "$T/rgb.gv"
run encode -q 34 "$TESTDATA/courtyard-160x120-u16.tif" -o "$T/u16.gv"
expect_rc "a 16-bit TIFF: encode" 0
check "a 16-bit TIFF: level 0 goes through the scratch file" \
    sh -c "! grep -q 'read again' '$T/out'"

# The real threshold: more than 4097^2 pixels leave memory by default
# (gray: a third of RGB's encoding time, for CI).
if under_valgrind; then
    skip "gray 4100x4100 in 128x128 tiles, by default" "valgrind: some 40 times slower"
else
    unset GIGAVIEW_LEVEL0_RESIDENT
    make_tiff synth:4100x4100:gray "$T/big.tif" -c none -t -w 128 -l 128
    both "gray 4100x4100 in 128x128 tiles, by default" "$T/big.tif" 16.81

    # An input rewritten between the two reads of level 0: the encoder is
    # stopped once its progress shows pass 1 ("pyramid", the first read,
    # begun after it noted the input's size and time), the file's
    # modification time changes, and it must fail at its check after pass
    # 2 (the second read) rather than publish a store of two images.  Pass
    # 1, not pass 2: the check follows pass 2 at once, which a fast
    # machine finished between a progress line and the stop.
    rm -f "$T/changed.gv"
    "$GIGAVIEW" encode -q 34 --progress --quiet "$T/big.tif" -o "$T/changed.gv" \
        2>"$T/progress" &
    pid=$!
    # shellcheck disable=SC2317 # run by wait_until
    reading_or_ended() {
        ! kill -0 "$pid" 2>/dev/null ||
            tr '\r' '\n' <"$T/progress" | grep -q '^pyramid '
    }
    wait_until reading_or_ended
    kill -STOP "$pid" 2>/dev/null
    touch "$T/big.tif"
    kill -CONT "$pid" 2>/dev/null
    rc=0
    wait "$pid" || rc=$?
    expect_rc "an input changed between the two reads of level 0: the encode fails" 1
    check "and says the input changed while being read" \
        grep -q 'changed while being read' "$T/progress"
    check "and publishes no store" test ! -e "$T/changed.gv"
fi

done_testing
