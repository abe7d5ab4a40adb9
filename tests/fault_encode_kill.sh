#!/bin/sh
# fault_encode_kill.sh - SIGKILL the encoder at 30 random moments: never a
# partial store under the final name, and a re-run succeeds.
#
# cli_kill.sh kills at a handful of fixed delays; this test spreads 30
# kills uniformly over a whole encode, so that every phase (probing,
# reading the input, building the pyramid, coding pages, writing the
# index and root, linking the file into place) gets hit over the runs.
# The encode's duration D is measured first (the faster of two runs,
# which also give the reference store); the delays are drawn from [0, 0.9 D) with a seed that
# is printed, and can be replayed with GV_FAULT_SEED=N.  After each kill:
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

now() {
    date +%s.%N
}

# The faster of two runs: a first run on a loaded machine, with cold
# caches, can take twice as long as the runs that follow, and then most
# kills would come after the end.
dur=
for run_ in 1 2; do
    t0=$(now)
    "$GIGAVIEW" encode $img $args --quiet -o "$T/ref.gv" >"$T/out.txt" 2>"$T/err" ||
        bail "reference encode failed: $(cat "$T/err")"
    t1=$(now)
    dur=$(echo "$t0 $t1 $dur" | awk '{ d = $2 - $1; if ($3 != "" && $3 < d) d = $3; printf "%.3f", d }')
done
seed=${GV_FAULT_SEED:-$(date +%s)}
diag "reference encode of $img: ${dur}s, $(wc -c <"$T/ref.gv" | tr -d ' ') bytes; seed $seed"

delays=$(awk -v d="$dur" -v s="$seed" 'BEGIN {
    srand(s)
    for (i = 0; i < 30; i++) printf "%.3f\n", rand() * d * 0.9
}')
i=0
killed=0
finished=0
for delay in $delays; do
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
    "$GIGAVIEW" encode $img $args $tmpdir --quiet -o "$dir/out.gv" \
        >"$T/out.txt" 2>"$T/err" &
    pid=$!
    sleep "$delay"
    kill -KILL "$pid" 2>/dev/null
    status=0
    wait "$pid" || status=$?
    what="kill $i after ${delay}s${old:+ (over a store)}${tmpdir:+ (--tmpdir)}"
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
# The delays cover the encode up to 90% of its measured duration; most
# must land inside it, or the test has not tested anything (runs much
# faster than the reference one, e.g. on a machine whose load dropped,
# would show it here).
check "at least 15 of 30 kills landed mid-encode ($killed)" test "$killed" -ge 15

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
