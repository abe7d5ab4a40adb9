#!/bin/sh
# corpus-window.sh - replays the fuzz_window seed corpus (tests/fuzz/corpus/window)
# through run_fuzz_window, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_window" \
    "$srcdir/tests/fuzz/corpus/window"
