#!/bin/sh
# corpus-view-link.sh - replays the fuzz_view_link seed corpus
# (tests/fuzz/corpus/view_link) through run_fuzz_view_link, the libFuzzer
# target built with a plain main() (run_corpus.c).  TAP; under valgrind
# with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_view_link" \
    "$srcdir/tests/fuzz/corpus/view_link"
