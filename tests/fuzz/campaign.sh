#!/bin/sh
# campaign.sh - runs the libFuzzer targets for a while and reports.
#
#   tests/fuzz/campaign.sh BUILDDIR [SECONDS-PER-TARGET] [JOBS]
#
# FUZZ_TARGETS picks targets (default: store tile iiif router filter_graph
# worker settings batch imageio batch_frames listen_fds terrain_ext mesh_read, and
# view_script when BUILDDIR has SDL2, the native viewer's).
# BUILDDIR was configured with --enable-fuzzing CC=clang CXX=clang++ (the
# targets are built here if needed).  Each target starts from a copy of
# its seed corpus (tests/fuzz/corpus/*, left untouched) in a work
# directory, runs for SECONDS (default 60), and the script prints the
# executions done, the corpus growth and any findings (crash-*, leak-*,
# timeout-*, oom-* files, kept in the work directory with the logs).
# Add a finding to tests/fuzz/corpus/<target>/ once it is fixed, so that
# `make check` replays it forever.  Exit 1 when something was found.
#
# VALGRIND_REPLAY=PLAINBUILD (a build without sanitizers, with the
# run_fuzz_* programs built) also replays each grown corpus through
# PLAINBUILD/tests/fuzz/run_fuzz_TARGET under valgrind: the libraries the
# targets call (OpenImageIO and its readers, jansson) are not
# instrumented, so AddressSanitizer misses a stray write inside them that
# does not crash, and valgrind sees it.  Its errors count as findings
# (the log names the input: run_corpus prints each file's name first).
# BUILDDIR and PLAINBUILD may be relative (to the current directory).
# Exit 2 when a target could not be built or ran no input at all (the
# log's last lines are printed): a campaign that fuzzed nothing fails.
set -u
build=${1:?usage: campaign.sh BUILDDIR [SECONDS] [JOBS]}
# Absolute: the targets run from their findings directory.
build=$(cd "$build" 2>/dev/null && pwd) ||
    { echo "campaign: no build directory $1" >&2; exit 2; }
if [ -n "${VALGRIND_REPLAY:-}" ]; then
    VALGRIND_REPLAY=$(cd "$VALGRIND_REPLAY" 2>/dev/null && pwd) ||
        { echo "campaign: no build directory $VALGRIND_REPLAY" >&2; exit 2; }
fi
secs=${2:-60}
jobs=${3:-1}
here=$(cd "$(dirname "$0")" && pwd)
work=${FUZZ_WORK:-$(mktemp -d "${TMPDIR:-/tmp}/gvfuzz.XXXXXX")}
targets=${FUZZ_TARGETS:-store tile iiif router filter_graph worker settings batch imageio batch_frames listen_fds terrain_ext mesh_read}
if [ -z "${FUZZ_TARGETS:-}" ] && grep -q '^#define GV_HAVE_SDL2 1' "$build/config.h" 2>/dev/null; then
    targets="$targets view_script"
fi
make -C "$build" $(for t in $targets; do printf 'tests/fuzz/fuzz_%s ' "$t"; done) >/dev/null ||
    { echo "campaign: cannot build the fuzz targets in $build" >&2; exit 2; }
found=0
idle=0
for t in $targets; do
    mkdir -p "$work/$t/corpus" "$work/$t/findings"
    cp "$here/corpus/$t/"* "$work/$t/corpus/"
    before=$(ls "$work/$t/corpus" | wc -l)
    dict=
    [ -f "$here/$t.dict" ] && dict="-dict=$here/$t.dict"
    # -rss_limit_mb: a store claiming a huge image must not make us
    # allocate for it.  -timeout: one input must never take seconds.
    (cd "$work/$t/findings" &&
        "$build/tests/fuzz/fuzz_$t" $dict -max_total_time="$secs" \
            -max_len=1048576 -rss_limit_mb=2048 -timeout=10 \
            -jobs="$jobs" -workers="$jobs" -print_final_stats=1 \
            "$work/$t/corpus" >"$work/$t/log" 2>&1)
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$t/log" |
        awk '{ s += $1 } END { print s + 0 }')
    speed=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$work/$t/log" | tail -n 1)
    after=$(ls "$work/$t/corpus" | wc -l)
    findings=$(ls "$work/$t/findings" | grep -E '^(crash|leak|timeout|oom|slow-unit)-' || true)
    echo "fuzz_$t: ${secs}s, $execs executions (${speed:-?}/s), corpus $before -> $after"
    if [ "$execs" -eq 0 ]; then
        idle=1
        echo "  NOTHING RAN: $work/$t/log ends:"
        tail -n 5 "$work/$t/log" | sed 's/^/    /'
    fi
    if [ -n "$findings" ]; then
        found=1
        for f in $findings; do
            echo "  FINDING $work/$t/findings/$f"
        done
        grep -E '^(==[0-9]+==ERROR|SUMMARY|.*runtime error)' "$work/$t/log" | head -n 5 |
            sed 's/^/    /'
    fi
    if [ -n "${VALGRIND_REPLAY:-}" ]; then
        make -C "$VALGRIND_REPLAY" "tests/fuzz/run_fuzz_$t" >/dev/null 2>&1 ||
            { echo "campaign: cannot build run_fuzz_$t in $VALGRIND_REPLAY" >&2; exit 2; }
        if valgrind -q --error-exitcode=99 --leak-check=full \
            --errors-for-leak-kinds=definite --show-leak-kinds=definite \
            "$VALGRIND_REPLAY/tests/fuzz/run_fuzz_$t" "$work/$t/corpus" \
            >"$work/$t/valgrind.log" 2>&1; then
            echo "  valgrind replay of $after inputs: clean"
        else
            found=1
            echo "  FINDING valgrind replay: $work/$t/valgrind.log"
            grep -m 1 -B 30 '^==[0-9]*== [A-Z]' "$work/$t/valgrind.log" |
                grep '^# ' | tail -n 1 | sed 's/^# /    input /'
            grep -m 3 '^==[0-9]*== [A-Z]' "$work/$t/valgrind.log" | sed 's/^/    /'
        fi
    fi
done
echo "logs and corpora in $work"
[ "$idle" -eq 0 ] || exit 2
exit $found
