#!/bin/sh
# corpus-listen-fds.sh - replays the fuzz_listen_fds seed corpus
# (tests/fuzz/corpus/listen_fds) through run_fuzz_listen_fds, the
# libFuzzer target built with a plain main() (run_corpus.c).  TAP; under
# valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_listen_fds" \
    "$srcdir/tests/fuzz/corpus/listen_fds"
