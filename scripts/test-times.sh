#!/bin/sh
# test-times.sh BUILDDIR [N] - how long each test of the last `make check`
# in BUILDDIR took, the N slowest first (default 15), then the test
# phase's wall time and the sum of the tests' times (with make -j2 the
# wall time is about half the sum: shortening any test shortens CI).
#
# A test's time is from its .log file's birth (the test driver creates it
# as the test starts) to its .trs file's last change (written as it ends),
# so it needs a file system that records birth times (ext4, xfs, btrfs);
# where stat prints none (0 or '-'), it says so and exits 1.
set -eu
dir=${1:?usage: test-times.sh BUILDDIR [N]}
n=${2:-15}
cd "$dir"
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
find . -name '*.trs' | while read -r t; do
    l=${t%.trs}.log
    [ -f "$l" ] || continue
    echo "$(stat -c %.3W "$l") $(stat -c %.3Y "$t") ${t%.trs}"
done >"$tmp"
if awk '$1 + 0 == 0 { bad = 1 } END { exit !bad }' "$tmp"; then
    echo "test-times: no file birth times on this file system" >&2
    exit 1
fi
awk '{ printf "%8.1f s  %s\n", $2 - $1, substr($3, 3) }' "$tmp" | sort -rn | head -n "$n"
awk '{ if (s == "" || $1 < s) s = $1; if ($2 > e) e = $2; sum += $2 - $1 }
     END { printf "%d tests, wall %.1f s, sum %.1f s\n", NR, e - s, sum }' "$tmp"
