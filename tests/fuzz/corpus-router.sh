#!/bin/sh
# corpus-router.sh - replays the fuzz_router seed corpus
# (tests/fuzz/corpus/router) through run_fuzz_router, the libFuzzer target
# built with a plain main() (run_corpus.c).  TAP; under valgrind with make
# check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_router" \
    "$srcdir/tests/fuzz/corpus/router"
