#!/bin/sh
# corpus-tile.sh - replays the fuzz_tile seed corpus (tests/fuzz/corpus/tile)
# through run_fuzz_tile, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_tile" \
    "$srcdir/tests/fuzz/corpus/tile"
