#!/bin/sh
# corpus-worker.sh - replays the fuzz_worker seed corpus
# (tests/fuzz/corpus/worker: frames of the filter job protocol) through
# run_fuzz_worker, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_worker" \
    "$srcdir/tests/fuzz/corpus/worker"
