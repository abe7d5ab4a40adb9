#!/bin/sh
# corpus-batch.sh - replays the fuzz_batch seed corpus (tests/fuzz/corpus/batch)
# through run_fuzz_batch, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_batch" \
    "$srcdir/tests/fuzz/corpus/batch"
