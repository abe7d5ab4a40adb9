#!/bin/sh
# fault_disk_full.sh - the disk fills during an encode: a clear error and
# no partial output.
#
# cli_bad_input.sh simulates a full disk with a file size limit (ulimit
# -f: EFBIG).  This test fills real file systems: small tmpfs mounts
# (so it needs root, or it is skipped), where write(2) fails with ENOSPC
# part-way through.  Cases:
#  - the store does not fit where it goes (scratch elsewhere);
#  - the scratch file does not fit (--tmpdir on the small mount);
#  - neither has room (no --tmpdir: the scratch file lives beside the
#    output);
#  - a shard's scratch file does not fit (level 0 written by another
#    thread than a whole encode's);
#  - a good store already at the output path, and no room for the new
#    one: the old store is untouched;
#  - another process fills the disk while the encode runs (a writer
#    started at a random moment takes every free block).
# Every failure must exit 1 with "No space left on device" (the
# system's words, so an operator recognises them) naming the file
# system's path, leave no file behind, and give back every block it took
# (the mount's used space returns to what it was: the store and the
# scratch are unnamed O_TMPFILE files, freed when the process exits).
. "$(dirname "$0")/lib.sh"

if [ "$(id -u)" != 0 ]; then
    echo "1..0 # SKIP mounting a small tmpfs needs root"
    exit 0
fi
M="$T/mnt"
mkdir "$M" "$T/elsewhere" || bail "mkdir"
if ! mount -t tmpfs -o size=1m tmpfs "$M" 2>"$T/mount.err"; then
    echo "1..0 # SKIP cannot mount a tmpfs here: $(cat "$T/mount.err")"
    exit 0
fi
umount "$M"
mounted=
fault_cleanup() {
    [ -n "$mounted" ] && umount "$M" 2>/dev/null
    cleanup
}
trap fault_cleanup EXIT

# with_mount SIZE: a fresh, empty tmpfs of SIZE at $M.
with_mount() {
    [ -n "$mounted" ] && umount "$M"
    mount -t tmpfs -o "size=$1" tmpfs "$M" || bail "mount tmpfs size=$1"
    mounted=1
}
used_kb() {
    df -k --output=used "$M" | tail -n 1 | tr -d ' '
}

# A 3000x3000 store is about 0.5 to 1.1 MB (at -r 3 -q 32); its scratch file is
# about 2 x 3 bytes per pixel, 54 MB.
img=synth:3000x3000
args="-r 3 -q 32 --quiet"
t0=$(date +%s.%N)
run encode $img $args -o "$T/ref.gv"
t1=$(date +%s.%N)
[ "$rc" -eq 0 ] || bail "reference encode: $(cat "$T/err")"
ref_s=$(echo "$t0 $t1" | awk '{ printf "%.3f", $2 - $1 }')
diag "the store is $(wc -c <"$T/ref.gv" | tr -d ' ') bytes, encoded in ${ref_s}s"

# The two messages of a full disk: the store or the scratch file.
no_space_store="gigaview encode: store: writing $M/x.gv: No space left on device"
no_space_spill="gigaview encode: spill: writing the scratch file in $M: No space left on device"

# full_case DESCRIPTION WANT...: after a run that should have failed for
# lack of space on $M: exit 1, stderr exactly one of the WANTs (where
# store pages and scratch writes interleave, either may be the write that
# finds the disk full), nothing left, every block given back.
full_case() {
    desc=$1
    shift
    expect_rc "$desc" 1
    got=$(cat "$T/err")
    matched=
    for want in "$@"; do
        [ "$got" = "$want" ] && matched=1
    done
    if [ -n "$matched" ]; then
        ok "$desc: says which file found no space left on device"
    else
        not_ok "$desc: says which file found no space left on device" "stderr:" "$got" \
            "wanted one of:" "$@"
    fi
    left=$(listing "$M")
    if [ -z "$left" ]; then ok "$1: nothing left on the full file system"; else
        not_ok "$1: left behind" "$left"; fi
    check "$1: every block given back (used $(used_kb) KiB)" test "$(used_kb)" -eq 0
    check "$1: nothing left in the other directory" test -z "$(listing "$T/elsewhere")"
}

# Half the store's measured size, so that no codec change makes it fit.
half_kb=$(( ($(wc -c <"$T/ref.gv") + 1023) / 2048 ))
with_mount "${half_kb}k"
run encode $img $args --tmpdir "$T/elsewhere" -o "$M/x.gv"
full_case "the store does not fit (${half_kb} KiB)" "$no_space_store"

