#!/bin/sh
# cli_height_bytes.sh - the streaming height encoder writes the stores of
# the in-memory encoder it replaced, byte for byte, and keeps the
# operator's --max-pixels limit.
#
# The hashes below are of the stores that the in-memory encoder (main at
# 818f633, 2026-12-02, before height encodes streamed) wrote for the same
# inputs and options: the three ETOPO crops of tests/data at E = 0, 2 and
# 25 m (one to three tiles, two and three levels), and synth-height at
# 4100 x 4100 (2 x 2 pages at level 0, 2 threads) at e = 3.  A store is
# the same on every machine and for any number of threads, so the hashes
# hold anywhere.  The 4100 x 4100 case is skipped under valgrind (slow).
. "$(dirname "$0")/lib.sh"

while read -r hash name input e; do
    case $input in
    synth-height:*)
        if under_valgrind; then
            skip "$name" "slow under valgrind"
            continue
        fi
        run encode --quiet --height --max-error "$e" -j 2 "$input" -o "$T/$name" </dev/null ;;
    *)
        run encode --quiet --height --offset -11000 --unit m --max-error "$e" \
            "$TESTDATA/$input" -o "$T/$name" </dev/null ;;
    esac
    if [ "$rc" -ne 0 ]; then
        not_ok "$name: encode failed" "$(head -c 2000 "$T/err")"
        continue
    fi
    got=$(sha256sum "$T/$name" | cut -d' ' -f1)
    check "$name: the bytes of the in-memory encoder's store" test "$got" = "$hash"
done <<'HASHES'
a2b7f4e7fe9e59b5dbd301c043832d468835512d9555c6c76dbeeffe5cf21a58 etopo-600x400-E0.gv etopo-600x400-u16.png 0
09ac4aef5ba32a1407c93e6016747b0582d5feb2efaf9fe6e50a5b66f448d306 etopo-600x400-E2.gv etopo-600x400-u16.png 2
662aa181e0caecb04fa36269ee460b4adcb4ab271ce0a2f71408ff250e5b96b7 etopo-600x400-E25.gv etopo-600x400-u16.png 25
f3d4f9530ea66824dc11e34117c9a7d882e40e1a9c137eb87d3866b9443aa456 etopo5-720x361-E0.gv etopo5-720x361-u16.png 0
4b094e7fad8ec0a44f06573bd6a43ddb1bda352fe80d856b8204d6740a1eb33d etopo5-720x361-E2.gv etopo5-720x361-u16.png 2
3f226f035e660a4b9c84cd40d590e80b082b23249e1bde21dc9b7e4a532c0849 etopo5-720x361-E25.gv etopo5-720x361-u16.png 25
f565b47e86704013fe13a64b9832b6175e2da86eab81e46b3e9bf0e51c17fcb7 himalaya-E0.gv etopo5-himalaya-1030x300-u16.png 0
04f0c326a080a83da6b91282399e2adaaf31547be3b6ad52e33e9fe663126dc5 himalaya-E2.gv etopo5-himalaya-1030x300-u16.png 2
522f853165a56b33b3dbf9f9e49c7910a2c99e9bc9fbbe961486098d7fe0ba33 himalaya-E25.gv etopo5-himalaya-1030x300-u16.png 25
73c8a83eb8461e6d41ae8207829513d066c99ac1f640067738bf65d9e2009e45 synth-4100-E3.gv synth-height:4100x4100 3
HASHES

# --max-pixels is the operator's limit, for files and patterns alike.
run encode --quiet --height --max-pixels 100000 \
    "$TESTDATA/etopo5-720x361-u16.png" -o "$T/limit.gv"
expect_rc "720x361 with --max-pixels 100000 is refused" 1
run encode --quiet --height --max-pixels 100000 synth-height:400x300 -o "$T/limit.gv"
expect_rc "synth-height:400x300 with --max-pixels 100000 is refused" 1
expect_err "... saying so" "exceed the limit of 100000"
check "no store is left behind" test ! -e "$T/limit.gv"
# A mosaic's tiles must agree: one channel, the same sample type.
run encode --quiet --height --mosaic 2x1 "$TESTDATA/etopo5-720x361-u16.png" \
    synth-height:720x361 -o "$T/bad.gv"
expect_rc "a pattern as a mosaic tile is refused" 1
run encode --quiet synth-height:64x64 -o "$T/bad.gv"
expect_rc "synth-height: without --height is refused" 1
expect_err "... naming --height" "needs a height store \(--height\)"

done_testing
