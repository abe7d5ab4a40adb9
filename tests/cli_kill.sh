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

# kill_at PERCENT SIGNAL ARGS...: start `gigaview encode ARGS --progress`
# in the background, send SIGNAL once its progress line reaches PERCENT
# (or it has ended) and reap it; sets $status.  Kills land at points of
# the work, not of the clock, so a loaded or a fast machine only moves
# them in time (fixed delays once landed after a faster encoder's end).
# The pyramid is built up to about 15 %, pages are encoded from there.
kill_at() {
    pct=$1 sig=$2
    shift 2
    "$GIGAVIEW" encode "$@" --progress >"$T/out" 2>"$T/err" &
    kill_at_progress $! "$T/err" "$pct" "$sig"
}

for pct in 1 4 8 12 20 35; do
    kill_at "$pct" KILL "$big" --tmpdir "$scratch" -o "$dir/out.gv"
    if [ "$status" -eq 137 ]; then ok "SIGKILL at ${pct} %: killed"; else
        not_ok "SIGKILL at ${pct} %: exit $status, not killed (too fast?)"; fi
    check "SIGKILL at ${pct} %: no store" test ! -e "$dir/out.gv"
    left=$(listing "$dir")
    if [ -z "$left" ]; then ok "SIGKILL at ${pct} %: output directory empty"; else
        not_ok "SIGKILL at ${pct} %: left in the output directory" "$left"; fi
    check "SIGKILL at ${pct} %: scratch directory empty" test -z "$(listing "$scratch")"
done
# Without --tmpdir the scratch file lives beside the output.
kill_at 12 KILL "$big" -o "$dir/out.gv"
check "SIGKILL without --tmpdir: killed" test "$status" -eq 137
check "SIGKILL without --tmpdir: output directory empty" test -z "$(listing "$dir")"
# SIGTERM has no handler: same outcome.  (SIGINT cannot be tested this
# way: a non-interactive shell starts background jobs with it ignored.)
for sig in TERM; do
    kill_at 10 "$sig" "$big" -o "$dir/out.gv"
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
for pct in 1 8 25; do
    kill_at "$pct" KILL "$big" -o "$dir/out.gv"
    check "SIGKILL of a re-encode at ${pct} %: killed" test "$status" -eq 137
    check "SIGKILL of a re-encode at ${pct} %: old store byte-identical" \
        cmp -s "$dir/out.gv" "$T/copy.gv"
    check "SIGKILL of a re-encode at ${pct} %: nothing else in the directory" \
        test "$(listing "$dir")" = out.gv
done

done_testing
