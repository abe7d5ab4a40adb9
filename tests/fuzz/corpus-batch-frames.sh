#!/bin/sh
# corpus-batch-frames.sh - replays the fuzz_batch_frames seed corpus
# (tests/fuzz/corpus/batch_frames) through run_fuzz_batch_frames, the
# libFuzzer target built with a plain main() (run_corpus.c).  TAP; under
# valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_batch_frames" \
    "$srcdir/tests/fuzz/corpus/batch_frames"
