#!/bin/sh
# cli_kill.sh - a killed encode leaves nothing behind.
#
# The store is written to an unnamed O_TMPFILE and linked into place only
# when complete, and the scratch file is unnamed too, so SIGKILL at any
# moment - reading the input, building the pyramid, encoding pages - must
# leave no file at the output path and nothing else in its directory (or
# in --tmpdir), and an existing store at that path must survive byte for
# byte.  Skipped under valgrind (the timings would be meaningless).
. "$(dirname "$0")/lib.sh"

if under_valgrind; then
    echo "1..0 # SKIP kill timings are meaningless under valgrind"
    exit 0
fi

dir="$T/d"
scratch="$T/scratch"
mkdir "$dir" "$scratch" || bail "mkdir"
# A few seconds of work on two cores at the default quality.
big=synth:6000x6000

# kill_at SECONDS SIGNAL ARGS...: start `gigaview encode ARGS` in the
# background, send SIGNAL after SECONDS and reap it; sets $status.
kill_at() {
    secs=$1 sig=$2
    shift 2
    "$GIGAVIEW" encode "$@" >"$T/out" 2>"$T/err" &
    pid=$!
    sleep "$secs"
    kill -s "$sig" "$pid" 2>/dev/null
    status=0
    wait "$pid" || status=$?
}

# The encode's duration D is measured first (its store removed): the kills
# below land at fixed fractions of it, from 0.6 % to a third, so that every
# one of them comes before the end however fast the encoder or machine (a
# faster encoder made fixed delays of up to 3 s land after it).
t0=$(date +%s.%N)
"$GIGAVIEW" encode "$big" --tmpdir "$scratch" -o "$dir/out.gv" >"$T/out" 2>"$T/err" ||
    bail "reference encode failed: $(cat "$T/err")"
t1=$(date +%s.%N)
rm -f "$dir/out.gv"
# at FRACTION: FRACTION of D in seconds.
at() {
    echo "$t0 $t1 $1" | awk '{ printf "%.3f", ($2 - $1) * $3 }'
}
diag "reference encode of $big: $(at 1)s"

for frac in 0.006 0.02 0.05 0.11 0.17 0.33; do
    secs=$(at "$frac")
    kill_at "$secs" KILL "$big" --tmpdir "$scratch" -o "$dir/out.gv"
    if [ "$status" -eq 137 ]; then ok "SIGKILL after ${secs}s: killed"; else
        not_ok "SIGKILL after ${secs}s: exit $status, not killed (too fast?)"; fi
    check "SIGKILL after ${secs}s: no store" test ! -e "$dir/out.gv"
    left=$(listing "$dir")
    if [ -z "$left" ]; then ok "SIGKILL after ${secs}s: output directory empty"; else
        not_ok "SIGKILL after ${secs}s: left in the output directory" "$left"; fi
    check "SIGKILL after ${secs}s: scratch directory empty" test -z "$(listing "$scratch")"
done
# Without --tmpdir the scratch file lives beside the output.
kill_at "$(at 0.11)" KILL "$big" -o "$dir/out.gv"
check "SIGKILL without --tmpdir: killed" test "$status" -eq 137
check "SIGKILL without --tmpdir: output directory empty" test -z "$(listing "$dir")"
# SIGTERM has no handler: same outcome.  (SIGINT cannot be tested this
# way: a non-interactive shell starts background jobs with it ignored.)
for sig in TERM; do
    kill_at "$(at 0.09)" "$sig" "$big" -o "$dir/out.gv"
    check "SIG$sig: the encode stopped" test "$status" -gt 128
    check "SIG$sig: output directory empty" test -z "$(listing "$dir")"
done

# After all that, a normal run succeeds and the store validates.
run encode "$big" -r 4 -q 30 --tmpdir "$scratch" -o "$dir/out.gv" --quiet
expect_rc "a normal encode after the kills" 0
run info "$dir/out.gv"
expect_rc "info validates the store" 0
check "info reports 6000 x 6000" grep -q "^image  *6000 x 6000, RGB" "$T/out"
run export "$dir/out.gv" --region 5900,5900,100,100 -o "$T/corner.png"
expect_rc "the last tile decodes" 0
check "only the store is in the directory" test "$(listing "$dir")" = out.gv
rm -f "$T/corner.png"

# Killing a re-encode over the store leaves the old one untouched.
cp "$dir/out.gv" "$T/copy.gv"
for frac in 0.01 0.08 0.22; do
    secs=$(at "$frac")
    kill_at "$secs" KILL "$big" -o "$dir/out.gv"
    check "SIGKILL of a re-encode after ${secs}s: killed" test "$status" -eq 137
    check "SIGKILL of a re-encode after ${secs}s: old store byte-identical" \
        cmp -s "$dir/out.gv" "$T/copy.gv"
    check "SIGKILL of a re-encode after ${secs}s: nothing else in the directory" \
        test "$(listing "$dir")" = out.gv
done

done_testing
