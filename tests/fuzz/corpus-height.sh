#!/bin/sh
# corpus-height.sh - replays the fuzz_height seed corpus
# (tests/fuzz/corpus/height) through run_fuzz_height, the libFuzzer target
# built with a plain main() (run_corpus.c).  TAP; under valgrind with make
# check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_height" \
    "$srcdir/tests/fuzz/corpus/height"
