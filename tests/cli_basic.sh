#!/bin/sh
# cli_basic.sh - end-to-end checks of `gigaview encode | info | export`.
#
# Encodes the committed crops (8-bit JPEG and PNG, 16-bit gray PNG, float
# EXR) and procedural images at edge sizes, then checks what `info`
# reports, that `export` writes images of the right size at level 0, in a
# sub-region and at root mips, that the decoded pixels are the ones the
# encoder measured (idiff's PSNR equals the stored level-0 PSNR), that
# root-only stores are lossless, that mosaics and thread counts do not
# change a single byte of the store, and the exit statuses of usage errors.
# Needs oiiotool and idiff (Debian: openimageio-tools).
. "$(dirname "$0")/lib.sh"
need_tool oiiotool idiff

# The source tree, absolute: $0 may be relative (make distcheck).
srcroot=$(cd "$(dirname "$0")/.." && pwd)
mkdir "$T/w" && cd "$T/w" || bail "cd $T/w"

# check_size DESCRIPTION FILE "W H C"
check_size() {
    got=$(image_size "$2")
    if [ "$got" = "$3" ]; then ok "$1: $2 is $3"; else
        not_ok "$1: $2 is '$got', wanted '$3'"; fi
}

# ------------------------------------------------------- committed crops
# name  width height channels  reference for the PSNR check
for spec in \
    "seeding-640x480.jpg 640 480 3 RGB" \
    "seeding-700x520.png 700 520 3 RGB" \
    "etopo-600x400-u16.png 600 400 1 gray" \
    "courtyard-256x128.exr 256 128 3 RGB"; do
    set -- $spec
    f=$1 w=$2 h=$3 c=$4 kind=$5
    s=${f%%.*}.gv
    run encode "$TESTDATA/$f" -o "$s"
    expect_rc "encode $f" 0
    check "encode $f: stderr empty off a terminal" test ! -s "$T/err"
    check "encode $f: summary names the size" \
        grep -q "^image  *$w x $h, $kind" "$T/out"
    # The PSNR reached, against the whole-image target of -q (default 40).
    p0=$(sed -n 's/^psnr  *\([0-9.]*\) dB at level 0 (target 40.0 dB, \([-+][0-9.]*\))$/\1 \2/p' "$T/out")
    check "encode $f: summary gives the PSNR reached and its distance to -q ($p0)" \
        awk -v a="${p0% *}" -v d="${p0#* }" 'BEGIN { exit !(a != "" && (a - 40 - d) ^ 2 < 0.0001) }'
    check "encode $f: store exists" test -s "$s"

    run info "$s"
    expect_rc "info $f" 0
    check "info $f: size and kind" grep -q "^image  *$w x $h, $kind\$" "$T/out"
    check "info $f: format version 6" grep -q "(format version 6)" "$T/out"

    run info --json "$s"
    expect_rc "info --json $f" 0
    cp "$T/out" info.json
    check "info --json $f: width $w" test "$(json_field info.json width)" = "$w"
    check "info --json $f: height $h" test "$(json_field info.json height)" = "$h"
    check "info --json $f: channels $c" test "$(json_field info.json channels)" = "$c"
    check "info --json $f: bytes = file size" \
        test "$(json_field info.json bytes)" = "$(wc -c <"$s" | tr -d ' ')"
    check "info --json $f: one JSON line, closed" \
        test "$(wc -l <info.json)" -eq 1 -a "$(tail -c 3 info.json)" = "]}"
    psnr0=$(json_field info.json psnr0)
    root=$(json_field info.json root_level)
    mips=$(json_field info.json root_mips)

    # Level 0, whole.
    run export "$s" -o l0.png
    expect_rc "export $f level 0" 0
    check_size "export $f level 0" l0.png "$w $h $c"

    # The exported pixels are exactly what the encoder measured: idiff's
    # PSNR against the input brought to 8 bits equals the stored psnr0.
    case $f in
    *.exr)
        # Float input: clip to [0,1] and sRGB-encode like the encoder
        # (docs/FORMAT.md).  Only the curve's rounding differs from the
        # encoder's (at most one code value), so the export's PSNR
        # against this is within 0.3 dB of the stored psnr0.
        oiiotool "$TESTDATA/$f" --clamp:min=0:max=1 \
            --colorconvert linear sRGB -d uint8 -o ref8.png
        p=$(idiff_psnr ref8.png l0.png)
        check "export $f: decoded PSNR $p near the stored psnr0 $psnr0" \
            close_to "$p" "$psnr0" 0.3
        ;;
    *)
        oiiotool "$TESTDATA/$f" -d uint8 -o ref8.png
        p=$(idiff_psnr ref8.png l0.png)
        if close_to "$p" "$psnr0" 0.01; then
            ok "export $f: decoded PSNR $p = stored psnr0 $psnr0"
        else
            not_ok "export $f: decoded PSNR '$p' != stored psnr0 '$psnr0'"
        fi
        ;;
    esac

    # A sub-region, as TIFF; it must equal the same cut of level 0.
    rx=$((w / 3)) ry=$((h / 4)) rw=$((w / 2)) rh=$((h / 3))
    run export "$s" --region "$rx,$ry,$rw,$rh" -o region.tif
    expect_rc "export $f region $rx,$ry,$rw,$rh to .tif" 0
    check_size "export $f region" region.tif "$rw $rh $c"
    oiiotool l0.png --cut "${rw}x${rh}+${rx}+${ry}" -o cut.png
    check "export $f region equals the cut of level 0" \
        idiff -q -fail 0 cut.png region.tif

    # The first root mip (half the root) and the last one (1x1).
    # The root level's size, from the per-level list of the JSON.
    set -- $(grep -o "{\"level\":$root,\"width\":[0-9]*,\"height\":[0-9]*" info.json |
        sed 's/.*"width":\([0-9]*\),"height":\([0-9]*\)/\1 \2/')
    [ $# -eq 2 ] || bail "no root level $root in $(cat info.json)"
    mw=$(( ($1 + 1) / 2 )) mh=$(( ($2 + 1) / 2 ))
    run export "$s" --level $((root + 1)) -o mip1.png
    expect_rc "export $f root mip 1 (level $((root + 1)))" 0
    check_size "export $f root mip 1" mip1.png "$mw $mh $c"
    last=$((root + mips - 1))
    run export "$s" -l $last -o mipl.tif
    expect_rc "export $f last root mip (level $last)" 0
    check_size "export $f last root mip" mipl.tif "1 1 $c"
    run export "$s" -l $((last + 1)) -o none.png
    expect_rc "export $f level past the last" 1
    expect_err_is "export $f level past the last: message" \
        "gigaview export: no level $((last + 1)) (the store has 0..$last)"
    check "export $f level past the last: no output" test ! -e none.png
    rm -f l0.png region.tif cut.png mip1.png mipl.tif ref8.png
done

# A JPEG export opens and has the right size (lossy, so no pixel check).
run export seeding-640x480.gv --region 10,20,300,200 -o r.jpg
expect_rc "export to .jpg" 0
check_size "export to .jpg" r.jpg "300 200 3"

# --------------------------------------------------------- edge sizes
# synth:WxH[:gray] at sizes around the tile size and far from square.
# The long thin ones use a low quality to stay fast.
for spec in "1x1 1 1 3" "513x513 513 513 3" "514x514 514 514 3" \
    "514x514:gray 514 514 1" "1x70000 1 70000 3" "70000x1:gray 70000 1 1"; do
    set -- $spec
    src=$1 w=$2 h=$3 c=$4
    s=edge.gv
    rm -f "$s"
    fast=
    [ "$w" -gt 1000 ] || [ "$h" -gt 1000 ] && fast="-r 4 -q 30"
    run encode "synth:$src" -o "$s" --quiet $fast
    expect_rc "encode synth:$src" 0
    check "encode synth:$src --quiet: no output at all" \
        test ! -s "$T/out" -a ! -s "$T/err"
    run info --json "$s"
    expect_rc "info synth:$src" 0
    cp "$T/out" info.json
    check "info synth:$src: ${w}x$h, $c channels" test \
        "$(json_field info.json width) $(json_field info.json height) $(json_field info.json channels)" = "$w $h $c"
    # A region at the far corner of level 0 (the last tile's column/row).
    rw=$((w < 100 ? w : 100)) rh=$((h < 100 ? h : 100))
    rx=$((w - rw)) ry=$((h - rh))
    run export "$s" --region "$rx,$ry,$rw,$rh" -o edge.png
    expect_rc "export synth:$src region $rx,$ry,$rw,$rh" 0
    check_size "export synth:$src region" edge.png "$rw $rh $c"
    run export "$s" --region "$rx,$ry,$((rw + 1)),$rh" -o bad.png
    expect_rc "export synth:$src region one past the edge" 1
    expect_err_is "export synth:$src region one past the edge: message" \
        "gigaview export: region $rx,$ry,$((rw + 1)),$rh is outside level 0 ($w x $h)"
    check "export synth:$src region one past the edge: no output" test ! -e bad.png
    if [ "$src" = 1x70000 ]; then
        # A whole 1x70000 level 0 exports in one piece.
        run export "$s" -o tall.png
        expect_rc "export all of a 1x70000 level 0" 0
        check_size "export 1x70000" tall.png "1 70000 3"
        rm -f tall.png
    fi
    rm -f edge.png
done
rm -f edge.gv

# ------------------------------------------------- lossless root stores
# A store whose level 0 is its root (<= 128 a side, the root side of
# format version 6) keeps the pixels exactly: export == input, and psnr0
# is reported as 99.
oiiotool --pattern fill:topleft=0,0,0:topright=1,0,0:bottomleft=0,1,0:bottomright=0,0,1 \
    128x128 3 --noise:type=uniform:min=0:max=0.3:seed=7 -d uint8 -o n128.png ||
    bail "oiiotool --pattern"
oiiotool n128.png --ch R -o g128.png || bail "oiiotool --ch"
oiiotool --pattern constant:color=0.2,0.4,0.6 1x1 3 -d uint8 -o one.png ||
    bail "oiiotool 1x1"
for f in n128.png g128.png one.png; do
    run encode "$f" -o ll.gv --quiet
    expect_rc "encode $f" 0
    gv info --json ll.gv >info.json
    check "$f: psnr0 is 99 (lossless)" test "$(json_field info.json psnr0)" = 99.000
    run export ll.gv -o back.png
    expect_rc "export $f" 0
    check "$f: export is identical to the input" idiff -q -fail 0 "$f" back.png
    rm -f ll.gv back.png
done
# One more than the root side is tiled and lossy, but still right-sized.
oiiotool n128.png --resize 129x129 -o n129.png
gv encode n129.png -o t.gv --quiet || bail "encode n129"
run export t.gv -o back.png
check_size "129x129 tiled store" back.png "129 129 3"
p=$(idiff_psnr n129.png back.png)
check "129x129: decoded PSNR $p = stored psnr0" \
    close_to "$p" "$(gv info --json t.gv | grep -o '"psnr0":[0-9.]*' | cut -d: -f2)" 0.01
rm -f t.gv back.png n129.png

# ------------------------------------------------------------- mosaic
# A 2x2 mosaic of the cut-up image encodes to the very same bytes.
img="$TESTDATA/seeding-700x520.png"
oiiotool "$img" --cut 350x260+0+0 -o m00.png &&
    oiiotool "$img" --cut 350x260+350+0 -o m10.png &&
    oiiotool "$img" --cut 350x260+0+260 -o m01.png &&
    oiiotool "$img" --cut 350x260+350+260 -o m11.png || bail "oiiotool --cut"
run encode --mosaic 2x2 m00.png m10.png m01.png m11.png -o mosaic.gv --quiet
expect_rc "encode --mosaic 2x2" 0
check "mosaic store is byte-identical to the whole image's" \
    cmp -s mosaic.gv seeding-700x520.gv
# Row-major order matters: swapping two tiles gives a different store.
run encode -m 2x2 m10.png m00.png m01.png m11.png -o swapped.gv --quiet
expect_rc "encode a mosaic with two tiles swapped" 0
check "swapped mosaic differs" test -s swapped.gv -a -n "$(cmp swapped.gv mosaic.gv 2>&1)"
# Mosaic column widths must agree.
oiiotool "$img" --cut 340x260+0+0 -o narrow.png
run encode -m 2x2 m00.png m10.png narrow.png m11.png -o bad.gv
expect_rc "mosaic with a mismatched tile fails" 1
expect_err_is "mosaic with a mismatched tile: message" \
    "gigaview encode: source: mosaic: narrow.png is 340 pixels wide but m00.png above it in grid column 1 is 350"
check "mosaic with a mismatched tile: no output" test ! -e bad.gv
rm -f m??.png narrow.png swapped.gv mosaic.gv

# ------------------------------------------------------- determinism
# Thread count does not change a byte (several pages and levels).
run encode synth:2100x1300 -q 30 -r 6 -j 1 -o j1.gv --quiet
expect_rc "encode -j 1" 0
run encode synth:2100x1300 -q 30 -r 6 -j 2 -o j2.gv --quiet
expect_rc "encode -j 2" 0
check "-j 1 and -j 2 stores are byte-identical" cmp -s j1.gv j2.gv
run encode "$TESTDATA/seeding-700x520.png" -j 2 -o j2b.gv --quiet
check "-j 2 on the PNG matches the default run" cmp -s j2b.gv seeding-700x520.gv
# Every kernel has SIMD paths and a portable one: the same bytes at each
# level of GIGAVIEW_SIMD (at -q 50 two of the four tiles are D tiles).
run encode "$TESTDATA/seeding-700x520.png" -q 50 -o simd-max.gv --quiet
for level in c avx2 avx512; do
    GIGAVIEW_SIMD=$level run encode "$TESTDATA/seeding-700x520.png" -q 50 \
        -o simd-$level.gv --quiet
    check "GIGAVIEW_SIMD=$level gives the same store" cmp -s simd-$level.gv simd-max.gv
done
# The encoder cuts blocks short where their last values cost more bits
# than the error they remove (FORMAT.md 8): at equal PSNR the store is
# smaller than without the cut (GIGAVIEW_RDO_TAILS=0).  Each way is
# encoded at -q 38 and 42 (the lambda trial lands each at its own PSNR),
# and its bytes at the PSNR between the four are interpolated (log bytes
# linear in dB); bench/encoder-rd-diff.sh measures the gain over a curve.
rd_point() { # TAIL-SETTING Q: "bytes psnr" of picos at -q Q
    GIGAVIEW_RDO_TAILS=$1 run encode "$TESTDATA/picos-1100x700.jpg" -q "$2" -o cut.gv
    echo "$(sed -n 's/^size *\([0-9]*\) bytes.*/\1/p' "$T/out") $(sed -n 's/^psnr *\([0-9.]*\) dB.*/\1/p' "$T/out")"
}
pts="$(rd_point 1 38) $(rd_point 1 42) $(rd_point 0 38) $(rd_point 0 42)"
check "cutting blocks short saves bytes at equal PSNR ($pts: cut 38, 42, uncut 38, 42)" \
    awk -v s="$pts" 'function at(b1, p1, b2, p2, p) { return exp(log(b1) + (log(b2) - log(b1)) * (p - p1) / (p2 - p1)) }
        BEGIN { n = split(s, v, " "); if (n != 8 || v[4] <= v[2] || v[8] <= v[6]) exit 1
                p = (v[2] + v[4] + v[6] + v[8]) / 4
                exit !(at(v[1], v[2], v[3], v[4], p) < at(v[5], v[6], v[7], v[8], p)) }'
rm -f cut.gv uncut.gv
# Pass 2 maps each page's window from the scratch file; copying it
# (GIGAVIEW_SPILL_VIEWS=0, the fallback where mapping fails) gives the
# same bytes.  4400 wide: two pages of level 0, the second one narrow.
# 4400 x 700 keeps level 0 in memory (the levels above are mapped or
# copied); 4400 x 3900 is more than 4097^2 pixels, so level 0 is mapped
# or copied too.  (cli_shard.sh compares an encode that keeps level 0 in
# memory with shards, which never do.)
for size in 4400x700 4400x3900; do
    run encode synth:$size -q 30 -r 4 -o views.gv --quiet
    expect_rc "encode $size with mapped windows" 0
    GIGAVIEW_SPILL_VIEWS=0 run encode synth:$size -q 30 -r 4 -o copies.gv --quiet
    check "$size: windows copied from the scratch file give the same store" \
        cmp -s views.gv copies.gv
done
rm -f views.gv copies.gv
# Re-encoding over an existing store replaces it.
run encode synth:600x300:gray -o j1.gv --quiet
expect_rc "encode over an existing store" 0
gv info --json j1.gv >info.json
check "the store was replaced" test "$(json_field info.json width)" = 600
rm -f j1.gv j2.gv j2b.gv avx2.gv noavx2.gv

# ----------------------------------------------------------- progress
run encode synth:1100x700 -o p.gv --progress --quiet
expect_rc "encode --progress" 0
# The bar is redrawn after carriage returns; the last drawing is the full
# bar at 100.0% (the rate and the time vary).
check "--progress ends with the full bar at 100.0% on stderr" sh -c \
    "tr '\\r' '\\n' <'$T/err' | tail -n 1 |
        grep -Eq '^done     \\[#{30}\\] 100\\.0% +[0-9.]+ MP/s +[0-9]+:[0-9]{2} total\$'"
# Tiles overlap, so their samples add up to more than the pixels: the
# percentage must still never pass 100.
top_pct=$(tr '\r' '\n' <"$T/err" | sed -n 's/.*\] *\([0-9.]*\)%.*/\1/p' | sort -n | tail -n 1)
check "--progress never shows more than 100% (top $top_pct)" test "$top_pct" = 100.0
check "--progress --quiet: nothing on stdout" test ! -s "$T/out"
rm -f p.gv

# ------------------------------------------------------- usage errors
# Each must exit 2, print its message (the first line of stderr, checked
# exactly; a usage text follows some) on stderr only, and create nothing.
# usage_case DESCRIPTION FIRST-LINE ARGS...
usage_case() {
    desc=$1 want=$2
    shift 2
    run "$@"
    expect_rc "usage: $desc" 2
    got=$(head -n 1 "$T/err")
    if [ "$got" = "$want" ] && [ ! -s "$T/out" ]; then ok "usage: $desc: message on stderr only"; else
        not_ok "usage: $desc: message on stderr only" "got: $got" "wanted: $want"; fi
}
U_TOP="usage: gigaview COMMAND [ARGS]"
U_ENC="usage: gigaview encode [OPTIONS] INPUT... -o STORE"
U_INFO="usage: gigaview info STORE [--json]"
U_EXP="usage: gigaview export STORE [--level L] [--region X,Y,W,H] -o OUT"
E="gigaview encode:"
X="gigaview export:"
# --layouts vq: the VQ encoder alone writes a format version 2 store, for
# readers older than layout D; it decodes like any other.
run encode -q 36 synth:700x600 -o "$T/d.gv"
check "default layouts: the summary counts D tiles" grep -q "^tiles .* D:[1-9]" "$T/out"
run encode --layouts vq -q 36 synth:700x600 -o "$T/vq.gv"
expect_rc "encode --layouts vq" 0
check "--layouts vq: VQ tiles only" sh -c 'grep -q "^tiles .*rate:tiles" "$1" && ! grep -q "D:" "$1"' sh "$T/out"
run info "$T/vq.gv"
check "--layouts vq: format version 2" grep -q "(format version 2)" "$T/out"
run export "$T/vq.gv" -o "$T/vq.png"
expect_rc "--layouts vq: the store exports" 0
# A store of format version 4 (tiles in layout D, before D2) still reads.
run info "$TESTDATA/v4-picos-1100x700.gv"
check "version 4: info names it" grep -q "(format version 4)" "$T/out"
run export "$TESTDATA/v4-picos-1100x700.gv" -o "$T/v4.png"
expect_rc "version 4: the store exports" 0

usage_case "no command" "$U_TOP"
usage_case "unknown command" "gigaview: unknown command 'frobnicate'" frobnicate
usage_case "encode without -o" "$U_ENC" encode synth:10x10
usage_case "encode without input" "$U_ENC" encode -o u.gv
usage_case "encode -r 0" "$E --max-rate wants 1..12, not '0'" encode -r 0 synth:10x10 -o u.gv
usage_case "encode -r 13" "$E --max-rate wants 1..12, not '13'" encode -r 13 synth:10x10 -o u.gv
usage_case "encode -j 0" "$E --jobs wants 1..1024, not '0'" encode -j 0 synth:10x10 -o u.gv
usage_case "encode -j x" "$E --jobs wants 1..1024, not 'x'" encode -j x synth:10x10 -o u.gv
usage_case "encode -q 0" "$E --psnr wants a number of dB in (0, 99], not '0'" \
    encode -q 0 synth:10x10 -o u.gv
usage_case "encode -q 100" "$E --psnr wants a number of dB in (0, 99], not '100'" \
    encode -q 100 synth:10x10 -o u.gv
usage_case "encode -q 30dB" "$E --psnr wants a number of dB in (0, 99], not '30dB'" \
    encode -q 30dB synth:10x10 -o u.gv
usage_case "encode -q with --min-tile-psnr" \
    "$E --min-tile-psnr is a mode of its own: give it without -q or --rd" \
    encode -q 35 --min-tile-psnr 35 synth:10x10 -o u.gv
usage_case "encode --layouts jpeg" "$E --layouts wants d, all or vq, not 'jpeg'" \
    encode --layouts jpeg synth:10x10 -o u.gv
usage_case "encode --min-tile-psnr with --layouts d" \
    "$E --min-tile-psnr codes VQ tiles only: give it without --layouts (or with --layouts vq)" \
    encode --min-tile-psnr 35 --layouts d synth:10x10 -o u.gv
usage_case "encode --min-tile-psnr 0" "$E --min-tile-psnr wants a number of dB in (0, 99], not '0'" \
    encode --min-tile-psnr 0 synth:10x10 -o u.gv
usage_case "encode --mosaic 2" "$E --mosaic wants COLSxROWS, not '2'" \
    encode --mosaic 2 synth:10x10 -o u.gv
usage_case "encode --mosaic 0x1" "$E --mosaic wants COLSxROWS, not '0x1'" \
    encode --mosaic 0x1 synth:10x10 -o u.gv
usage_case "encode --mosaic count mismatch" "$E a 2x1 mosaic needs 2 inputs, got 1" \
    encode -m 2x1 synth:10x10 -o u.gv
usage_case "encode two inputs without --mosaic" "$E several inputs need --mosaic COLSxROWS" \
    encode synth:10x10 synth:10x10 -o u.gv
usage_case "encode --range 5:1" "$E --range wants LO:HI with LO < HI" \
    encode --range 5:1 synth:10x10 -o u.gv
usage_case "encode --range 5" "$E --range wants LO:HI" encode --range 5 synth:10x10 -o u.gv
usage_case "encode --max-pixels 0" "$E --max-pixels wants a positive count" \
    encode --max-pixels 0 synth:10x10 -o u.gv
usage_case "encode --max-pixels -5 (strtoull would wrap it)" "$E --max-pixels wants a positive count" \
    encode --max-pixels -5 synth:10x10 -o u.gv
usage_case "encode --max-decoder-memory 0" \
    "$E --max-decoder-memory wants a positive size: digits with an optional K, M, G or T, not '0'" \
    encode --max-decoder-memory 0 synth:10x10 -o u.gv
usage_case "encode --max-decoder-memory 1X" \
    "$E --max-decoder-memory wants a positive size: digits with an optional K, M, G or T, not '1X'" \
    encode --max-decoder-memory 1X synth:10x10 -o u.gv
usage_case "encode --max-decoder-memory 99999999999T (past 64 bits)" \
    "$E --max-decoder-memory wants a positive size: digits with an optional K, M, G or T, not '99999999999T'" \
    encode --max-decoder-memory 99999999999T synth:10x10 -o u.gv
# getopt's own words (glibc), then the usage.
usage_case "encode unknown option" "$E unrecognized option '--frobnicate'" \
    encode --frobnicate synth:10x10 -o u.gv
usage_case "info without a store" "$U_INFO" info
usage_case "info with two stores" "$U_INFO" info a.gv b.gv
usage_case "export without -o" "$U_EXP" export seeding-640x480.gv
usage_case "export without a store" "$U_EXP" export -o u.png
usage_case "export --level -1" "$X bad --level '-1'" export seeding-640x480.gv -l -1 -o u.png
usage_case "export --level x" "$X bad --level 'x'" export seeding-640x480.gv -l x -o u.png
usage_case "export --region 1,2,3" "$X --region wants X,Y,W,H, not '1,2,3'" \
    export seeding-640x480.gv --region 1,2,3 -o u.png
usage_case "export --max-pixels 0" "$X bad --max-pixels '0'" \
    export seeding-640x480.gv --max-pixels 0 -o u.png
usage_case "export --max-pixels ' 7'" "$X bad --max-pixels ' 7'" \
    export seeding-640x480.gv --max-pixels " 7" -o u.png
check "usage errors created no file" test ! -e u.gv -a ! -e u.png

for cmd in "" encode info export; do
    run $cmd --help
    expect_rc "gigaview $cmd --help" 0
    case $cmd in
    encode) want=$U_ENC ;;
    info) want=$U_INFO ;;
    export) want=$U_EXP ;;
    *) want=$U_TOP ;;
    esac
    check "gigaview $cmd --help: usage on stdout" test "$(head -n 1 "$T/out")" = "$want"
