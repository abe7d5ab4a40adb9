#!/bin/sh
# corpus-access-token.sh - replays the fuzz_access_token seed corpus (tests/fuzz/corpus/access_token)
# through run_fuzz_access_token, the libFuzzer target built with a plain main()
# (run_corpus.c).  TAP; under valgrind with make check VALGRIND=1.
srcdir=${top_srcdir:-$(dirname "$0")/../..}
builddir=${top_builddir:-.}
exec sh "$srcdir/tests/run-test.sh" "$builddir/tests/fuzz/run_fuzz_access_token" \
    "$srcdir/tests/fuzz/corpus/access_token"
