#!/bin/sh
# corpus-iiif.sh - replays the fuzz_iiif seed corpus (tests/fuzz/corpus/iiif)
# through run_fuzz_iiif, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_iiif" \
    "$srcdir/tests/fuzz/corpus/iiif"