done
run --version
expect_rc "gigaview --version" 0
version=$(sed -n 's/^AC_INIT(\[gigaview\], \[\([^]]*\)\].*/\1/p' "$srcroot/configure.ac")
check "--version prints the version of configure.ac ($version)" \
    test "$(cat "$T/out")" = "gigaview $version"

# --------------------------------------------------- run-time errors
# Exit 1 with a message naming the problem.
run info missing.gv
expect_rc "info on a missing store" 1
expect_err_is "info on a missing store: message" \
    "gigaview info: store: missing.gv: No such file or directory"
run info "$TESTDATA/seeding-640x480.jpg"
expect_rc "info on a JPEG" 1
expect_err_is "info on a JPEG: message" "gigaview info: store: not a gigaview store (bad magic)"
run export seeding-640x480.gv --region 600,0,41,10 -o u.png
expect_rc "export region past the right edge" 1
run export seeding-640x480.gv --max-pixels 100 -o u.png
expect_rc "export over --max-pixels" 1
expect_err_is "export over --max-pixels: message" \
    "gigaview export: region of 307200 pixels exceeds the limit of 100 (--max-pixels)"
run export seeding-640x480.gv -o u.bogusformat
expect_rc "export to an unknown format" 1
expect_err_is "export to an unknown format: message" \
    "gigaview export: imageio: u.bogusformat: unsupported output format \".bogusformat\" (png, jpg, webp, tif)"
check "run-time errors created no file" test ! -e u.png -a ! -e u.bogusformat

check "no stray files left in the work directory" \
    test -z "$(listing . | grep -v -e '\.gv$' -e '^info\.json$' -e '^n128\.png$' \
        -e '^g128\.png$' -e '^one\.png$' -e '^r\.jpg$')"

done_testing
