#!/bin/sh
# corpus-mesh-read.sh - replays the fuzz_mesh_read seed corpus
# (tests/fuzz/corpus/mesh_read) through run_fuzz_mesh_read, the libFuzzer
# target built with a plain main() (run_corpus.c).  TAP; under valgrind
# with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_mesh_read" \
    "$srcdir/tests/fuzz/corpus/mesh_read"
