#!/bin/sh
# corpus-store-meta.sh - replays the fuzz_store_meta seed corpus
# (tests/fuzz/corpus/store_meta) through run_fuzz_store_meta, the
# libFuzzer target built with a plain main() (run_corpus.c).  TAP; under
# valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_store_meta" \
    "$srcdir/tests/fuzz/corpus/store_meta"