with_mount 8m
run encode $img $args --tmpdir "$M" -o "$T/elsewhere/x.gv"
full_case "the scratch file does not fit (8 MiB --tmpdir)" "$no_space_spill"
check "no store where the output was going" test ! -e "$T/elsewhere/x.gv"

with_mount 8m
run encode $img $args -o "$M/x.gv"
full_case "neither fits (8 MiB, scratch beside the output)" "$no_space_spill" \
    "$no_space_store"

# A shard's scratch file is sized at the start, a hole that takes no
# blocks; its level-0 rows are then written by the encoder's thread (a
# whole encode's by pass 1's reading thread), so the full disk is found
# in another place than above.
with_mount 8m
run encode $img $args --shard 0/2 --tmpdir "$M" -o "$T/elsewhere/x.gvshard"
full_case "a shard's scratch file does not fit (8 MiB --tmpdir)" "$no_space_spill"

# Room for the old store but not for a second, larger one: the mount holds
# the old store and half of the new one (both sizes measured, so no codec
# change can make the new store fit).
run encode synth:4000x4000 $args -o "$T/big.gv"
[ "$rc" -eq 0 ] || bail "larger encode: $(cat "$T/err")"
old_kb=$(( ($(wc -c <"$T/ref.gv") + 1023) / 1024 ))
big_kb=$(( ($(wc -c <"$T/big.gv") + 1023) / 1024 ))
rm -f "$T/big.gv"
with_mount "$((old_kb + big_kb / 2 + 64))k"
cp "$T/ref.gv" "$M/x.gv"
before=$(used_kb)
run encode synth:4000x4000 $args --tmpdir "$T/elsewhere" -o "$M/x.gv"
expect_rc "no room for the new store over an old one" 1
expect_err_is "over an old one: says the store found no space left on device" "$no_space_store"
check "over an old one: the old store is byte-identical" cmp -s "$M/x.gv" "$T/ref.gv"
check "over an old one: only the old store is there" test "$(listing "$M")" = x.gv
check "over an old one: used space as before ($before KiB)" test "$(used_kb)" -eq "$before"
run info "$M/x.gv"
expect_rc "over an old one: the old store still opens" 0

# Another process fills the disk during the encode.  The mount has room
# for everything (scratch 54 MB + store) with 40 MB to spare; after a
# random delay inside the encode, dd takes every free block.  Five runs;
# each must either fail cleanly for lack of space or, if it finished
# before dd got going, have written the whole store.  The delays fall in
# the first 5 to 60 % of the reference encode's time (fixed delays of
# 0.1 to 0.9 s missed most of a faster encoder's run), and the encode is
# stopped (SIGSTOP) while dd fills the disk, so that it cannot outrun dd
# however the machine's load shares the two.
seed=${GV_FAULT_SEED:-$(date +%s)}
diag "filler delays seed $seed"
delays=$(awk -v s="$seed" -v d="$ref_s" 'BEGIN { srand(s); for (i = 0; i < 5; i++) printf "%.3f\n", d * (0.05 + rand() * 0.55) }')
failed=0
for delay in $delays; do
    with_mount 96m
    "$GIGAVIEW" encode $img $args -o "$M/x.gv" >"$T/out" 2>"$T/err" &
    pid=$!
    sleep "$delay"
    kill -STOP "$pid" 2>/dev/null
    dd if=/dev/zero of="$M/fill" bs=1M 2>/dev/null
    kill -CONT "$pid" 2>/dev/null
    rc=0
    wait "$pid" || rc=$?
    rm -f "$M/fill"
    if [ "$rc" -eq 0 ]; then
        check "filled after ${delay}s: finished first, the store is identical" \
            cmp -s "$M/x.gv" "$T/ref.gv"
        rm -f "$M/x.gv"
        check "filled after ${delay}s: nothing else left, every block back" \
            sh -c "test -z '$(listing "$M")' && test '$(used_kb)' -eq 0"
    else
        failed=$((failed + 1))
        full_case "filled by another process after ${delay}s" "$no_space_spill" \
            "$no_space_store"
    fi
done
diag "$failed of 5 encodes hit the full disk"
check "at least one encode hit the disk filling up under it" test "$failed" -ge 1

done_testing
