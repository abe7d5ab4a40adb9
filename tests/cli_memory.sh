#!/bin/sh
# cli_memory.sh - the encoder's peak memory is bounded and does not grow
# with the image's area.
#
# Encodes synth:8200x4096 and synth:8200x16384 (same width, 4x the area)
# with 2 threads and measures peak RSS with /usr/bin/time -f %M.  The
# heights are at least one page (4096 rows) so that the smaller run
# already touches the whole page window.  8200 is wider than two pages
# at level 1 too, so that neither run keeps level 1's decoded tiles in
# memory instead of the scratch file (an image up to 8194 pixels square
# does: less memory, but not what grows with the area).
#
# The bound, from docs/FORMAT.md section 9 (C = 3 channels, T = 2 threads,
# W = 8200, rate cap 4):
#   window of a page      4097^2 * 3            = 50.4 MB
#   16 parent tiles       16 * 513^2 * 3        = 12.6 MB
#   64 decoded tiles      64 * 513^2 * 3        = 50.5 MB
#   64 tile buffers       64 * (1 + 16*12 + 257^2*4/8) =  2.1 MB
#   per thread            2 * ~7 MiB            = 14.7 MB
#   input rows            16 MiB (+ 4 MiB in the source)  = 21.0 MB
#   pyramid rows          4 * W * C             =  0.1 MB
#   root and its mips     2 * 512^2 * 3 * 4/3   =  2.1 MB
#                                         total ~ 154 MB = 147 MiB
# on top of what the process costs before it opens anything (OpenImageIO
# and its ~250 shared libraries: ~125 MiB resident), which is measured
# here with `gigaview --version`.  Assert: peak <= baseline + 147 MiB +
# 15% slack, and below 400 MiB absolute; the 4x-area run within +15% or
# +30 MiB of the smaller one.
#
# Skipped without /usr/bin/time (Debian package `time`), under valgrind
# and in sanitizer builds.
. "$(dirname "$0")/lib.sh"

peak_rss_preflight

base=$(peak_kib --version)
diag "baseline (gigaview --version): $((base / 1024)) MiB"

work_kib=$((147 * 1024))
bound=$(( (base + work_kib) * 115 / 100 ))
absolute=$((400 * 1024))

start=$(date +%s)
small=$(peak_kib encode synth:8200x4096 -r 4 -q 30 -j 2 --quiet -o "$T/a.gv")
large=$(peak_kib encode synth:8200x16384 -r 4 -q 30 -j 2 --quiet -o "$T/b.gv")
diag "peak RSS: 8200x4096 $((small / 1024)) MiB, 8200x16384 $((large / 1024)) MiB" \
    "(bound $((bound / 1024)) MiB) in $(( $(date +%s) - start )) s"

for pair in "8200x4096 $small" "8200x16384 $large"; do
    set -- $pair
    if [ "$2" -le "$bound" ] && [ "$2" -le "$absolute" ]; then
        ok "$1: peak $(($2 / 1024)) MiB <= $((bound / 1024)) MiB and 400 MiB"
    else
        not_ok "$1: peak $(($2 / 1024)) MiB exceeds $((bound / 1024)) MiB or 400 MiB"
    fi
done
growth_ok=$(( large <= small * 115 / 100 || large <= small + 30 * 1024 ))
if [ "$growth_ok" -eq 1 ]; then
    ok "4x the area: peak grows by $(( (large - small) / 1024 )) MiB (<= 15% or 30 MiB)"
else
    not_ok "4x the area: peak grows from $((small / 1024)) to $((large / 1024)) MiB"
fi
check "both stores were written" test -s "$T/a.gv" -a -s "$T/b.gv"

done_testing
