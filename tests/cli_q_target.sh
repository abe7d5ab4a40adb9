#!/bin/sh
# cli_q_target.sh - `-q` lands within 1 dB of the level-0 PSNR asked for,
# and the lambda trial that makes it so (lib/encode/lambda_trial.h) keeps
# stores deterministic.
#
# On the test photographs at -q 36, 40 and 44 (tests/data/picos-1100x700.jpg:
# the whole image is the trial's sample), and on a 5x5 mosaic of Picos
# (109 tiles: 8 groups of 2x2 tiles sampled, the whole level estimated
# from them with the rate model): the summary's reached PSNR is within
# 1 dB of -q.  The rate model alone landed Picos at -q 44 at +1.22 dB and
# the mosaic at -q 40 at -1.62 dB.  The mosaic's store is the same byte
# for byte with one worker, when pass 2 codes the sample's tiles again
# instead of taking the trial's (GIGAVIEW_TRIAL_REUSE=0), and as two
# merged shards (each shard keeps the sample's originals beside its own).
# Under valgrind only the mosaic at one quality runs.
. "$(dirname "$0")/lib.sh"

# reached FILE: the PSNR of the summary in FILE.
reached() {
    sed -n 's/^psnr *\([0-9.]*\) dB.*/\1/p' "$1"
}

# lands DESCRIPTION Q: the last run succeeded, printed the trial's line,
# and reached Q within 1 dB.
lands() {
    p=$(reached "$T/out")
    if [ "$rc" -ne 0 ] || [ -z "$p" ]; then
        not_ok "$1" "exit $rc" "$(head -c 2000 "$T/err")"
    elif ! grep -q '^lambda .* trial encode' "$T/out"; then
        not_ok "$1: the summary names the trial" "$(cat "$T/out")"
    elif awk -v p="$p" -v q="$2" 'BEGIN { d = p - q; exit !(d >= -1 && d <= 1) }'; then
        ok "$1: $p dB"
    else
        not_ok "$1: $p dB, more than 1 dB from $2" "$(cat "$T/out")"
    fi
}

picos=$TESTDATA/picos-1100x700.jpg
if ! under_valgrind; then
    for q in 36 40 44; do
        run encode "$picos" -q "$q" -o "$T/p$q.gv"
        lands "picos -q $q" "$q"
    done
fi

# The mosaic: 25 copies of Picos, 5500 x 3500.
set -- --mosaic 5x5
i=0
while [ $i -lt 25 ]; do
    set -- "$@" "$picos"
    i=$((i + 1))
done
run encode "$@" -q 40 -o "$T/m.gv"
lands "mosaic -q 40" 40
if ! under_valgrind; then
    run encode "$@" -q 40 -j 1 -o "$T/m1.gv"
    check "mosaic: one worker writes the same store" cmp -s "$T/m.gv" "$T/m1.gv"
    GIGAVIEW_TRIAL_REUSE=0 run encode "$@" -q 40 -o "$T/m2.gv"
    check "mosaic: the sample coded again in pass 2 gives the same store" \
        cmp -s "$T/m.gv" "$T/m2.gv"
    run encode "$@" -q 40 --shard 0/2 -o "$T/s0"
    rc0=$rc
    run encode "$@" -q 40 --shard 1/2 -o "$T/s1"
    rc1=$rc
    run merge -o "$T/ms.gv" "$T/s1" "$T/s0"
    if [ "$rc0" -eq 0 ] && [ "$rc1" -eq 0 ] && [ "$rc" -eq 0 ] &&
        cmp -s "$T/m.gv" "$T/ms.gv"; then
        ok "mosaic: two merged shards write the same store"
    else
        not_ok "mosaic: two merged shards write the same store" \
            "shards exit $rc0 $rc1, merge exit $rc" "$(head -c 2000 "$T/err")"
    fi
fi
done_testing
