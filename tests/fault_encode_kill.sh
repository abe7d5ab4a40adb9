#!/bin/sh
# fault_encode_kill.sh - SIGKILL the encoder at 30 random moments: never a
# partial store under the final name, and a re-run succeeds.
#
# cli_kill.sh kills at a handful of fixed delays; this test spreads 30
# kills uniformly over a whole encode, so that every phase (probing,
# reading the input, building the pyramid, coding pages, writing the
# index and root, linking the file into place) gets hit over the runs.
# The kills land at points of the work, not of the clock: each run is
# killed once the encoder's progress line (--progress) reaches a
# percentage drawn with a seed that is printed, and can be replayed with
# GV_FAULT_SEED=N (see "points" below); at 100 the index, the root and
# the link into place are still to come.  (Delays drawn from a measured
# duration landed after the end whenever the machine's load dropped or
# rose between runs.)  After each kill:
#  - killed (exit 137): no file at the output path, nothing else in the
#    output directory or the scratch directory; where a good store was
#    already at that path (every other run), it is byte-identical;
#  - finished before the kill arrived (exit 0): the store at the path
#    is complete, byte-identical to the reference (the encoder is
#    deterministic).
# Afterwards a normal encode succeeds and is byte-identical to the
# reference.  Skipped under valgrind (the timings would mean nothing).
. "$(dirname "$0")/lib.sh"

if under_valgrind; then
    echo "1..0 # SKIP kill timings are meaningless under valgrind"
    exit 0
fi

dir="$T/d"
scratch="$T/scratch"
mkdir "$dir" "$scratch" || bail "mkdir"
img=synth:3000x3000
args="-r 3 -q 32"

run encode $img $args --quiet -o "$T/ref.gv"
[ "$rc" -eq 0 ] || bail "reference encode failed: $(cat "$T/err")"
seed=${GV_FAULT_SEED:-$(date +%s)}
diag "reference store of $img: $(wc -c <"$T/ref.gv" | tr -d ' ') bytes; seed $seed"

# Four runs in five at a point of the pyramid or the pages (the progress
# line moves in steps up to about 35 % on this image, then jumps to 100
# with its last page), every fifth at 100: the index, the root and the
# link into place.
points=$(awk -v s="$seed" 'BEGIN {
    srand(s)
    for (i = 0; i < 30; i++) printf "%d\n", i % 5 == 4 ? 100 : int(rand() * 36)
}')
i=0
killed=0
finished=0
for point in $points; do
    i=$((i + 1))
    rm -rf "$dir" "$scratch"
    mkdir "$dir" "$scratch"
    # Every other run replaces an existing store; every third run keeps its
    # scratch file beside the output (no --tmpdir).
    old=
    if [ $((i % 2)) -eq 0 ]; then
        cp "$T/ref.gv" "$dir/out.gv"
        old=1
    fi
    tmpdir="--tmpdir $scratch"
    [ $((i % 3)) -eq 0 ] && tmpdir=
    "$GIGAVIEW" encode $img $args $tmpdir --quiet --progress -o "$dir/out.gv" \
        >"$T/out.txt" 2>"$T/err" &
    kill_at_progress $! "$T/err" "$point" KILL
    what="kill $i at ${point} %${old:+ (over a store)}${tmpdir:+ (--tmpdir)}"
    case $status in
    137)
        killed=$((killed + 1))
        if [ -n "$old" ]; then
            check "$what: the old store is byte-identical" cmp -s "$dir/out.gv" "$T/ref.gv"
            check "$what: nothing else in the output directory" \
                test "$(listing "$dir")" = out.gv
        else
            # Empty, or the complete store when the kill landed after the
            # rename (the encoder was printing its summary or exiting).
            left=$(listing "$dir")
            if [ -z "$left" ]; then ok "$what: no store, output directory empty"
            elif [ "$left" = out.gv ] && cmp -s "$dir/out.gv" "$T/ref.gv"; then
                ok "$what: killed after publishing: the store is complete and identical"
            else
                not_ok "$what: left in the output directory" "$left"; fi
        fi
        check "$what: scratch directory empty" test -z "$(listing "$scratch")"
        ;;
    0)
        finished=$((finished + 1))
        check "$what: finished first; the store is complete and identical" \
            cmp -s "$dir/out.gv" "$T/ref.gv"
        check "$what: finished first; nothing else left" \
            sh -c "test '$(listing "$dir")' = out.gv && test -z '$(listing "$scratch")'"
        ;;
    *)
        not_ok "$what: exit $status, neither killed nor finished" "$(cat "$T/err")"
        ;;
    esac
done
diag "$killed runs killed mid-encode, $finished finished before the kill"
# Four points in five come before the encoder's last page; if most runs
# finished first, the test would not have tested anything.  (A point
# between two redraws of the progress line, 0.1 s apart, lands at the
# next: on a fast machine some land at 100 and the run may finish.)
check "at least 10 of 30 kills landed mid-encode ($killed)" test "$killed" -ge 10

rm -rf "$dir" "$scratch"
mkdir "$dir" "$scratch"
run encode $img $args --tmpdir "$scratch" --quiet -o "$dir/out.gv"
expect_rc "a normal encode after 30 kills" 0
check "it is byte-identical to the reference store" cmp -s "$dir/out.gv" "$T/ref.gv"
run info "$dir/out.gv"
expect_rc "info validates it" 0
check "only the store is in the directory, scratch empty" \
    sh -c "test '$(listing "$dir")' = out.gv && test -z '$(listing "$scratch")'"

done_testing
