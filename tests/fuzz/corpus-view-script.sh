#!/bin/sh
# corpus-view-script.sh - replays the fuzz_view_script seed corpus
# (tests/fuzz/corpus/view_script) through run_fuzz_view_script, the
# libFuzzer target built with a plain main() (run_corpus.c).  TAP; under
# valgrind with make check VALGRIND=1.  Skipped in a build without SDL2
# (no native viewer, so no script parser).
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
if [ ! -x "$builddir/tests/fuzz/run_fuzz_view_script" ]; then
    echo "1..0 # SKIP no run_fuzz_view_script: this build has no SDL2 (gigaview view)"
    exit 0
fi
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_view_script" \
    "$srcdir/tests/fuzz/corpus/view_script"
