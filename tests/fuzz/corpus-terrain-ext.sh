#!/bin/sh
# corpus-terrain-ext.sh - replays the fuzz_terrain_ext seed corpus
# (tests/fuzz/corpus/terrain_ext) through run_fuzz_terrain_ext, the
# libFuzzer target built with a plain main() (run_corpus.c).  TAP; under
# valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_terrain_ext" \
    "$srcdir/tests/fuzz/corpus/terrain_ext"
